"""AQS traces under one source tree, saved and compared with those of another (refactor check).

Runs a fixed list of AQS cases with whichever ``jamlab`` is importable (or with ``--src TREE``,
in a subprocess with ``PYTHONPATH=TREE``) and saves each trace (every column, the step counters,
the final positions) to ``OUT/<case>.npz``; ``compare A B`` prints, per case and column, the
largest relative difference and whether the two are bit-identical. Used for the AQS package
split (issue 14) against the pre-refactor commit, and reusable after any change that must not
change a trace:

    python scripts/refactor_trace_check.py run --src /work/wt-base/src --out /tmp/traces-base
    python scripts/refactor_trace_check.py run --src src --out /tmp/traces-new
    python scripts/refactor_trace_check.py compare /tmp/traces-base /tmp/traces-new

Cases: the shared LAMMPS reference starts (N = 1000 and N = 500, φ = 0.8; fast path, and plain
FIRE with classification), ``jam`` packings (N = 128 at the default goal pressure 1e-7 and at
1e-5, N = 500 at 1e-7; fast path and FIRE with classification), an unjammed packing (no
backbone), and fixed-pressure AQS (``shear_at_pressure``: the Newton path at p = 1e-4 and 1e-3,
N = 128 and 250, and plain FIRE; one N = 128 run whose rattlers block each other and are
settled without FIRE; every column and counter of the run compared). ``--cases``
selects some; ``--quick`` shortens every run, ``--long`` runs five times the steps;
``--count-calls NAME ...`` counts calls of functions by name (instrumentation by
``sys.setprofile``, e.g. of a code path that is to be removed). Exit code 1 when
``compare`` finds a difference above ``--rtol`` (default 1e-14) or a differing flag, iteration
count or counter.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REFERENCE = Path(__file__).resolve().parents[1] / "tests" / "data" / "reference"
FLOAT_COLUMNS = ("gamma", "energy", "shear_stress", "pressure", "z", "z_nr", "max_force")
EXACT_COLUMNS = ("plastic", "iterations")
COUNTERS = ("n_fallback", "n_substepped", "n_cleanup", "n_factorisations", "n_lean", "n_plastic")

# name: (start, steps, quick steps, minimizer, classify[, fixed pressure])
CASES = {
    "ref1000-linear": ("ref:lammps-aqs-n1000-phi0.80", 100, 20, "linear", True),
    "ref500-linear": ("ref:lammps-aqs-n500-phi0.80-1000steps", 300, 60, "linear", True),
    "ref500-fire": ("ref:lammps-aqs-n500-phi0.80-1000steps", 60, 10, "fire", True),
    "jam128-linear": ("jam:128:1:1e-7", 40, 10, "linear", True),
    "jam128-p1e-5-linear": ("jam:128:1:1e-5", 60, 15, "linear", True),
    "jam128-p1e-5-fire": ("jam:128:1:1e-5", 30, 8, "fire", True),
    "jam500-p1e-7-linear": ("jam:500:1:1e-7", 20, 5, "linear", True),
    "unjammed-linear": ("random:64:0.5:7", 10, 5, "linear", True),
    # fixed-pressure AQS (shear_at_pressure; "classify" unused): its default Newton path and
    # plain FIRE, from jam packings brought to p by the first step
    "jam128-pressure1e-4-newton": ("jam:128:1:1e-5", 100, 30, "newton", True, 1e-4),
    "jam250-pressure1e-4-newton": ("jam:250:2:1e-5", 100, 30, "newton", True, 1e-4),
    "jam250-pressure1e-3-newton": ("jam:250:3:1e-5", 100, 30, "newton", True, 1e-3),
    "jam128-pressure1e-4-fire": ("jam:128:1:1e-5", 30, 10, "fire", True, 1e-4),
    # rattlers that block each other (moved together: 22) and caged ones put on the backbone (2)
    "jam128s2-pressure1e-4-caged": ("jam:128:2:1e-4", 200, 30, "newton", True, 1e-4),
}
DGAMMA = 1e-5


def start_packing(spec: str, cache: dict):
    if spec in cache:
        return cache[spec]
    kind, *rest = spec.split(":")
    if kind == "ref":
        from jamlab.spheres.io import read_lammps_positions

        folder = REFERENCE / rest[0]
        meta = json.loads((folder / "meta.json").read_text())
        p = read_lammps_positions(folder / "positions.txt", box_length=meta["box_length"])
    elif kind == "jam":
        from jamlab.spheres.packing import jam

        n, seed, p_target = int(rest[0]), int(rest[1]), float(rest[2])
        res = jam(n, 3, seed=seed, p_target=p_target)
        if not res.ok:
            raise RuntimeError(f"{spec}: jam did not reach a jammed packing")
        p = res.packing
    elif kind == "random":
        from jamlab.spheres.potential import random_packing

        p = random_packing(int(rest[0]), 3, float(rest[1]), int(rest[2]))
    else:
        raise ValueError(spec)
    cache[spec] = p
    return p


def count_calls(names: list[str]) -> dict[str, int]:
    """Count calls of the Python functions with these names from now on (``sys.setprofile``:
    instrumentation from outside, the code under test unchanged)."""
    counts = dict.fromkeys(names, 0)

    def profile(frame, event, arg):
        if event == "call" and frame.f_code.co_name in counts:
            counts[frame.f_code.co_name] += 1

    sys.setprofile(profile)
    return counts


def run(
    out: Path, names: list[str], quick: bool, count: list[str] | None = None, long: bool = False
) -> None:
    import jamlab
    from jamlab.spheres.aqs import shear

    print(f"jamlab from {Path(jamlab.__file__).parent}", flush=True)
    out.mkdir(parents=True, exist_ok=True)
    cache: dict = {}
    for name in names:
        spec, steps, quick_steps, minimizer, classify, *pressure = CASES[name]
        t0 = time.perf_counter()
        start = start_packing(spec, cache)
        t1 = time.perf_counter()
        n = quick_steps if quick else 5 * steps if long else steps
        counts = count_calls(count) if count else None
        if pressure:
            from jamlab.spheres.pressure_shear import shear_at_pressure

            res = shear_at_pressure(start, DGAMMA, pressure=pressure[0], n_steps=n,
                                    minimizer=minimizer)
            # every column, and every numeric attribute (the run's counters)
            data = {k: np.asarray(v) for k, v in res.columns.items()}
            data.update({f"attr_{k}": np.asarray(v) for k, v in res.attrs.items()
                         if isinstance(v, int | float) and not isinstance(v, bool)})
            n_plastic, seconds = int(res.columns["plastic"].sum()), res.time
        else:
            res = shear(start, DGAMMA, n_steps=n, minimizer=minimizer, classify=classify)
            tr = res.trace
            data = {k: np.asarray(getattr(tr, k)) for k in FLOAT_COLUMNS + EXACT_COLUMNS}
            data.update({k: np.asarray(tr.attrs.get(k, -1)) for k in COUNTERS})
            n_plastic, seconds = int(tr.plastic.sum()), res.time
        if counts is not None:
            sys.setprofile(None)
        data["start_positions"] = np.asarray(start.positions)
        data["final_positions"] = np.asarray(res.packing.positions)
        np.savez(out / f"{name}.npz", **data)
        print(
            f"{name:22s} {n:4d} steps  {n_plastic:3d} plastic  start "
            f"{t1 - t0:6.1f} s  shear {seconds:6.1f} s",
            flush=True,
        )
        if counts is not None:
            print(f"    calls: {counts}", flush=True)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    if a.shape != b.shape:
        return float("inf")
    scale = np.maximum(np.abs(a), np.abs(b))
    diff = np.abs(a - b)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(diff == 0, 0.0, diff / np.where(scale == 0, 1.0, scale))
    return float(np.max(r)) if r.size else 0.0


def compare(a: Path, b: Path, rtol: float) -> int:
    bad = 0
    names = sorted(p.stem for p in a.glob("*.npz") if (b / p.name).is_file())
    if not names:
        print("no common cases")
        return 1
    for name in names:
        x, y = np.load(a / f"{name}.npz"), np.load(b / f"{name}.npz")
        parts, ok = [], set(x.files) == set(y.files)
        if not ok:
            parts.append(f"arrays differ: {sorted(set(x.files) ^ set(y.files))}")
        # floating-point arrays to rtol, the rest (flags, counts, counters) exactly
        floats = [k for k in x.files if k in y.files and x[k].dtype.kind == "f"
                  and not k.startswith("attr_")]
        exact = [k for k in x.files if k in y.files and k not in floats]
        for k in floats:
            r = _rel(x[k], y[k])
            same = x[k].shape == y[k].shape and np.array_equal(x[k], y[k], equal_nan=True)
            ok &= same or r <= rtol
            parts.append(f"{k}={'bit' if same else f'{r:.1e}'}")
        for k in exact:
            same = x[k].shape == y[k].shape and np.array_equal(x[k], y[k])
            ok &= same
            if not same:
                parts.append(f"{k} DIFFER")
        rows = x["energy"].size
        plastic = int(np.asarray(x["plastic"]).sum())
        print(
            f"{'OK  ' if ok else 'DIFF'} {name:22s} rows {rows:4d} plastic {plastic:3d}: "
            + " ".join(parts)
        )
        if not ok:
            for k in exact:
                if x[k].ndim and x[k].shape == y[k].shape:
                    where = np.flatnonzero(x[k] != y[k])
                    if where.size:
                        print(f"     {k} differs at rows {where[:20].tolist()}")
                elif not np.array_equal(x[k], y[k]):
                    print(f"     {k}: {x[k]} vs {y[k]}")
        bad += not ok
    print(f"{len(names) - bad}/{len(names)} cases identical to rtol {rtol:g}")
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run the cases and save their traces")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--src", help="source tree to put first on PYTHONPATH (runs a subprocess)")
    r.add_argument("--cases", nargs="*", choices=sorted(CASES), default=list(CASES))
    r.add_argument("--quick", action="store_true", help="fewer steps per case")
    r.add_argument("--long", action="store_true", help="five times the steps per case")
    r.add_argument(
        "--count-calls",
        nargs="*",
        default=None,
        help="count calls of these functions (by name) in each case (slower: a profiler)",
    )
    c = sub.add_parser("compare", help="compare two saved runs")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    c.add_argument("--rtol", type=float, default=1e-14)
    args = ap.parse_args(argv)
    if args.cmd == "compare":
        return compare(args.a, args.b, args.rtol)
    if args.src is not None:
        env = dict(os.environ, PYTHONPATH=str(Path(args.src).resolve()))
        cmd = [sys.executable, __file__, "run", "--out", str(args.out), "--cases", *args.cases]
        if args.quick:
            cmd.append("--quick")
        if args.long:
            cmd.append("--long")
        if args.count_calls:
            cmd += ["--count-calls", *args.count_calls]
        return subprocess.call(cmd, env=env)
    run(args.out, args.cases, args.quick, args.count_calls, args.long)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
