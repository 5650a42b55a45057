"""Where a fixed-pressure AQS run's time goes by function (cProfile), and how often the backbone's
METIS ordering repeats one already made.

Runs ``shear_at_pressure(packing, δγ, pressure=p, n_steps=…)`` (the default path, after a short
warm-up run that compiles the kernels) on the packing of ``benchmarks/bench_pressure.py``'s cache
(made there if missing; or ``--sample FILE``: a run's prepared packing, sheared as its run did; the
options of ``bench_pressure.parse_sample_arguments``) under ``cProfile``, and prints: the run's
profiled time; the time of the groups that carry it (the compiled FIRE loop, CHOLMOD's solves,
factorisations and analyses, METIS's nested dissection, the neighbour-list build kernel, the
backbone Hessian kernel), each from the profile's own-time (``tottime``) entries; the ``--top``
functions by own time; and the backbone orderings (``linalg.nested_dissection``) whose free set and
contact pairs repeat an earlier one of the run — what a cache of orderings could save.

    PYTHONPATH=src python scripts/profile_pressure.py --n 1000 --seed 1 --steps 300 --cache CACHE

The profile's own overhead (≈ 10–20 % on the Python side) makes its times larger than the
run's; the shares are what it is for. ``sample_cost.py`` has the unprofiled CPU time by part.
"""

from __future__ import annotations

import argparse
import cProfile
import hashlib
import io
import pstats
import sys
import time
from pathlib import Path

# bench_pressure first: it sets one thread for the BLAS, OpenMP and numba before numpy loads
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_pressure import parse_sample_arguments, sample_start  # noqa: E402

# isort: split
import numpy as np  # noqa: E402

import jamlab.spheres.aqs.linalg as linalg  # noqa: E402
import jamlab.spheres.pressure_shear as ps  # noqa: E402

GROUPS = {
    "FIRE (compiled loop)": lambda f, fn: f.endswith("kernels/fire.py") and fn == "fire",
    "CHOLMOD solve": lambda f, fn: fn == "<built-in method cvxopt.cholmod.solve>",
    "CHOLMOD numeric": lambda f, fn: fn == "<built-in method cvxopt.cholmod.numeric>",
    "CHOLMOD symbolic": lambda f, fn: fn == "<built-in method cvxopt.cholmod.symbolic>",
    "METIS nested dissection": lambda f, fn: "edge_nd" in fn,
    "neighbour-list build kernel": lambda f, fn: fn == "build_neighbor_list",
    "backbone Hessian kernel": lambda f, fn: fn == "backbone_hessian_csr",
}


def count_orderings() -> dict:
    """Wrap :func:`linalg.nested_dissection` to count calls and those whose free set and contact
    pairs repeat an earlier call's (the ordering is then the same: checked)."""
    seen: dict[str, np.ndarray] = {}
    tally = {"calls": 0, "repeats": 0, "cpu_s": 0.0, "repeat_cpu_s": 0.0}
    original = linalg.nested_dissection

    def wrapped(free, ci, cj, n):
        lo, hi = np.minimum(ci, cj), np.maximum(ci, cj)
        key = hashlib.sha1(np.asarray(free).tobytes()
                           + np.unique(lo * n + hi).tobytes()).hexdigest()
        t = time.process_time()
        out = original(free, ci, cj, n)
        dt = time.process_time() - t
        tally["calls"] += 1
        tally["cpu_s"] += dt
        if key in seen:
            if not np.array_equal(seen[key], out):
                raise AssertionError("one pattern, two orderings: METIS is not deterministic here")
            tally["repeats"] += 1
            tally["repeat_cpu_s"] += dt
        seen[key] = out
        return out

    linalg.nested_dissection = wrapped
    return tally


def group_times(stats: pstats.Stats) -> dict[str, float]:
    """Own time of the profile's entries per group of :data:`GROUPS`."""
    out = dict.fromkeys(GROUPS, 0.0)
    for (filename, _, name), (_, _, tottime, _, _) in stats.stats.items():
        for group, match in GROUPS.items():
            if match(filename, name):
                out[group] += tottime
    return out


def _count(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def main(argv: list[str] | None = None) -> int:
    a = parse_sample_arguments(__doc__, argv, lambda ap: ap.add_argument(
        "--top", type=_count, default=25, help="functions to list by own time"))
    packing = sample_start(a)
    ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=2)  # compile
    tally = count_orderings()
    prof = cProfile.Profile()
    prof.enable()
    r = ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps)
    prof.disable()
    stats = pstats.Stats(prof)
    total = stats.total_tt
    plastic = int(np.asarray(r.columns["plastic"], dtype=bool).sum())
    print(f"N = {a.n}, seed {a.seed}, p = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps, "
          f"{plastic} plastic: {total:.2f} s profiled")
    print("\n| group (own time) | s | share |\n|---|---|---|")
    groups = group_times(stats)
    for name, secs in groups.items():
        print(f"| {name} | {secs:.2f} | {100 * secs / total:.1f} % |")
    rest = total - sum(groups.values())
    print(f"| everything else | {rest:.2f} | {100 * rest / total:.1f} % |")
    print(f"\nbackbone orderings: {tally['calls']} made, {tally['repeats']} repeat an earlier "
          f"pattern of the run ({tally['repeat_cpu_s']:.2f} of {tally['cpu_s']:.2f} CPU s, "
          "timed outside the profile's accounting)")
    if a.top:
        buf = io.StringIO()
        pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(a.top)
        print("\n" + buf.getvalue().strip())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
