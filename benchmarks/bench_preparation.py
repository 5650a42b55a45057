"""The preparation of a fixed-pressure sample, two ways, side by side in one run.

A fixed-pressure AQS sample starts from a jammed packing brought to the target pressure ``p``.
``jamlab run --pressure p`` prepares it as ``jam(N, 3, seed, p_target=1e-7)`` (the study's
``p_target``, default 1e-7) and lets the shear's first enthalpy minimisation bring it to ``p``;
the caches of ``benchmarks/bench_pressure.py`` and ``scripts/sample_cost.py`` instead jam at
``p_target=min(p, 1e-4)`` and take one fixed-pressure step with FIRE. For each seed this times
(CPU, one thread) both ``jam`` calls and the FIRE step from each to ``p``, and prints the ratio.
The packings differ (another p_target ends the search elsewhere), so this compares the cost of
the two preparations, not of one packing. ``jam``'s own outcome is printed: at N = 1000 its
search for an isostatic backbone at p_target = 1e-4 fails all 11 attempts (a contact is added
below the window), and the caches use the last attempt's packing, which the FIRE step then
brings to p. Asserts nothing about time.

    python benchmarks/bench_preparation.py --n 1000 --seeds 1 2 3 --pressure 1e-4
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trees import SINGLE_THREAD  # noqa: E402  (benchmarks run as scripts)

os.environ.update(SINGLE_THREAD)

from bench_pressure import to_pressure  # noqa: E402
from jamlab.spheres.packing import jam  # noqa: E402


def prepare(n: int, seed: int, p_target: float,
            pressure: float) -> tuple[float, float, bool, str]:
    """CPU seconds of ``jam`` at ``p_target`` and of the FIRE step to ``pressure``, whether
    that step's minimum is converged and jammed, and ``jam``'s own outcome (``ok``, or how many
    attempts failed: its stopping rule wants an isostatic backbone within a factor 2 of
    ``p_target``, docs/packings.md)."""
    t = time.process_time()
    r = jam(n, 3, seed=seed, p_target=p_target)
    t_jam = time.process_time() - t
    t = time.process_time()
    _, ok = to_pressure(r.packing, pressure)
    t_step = time.process_time() - t
    outcome = "ok" if r.ok else r.reason.split(" (")[0]
    return t_jam, t_step, ok, f"{outcome}, {r.n_minimizations} minimisations"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--run-p-target", type=float, default=1e-7,
                    help="jamlab run's p_target (the study's default)")
    a = ap.parse_args()
    if not (a.pressure > 0 and a.run_p_target > 0 and a.n > 0):
        ap.error("--n, --pressure and --run-p-target must be positive")
    cache_pt = min(a.pressure, 1e-4)
    print(f"N = {a.n}, p = {a.pressure:g}: `jamlab run` jams at {a.run_p_target:g}, the "
          f"benchmark caches at {cache_pt:g}; CPU s, one thread\n")
    print("| seed | run: jam | run: step to p | bench cache: jam | bench cache: step to p | "
          "cache / run (total) | minima converged and jammed | jam's outcome: run / cache |")
    print("|---|---|---|---|---|---|---|---|")
    tot_run = tot_cache = 0.0
    for seed in a.seeds:
        j1, s1, ok1, how1 = prepare(a.n, seed, a.run_p_target, a.pressure)
        j2, s2, ok2, how2 = prepare(a.n, seed, cache_pt, a.pressure)
        tot_run += j1 + s1
        tot_cache += j2 + s2
        print(f"| {seed} | {j1:.1f} | {s1:.1f} | {j2:.1f} | {s2:.1f} | "
              f"{(j2 + s2) / (j1 + s1):.1f}× | {'yes' if ok1 else 'NO'} / "
              f"{'yes' if ok2 else 'NO'} | {how1} / {how2} |", flush=True)
    print(f"\nmean per sample: run {tot_run / len(a.seeds):.1f} CPU s, bench cache "
          f"{tot_cache / len(a.seeds):.1f} CPU s ({tot_cache / tot_run:.1f}×)")


if __name__ == "__main__":
    main()
