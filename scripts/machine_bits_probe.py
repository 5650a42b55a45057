"""Which part of the machine decides a sample's bits: the first steps of a run's sample computed
again on this machine, once as it is and once under each of the environment variables that make
a library choose other code for the same CPU, each compared row by row with the sample as stored.

The same study on two CPUs gave other trajectories (docs/reproduce.md, "p = 1e-6, N = 500 under
the new rule on another machine"); ``jamlab.provenance`` records the parts thought to choose their
arithmetic per CPU. This probe tests them one at a time, each on top of the run workers'
environment (one BLAS thread, ``as-run``):

- ``blas-all-cores``: BLAS with its default threads (all cores), as in a shell;
- ``numpy-no-avx512``: ``NPY_DISABLE_CPU_FEATURES`` turns off numpy's AVX-512 loops (its sums,
  norms and dot products then run on AVX2, as on a CPU without AVX-512);
- ``openblas-haswell``: ``OPENBLAS_CORETYPE=Haswell``, OpenBLAS's AVX2 kernels (numpy's BLAS and
  the one cvxopt's CHOLMOD calls, when it is OpenBLAS);
- ``numba-haswell``: ``NUMBA_CPU_NAME=haswell``, numba's kernels compiled for an AVX2 CPU (they
  are compiled again: a minute or two).

Each variant runs in its own process: the sample's study shortened to ``--steps`` steps (same
seed, packing and save points), its trace compared with the stored sample's first rows: the
first row where any column differs, and the FIRE iterations. Prints one line per variant.

    PYTHONPATH=src python scripts/machine_bits_probe.py data/runs/n500-p1e-6-vg --index 0 \\
        --steps 100
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from jamlab.runs.execute import SINGLE_THREAD_ENV

VARIANTS = {
    "as-run": {},
    "blas-all-cores": {name: "" for name in SINGLE_THREAD_ENV},
    "numpy-no-avx512": {"NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR"},
    "openblas-haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "numba-haswell": {"NUMBA_CPU_NAME": "haswell"},
}
"""Each variant's environment, on top of the run workers' (``SINGLE_THREAD_ENV``: one BLAS
thread); an empty value removes the variable (``blas-all-cores``: BLAS's default threads, as a
``jamlab shear`` in a shell has)."""
COLUMNS = ("energy", "pressure", "shear_stress", "max_force", "plastic", "jammed", "z", "z_nr",
           "phi", "energy_jump", "stress_jump")
"""The columns compared bit for bit. Not ``iterations``: at fixed pressure the work of
re-confirming a candidate step is charged to its row, and which candidates are re-confirmed
depends on the run's plastic threshold, measured on the whole run (a shortened run charges
other rows; measured: 7 of sample 0's first 100 rows, every physical column the same bits)."""


def child(run: Path, index: int, steps: int, out: Path) -> None:
    """Compute the sample's first ``steps`` steps here and save its trace (``out``, npz)."""
    from jamlab.provenance import machine
    from jamlab.runs import RunDir, sample_seed
    from jamlab.runs.physics import prepare_and_shear

    study = RunDir(run).study()
    key = [k for k in study.keys() if k.index == index][0]
    short = replace(study, gamma_max=steps * study.dgamma)
    t0 = time.process_time()
    with tempfile.TemporaryDirectory() as folder:
        result = prepare_and_shear(short, key, sample_seed(study.seed, key), Path(folder) / "ck")
    np.savez(out, seconds=time.process_time() - t0, machine=json.dumps(machine()),
             **{name: np.asarray(v) for name, v in result.traces.items()})


def stored_trace(run: Path, index: int) -> dict[str, np.ndarray]:
    from jamlab.runs import RunDir, read_sample

    rd = RunDir(run)
    study = rd.study()
    key = [k for k in study.keys() if k.index == index][0]
    return read_sample(rd.sample_path(key))["trace"]


def first_difference(a: dict, b: dict, rows: int) -> tuple[int | None, str]:
    """The first row (and its columns) where the two traces differ in any bit, or None."""
    for row in range(rows):
        cols = [c for c in COLUMNS if c in a and c in b
                and np.asarray(a[c][row]).tobytes() != np.asarray(b[c][row]).tobytes()]
        if cols:
            return row, ",".join(cols)
    return None, ""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="run directory with the finished sample")
    ap.add_argument("--index", type=int, default=0)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        child(args.run, args.index, args.steps, args.child)
        return
    stored = stored_trace(args.run, args.index)
    rows = args.steps + 1
    print(f"{args.run} sample {args.index}: first {args.steps} steps against the stored sample "
          f"(its FIRE iterations there: {int(np.sum(stored['iterations'][:rows])):,})")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.variants:
            out = Path(tmp) / f"{name}.npz"
            env = {**os.environ, **SINGLE_THREAD_ENV, **VARIANTS[name]}
            env = {k: v for k, v in env.items() if v != ""}
            cmd = [sys.executable, __file__, str(args.run), "--index", str(args.index),
                   "--steps", str(args.steps), "--child", str(out)]
            t = time.perf_counter()
            done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                print(f"{name:18s} failed: {done.stderr.strip().splitlines()[-1:]}")
                continue
            with np.load(out) as z:
                mine = {k: z[k] for k in z.files}
            record = json.loads(str(mine.pop("machine")))
            row, cols = first_difference(stored, mine, rows)
            iters = int(np.sum(mine["iterations"][:rows]))
            n_iter = int(np.sum(mine["iterations"][:rows] != stored["iterations"][:rows]))
            where = "bit for bit" if row is None else f"first differs at row {row} ({cols})"
            plastic = int(np.sum(mine["plastic"][:rows]))
            print(f"{name:18s} {where}; FIRE iterations {iters:,} ({n_iter} rows differ); "
                  f"plastic {plastic}; "
                  f"numpy SIMD {record['numpy_simd']}, LLVM CPU {record['llvm_cpu']}; "
                  f"{float(mine['seconds']):.0f} CPU s ({time.perf_counter() - t:.0f} s wall)")


if __name__ == "__main__":
    main()
