"""Throughput of the run machinery: 8 samples with 1 and with 2 local worker processes.

Runs the same 8-sample study twice (fresh run directories) through :func:`jamlab.runs.run_study`
— worker start-up, seeding, transport and atomic HDF5 writes included — and prints the wall times
and the speed-up ``t(1 worker) / t(2 workers)`` (ideal: 2 on two free cores). Asserts nothing.
Run: ``.venv/bin/python benchmarks/bench_runs.py [--task aqs|toy|random-shear] [--n 64]``.

``random-shear`` (the default while ``jamlab.spheres.packing.prepare`` is not available) shears a
uniformly random packing at φ, which ``shear`` first minimises with FIRE: the same CPU-bound kind
of work as a real UNSAT sample, for measuring the parallel speed-up only.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from jamlab.runs import Execution, SampleResult, Study, open_run, run_study
from jamlab.runs.tasks import TRACE_FIELDS


def random_shear(study, key, seed):  # noqa: ANN001 - a Task
    """Shear a random packing (FIRE-minimised by ``shear`` first); benchmark only."""
    import numpy as np

    from jamlab.spheres import aqs, random_packing

    packing = random_packing(key.n, study.dim, float(key.phi), seed)
    trace = aqs.shear(packing, study.dgamma, study.gamma_max).trace
    return SampleResult({f: np.asarray(getattr(trace, f)) for f in TRACE_FIELDS})


def _have_prepare() -> bool:
    try:
        from jamlab.spheres import packing
    except ImportError:
        return False
    return hasattr(packing, "prepare") and hasattr(packing, "jam")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default=None, choices=["aqs", "toy", "random-shear"])
    parser.add_argument("--n", type=int, default=256, help="particles per sample")
    parser.add_argument("--phi", default="0.8", help="packing fraction or 'jamming'")
    parser.add_argument("--dgamma", type=float, default=1e-4)
    parser.add_argument("--gamma-max", type=float, default=2e-2)
    args = parser.parse_args()
    if args.task is None:
        args.task = "aqs" if _have_prepare() else "random-shear"
    task = random_shear if args.task == "random-shear" else None
    study = Study(
        phi=[args.phi], n=[args.n], samples=8, dgamma=args.dgamma, gamma_max=args.gamma_max,
        seed=0, task="toy" if args.task == "toy" else "aqs",
    )  # fmt: skip
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in (1, 2):
            start = time.perf_counter()
            summary = run_study(
                study, Path(tmp) / f"w{workers}", Execution(workers=workers), task=task
            )
            times[workers] = time.perf_counter() - start
            busy = open_run(Path(tmp) / f"w{workers}", fields=("gamma",)).seconds.sum().item()
            print(
                f"workers={workers}: {times[workers]:7.2f} s for {summary.done} samples "
                f"({summary.failed} failed); summed sample time {busy:.2f} s, "
                f"occupancy {busy / times[workers]:.2f} (start-up and writes are the rest)"
            )
    print(
        f"task={args.task} N={args.n} phi={args.phi} steps={round(args.gamma_max / args.dgamma)}: "
        f"speed-up 2 workers / 1 worker = {times[1] / times[2]:.2f}"
    )


if __name__ == "__main__":
    main()
