"""Constant-volume AQS at jamming: a whole sample's time against the extrapolation of its start.

``benchmarks/bench_jamming.py`` times ``--steps`` (20) steps from ``jam(N, 3, seed, 1e-7)`` and
``scripts/project_cost.py`` multiplies that rate by 1000. At constant volume the state drifts
along a sample (the shear unjams the packing, or dilatancy raises its pressure by decades), so
the first steps need not be typical. This runs the same start — ``jam(N, 3, seed,
p_target=1e-7)``, then jamlab's default path ``shear(packing, δγ, n_steps=--steps)`` at constant
volume, as ``bench_jamming.py`` does — for a whole sample, records the CPU time of every step
(the ``progress`` callback), and prints per packing:

- the jam's and the whole sample's CPU time, and the sample's time projected from its first
  ``--first`` steps (``bench_jamming.py``'s rate × steps): their ratio is the extrapolation's
  error;
- per block of steps: CPU s, the fraction of jammed minima, the median pressure, mean FIRE
  iterations per step, plastic flags (all, and between jammed minima: the ones any statistic
  counts).

``--budget S`` stops a sample after S CPU seconds of shear (a packing that hovers at the edge of
jamming can take hours); it is reported as stopped, with the steps it finished, whose states
come from a hook after every step (``is_jammed`` and the pressure of each minimum; not timed).

``--floppy fire project`` runs each packing with both protocols for the steps from unjammed
minima (:class:`jamlab.spheres.aqs.AQSParameters` ``floppy``) in turn, and prints them side by
side.

CPU time (``time.process_time``, one thread): the machine is shared. ``--json`` keeps the
per-step times and states.

    PYTHONPATH=src python benchmarks/bench_cv_sample.py --n 1000 --seeds 1 2 --steps 1000 \\
        --json cv_sample.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import jamlab.spheres as sp
from jamlab.spheres.aqs import AQSParameters, shear
from jamlab.spheres.kernel_choice import calibration
from jamlab.spheres.potential import pressure
from jamlab.spheres.rigidity import is_jammed

DGAMMA = 1e-5
FTOL = 1e-12
BLOCKS = ((0, 20), (20, 100), (100, 300), (300, 600), (600, 1000))


class _OverBudget(Exception):
    """Raised by the progress callback when a sample has used its CPU budget."""


def jammed_start(n: int, seed: int) -> tuple[sp.Packing, float]:
    """``jam(n, 3, seed, p_target=1e-7)`` and its CPU seconds."""
    t0 = time.process_time()
    res = sp.jam(n, 3, seed, p_target=1e-7)
    if not res.ok:
        raise SystemExit(f"jam({n}, seed={seed}) failed: {res.reason}")
    return res.packing, time.process_time() - t0


def one(n: int, seed: int, steps: int, first: int, budget: float | None = None,
        floppy: str = "fire", start: tuple[sp.Packing, float] | None = None) -> dict:
    packing, jam_s = jammed_start(n, seed) if start is None else start
    marks: list[float] = []
    # each minimum's state, measured by a hook (for a sample stopped by --budget, which leaves
    # no trace; its CPU time is not counted as the shear's)
    start = packing
    rows: dict[str, list] = {"pressure": [pressure(start)],
                             "jammed": [bool(is_jammed(start, FTOL).jammed)],
                             "iterations": [0], "plastic": [False]}
    hook_s = [0.0]

    def after_step(before, new, step) -> None:
        t = time.process_time()
        rows["pressure"].append(pressure(new))
        rows["jammed"].append(bool(is_jammed(new, FTOL).jammed))
        rows["iterations"].append(int(step.iterations))
        rows["plastic"].append(bool(step.plastic))
        hook_s[0] += time.process_time() - t

    def progress(done: int, total: int) -> None:
        marks.append(time.process_time() - hook_s[0])
        if budget is not None and marks[-1] - t1 > budget:
            raise _OverBudget

    t1 = time.process_time()
    try:
        r = shear(start, DGAMMA, n_steps=steps, ftol=FTOL, progress=progress,
                  after_step=after_step, params=AQSParameters(floppy=floppy))
    except _OverBudget:
        r = None
    total = time.process_time() - t1 - hook_s[0]
    done = len(marks)
    per_step = np.diff(np.concatenate([[t1], marks]))
    if r is not None:  # the trace's own columns
        tr = r.trace
        rows = {"pressure": np.asarray(tr.pressure).tolist(),
                "jammed": np.asarray(tr.jammed, bool).tolist(),
                "iterations": np.asarray(tr.iterations).tolist(),
                "plastic": np.asarray(tr.plastic, bool).tolist()}
    jammed = np.asarray(rows["jammed"], bool)
    both = jammed[1:] & jammed[:-1]
    return {
        "N": n, "seed": seed, "floppy": floppy, "steps": steps, "steps_done": done,
        "dgamma": DGAMMA,
        "jam_cpu_s": jam_s, "shear_cpu_s": total, "first": first,
        "first_cpu_s": float(per_step[:first].sum()) if done >= first else None,
        "step_cpu_s": per_step.tolist(), **rows,
        "counted_plastic": int(np.count_nonzero(np.asarray(rows["plastic"], bool)[1:] & both)),
    }


def report(o: dict) -> None:
    steps, first, done = o["steps"], o["first"], o["steps_done"]
    proj = None if o["first_cpu_s"] is None else o["first_cpu_s"] * steps / first
    p = np.asarray(o["pressure"])
    jam = np.asarray(o["jammed"], bool)
    its = np.asarray(o["iterations"])
    plastic = np.asarray(o["plastic"], bool)
    both = jam[1:] & jam[:-1]
    line = (f"N = {o['N']}, seed {o['seed']}, floppy={o['floppy']}: jam {o['jam_cpu_s']:.0f} "
            f"CPU s; {done} steps "
            f"{o['shear_cpu_s']:.0f} CPU s ({o['shear_cpu_s'] / 60:.1f} min)")
    if done < steps:
        line += f" — STOPPED by the budget after {done} of {steps} steps"
    if proj is not None and done == steps:
        line += (f"; projected from the first {first} steps: {proj:.0f} s ({proj / 60:.1f} min), "
                 f"{proj / o['shear_cpu_s']:.2f}x the whole")
    print(line)
    print(f"  plastic flags {int(plastic[1:].sum())}, between jammed minima "
          f"{o['counted_plastic']}; jammed minima {int(jam[1:].sum())}/{done}; p from "
          f"{p[0]:.1e} to {p[-1]:.1e}")
    print("  | steps | CPU s | jammed | median p | FIRE its/step | plastic (counted) |")
    print("  |---|---|---|---|---|---|")
    for lo, hi in BLOCKS:
        if lo >= done:
            break
        hi = min(hi, done)
        s = slice(lo + 1, hi + 1)  # rows of the steps lo+1 … hi
        cpu = f"{float(np.sum(o['step_cpu_s'][lo:hi])):.1f}"
        counted = int((plastic[s] & both[lo:hi]).sum())
        print(f"  | {lo + 1}–{hi} | {cpu} | {jam[s].mean():.0%} | {np.median(p[s]):.1e} | "
              f"{its[s].mean():.0f} | {int(plastic[s].sum())} ({counted}) |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1000])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--first", type=int, default=20,
                    help="the steps bench_jamming.py times (the extrapolation compared)")
    ap.add_argument("--budget", type=float, default=None,
                    help="stop a sample after this many CPU seconds of shear (reported as "
                    "stopped, with the steps it finished)")
    ap.add_argument("--floppy", nargs="+", choices=("fire", "project"), default=["fire"],
                    help="the floppy-step protocols to time, each on the same packing in turn "
                    "(AQSParameters.floppy); with two, a side-by-side summary at the end")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    if a.json is not None and a.json.exists():
        ap.error(f"{a.json} exists; not overwriting it")
    if not 0 < a.first <= a.steps:
        ap.error("--first must be in 1 … --steps")
    results = []
    for n in a.n:
        for seed in a.seeds:
            start = jammed_start(n, seed)
            for floppy in a.floppy:
                o = one(n, seed, a.steps, a.first, a.budget, floppy, start)
                report(o)
                results.append(o)
                if a.json is not None:  # after every sample: a long run keeps what it finished
                    tmp = a.json.with_suffix(".tmp")
                    kernel = calibration().describe()  # the machine, for the reader
                    tmp.write_text(json.dumps({"samples": results, "force_kernel": kernel}))
                    tmp.replace(a.json)
    if len(a.floppy) > 1:
        print(f"\n# whole-sample shear CPU s, side by side ({' / '.join(a.floppy)})")
        print("| N | seed | " + " | ".join(a.floppy) + f" | {a.floppy[0]} / {a.floppy[1]} | "
              "counted plastic | jammed minima |")
        print("|---|---|" + "---|" * (len(a.floppy) + 3))
        for k in range(0, len(results), len(a.floppy)):
            group = results[k:k + len(a.floppy)]
            cpu = [g["shear_cpu_s"] for g in group]
            done = "" if all(g["steps_done"] == g["steps"] for g in group) else " (stopped)"
            print(f"| {group[0]['N']} | {group[0]['seed']} | "
                  + " | ".join(f"{c:.0f}" for c in cpu) + f" | {cpu[0] / cpu[1]:.2f}{done} | "
                  + " / ".join(str(g["counted_plastic"]) for g in group) + " | "
                  + " / ".join(str(int(np.sum(g["jammed"]))) for g in group) + " |")


if __name__ == "__main__":
    main()
