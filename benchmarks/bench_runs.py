"""Throughput of the run machinery: 8 samples with 1 and with 2 local worker processes.

Runs the same 8-sample study twice (fresh run directories) through :func:`jamlab.runs.run_study`
— worker start-up, seeding, transport and atomic HDF5 writes included — and prints the wall times
and the speed-up ``t(1 worker) / t(2 workers)`` (ideal: 2 on two free cores). Asserts nothing.
Run: ``.venv/bin/python benchmarks/bench_runs.py [--task aqs|toy] [--n 64] [--phi 0.8]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from jamlab.runs import Execution, Study, run_study


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="aqs", choices=["aqs", "toy"])
    parser.add_argument("--n", type=int, default=64, help="particles per sample")
    parser.add_argument("--phi", default="0.8", help="packing fraction or 'jamming'")
    parser.add_argument("--dgamma", type=float, default=1e-4)
    parser.add_argument("--gamma-max", type=float, default=4e-3)
    args = parser.parse_args()
    study = Study(
        phi=[args.phi], n=[args.n], samples=8, dgamma=args.dgamma, gamma_max=args.gamma_max,
        seed=0, task=args.task,
    )  # fmt: skip
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in (1, 2):
            start = time.perf_counter()
            summary = run_study(study, Path(tmp) / f"w{workers}", Execution(workers=workers))
            times[workers] = time.perf_counter() - start
            print(
                f"workers={workers}: {times[workers]:7.2f} s for {summary.done} samples "
                f"({summary.failed} failed)"
            )
    print(
        f"task={args.task} N={args.n} phi={args.phi} steps={round(args.gamma_max / args.dgamma)}: "
        f"speed-up 2 workers / 1 worker = {times[1] / times[2]:.2f}"
    )


if __name__ == "__main__":
    main()
