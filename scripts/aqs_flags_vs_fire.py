"""Plastic flags of the AQS fast path against plain FIRE with classification, step by step from
the same minimum (issue 15).

    python scripts/aqs_flags_vs_fire.py [--samples 10] [--gamma-max 0.2] [--json out.json]

Samples: ``jamlab prepare`` packings (:func:`jamlab.spheres.packing.prepare`, monodisperse,
d = 3) at φ = 0.8, N = 32 … 256 (``SAMPLES``), sheared with ``δγ = 1e-4`` to ``γ_max``.

The fast path (``minimizer="linear"``) is run as :func:`jamlab.spheres.aqs.shear` runs it (the
same :class:`~jamlab.spheres.aqs.steps.Stepper` loop). Before each of its steps, plain FIRE with
classification (the ``minimizer="fire"`` strategy, a fresh ``Stepper`` at the same minimum)
takes the same step from the same minimum, so the two verdicts are compared at every step, not
only until the two trajectories part. Per sample the table gives the steps, the plastic steps
of each, the steps where both reach the same minimum
(:func:`jamlab.spheres.aqs.classify.same_minimum`) and, among them, the steps whose flags
differ (the claim: none); then the steps where they reach different minima, with both flags.
Asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from jamlab.spheres.aqs.classify import same_minimum
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.aqs.record import observe
from jamlab.spheres.aqs.saddle import descend
from jamlab.spheres.aqs.steps import Stepper
from jamlab.spheres.fire import FireParameters
from jamlab.spheres.packing import prepare
from jamlab.spheres.potential import NeighborList

SAMPLES = [(32, 1), (32, 2), (48, 3), (64, 4), (64, 5), (96, 6), (128, 7), (128, 8), (192, 9),
           (256, 10)]  # fmt: skip
PHI, DGAMMA, FTOL = 0.8, 1e-4, 1e-12


def fire_step(cur, backbone, prev, target, params, fire_params):
    """Plain FIRE with classification from the minimum ``cur``: (minimum, plastic)."""
    nl = NeighborList(cur)
    counters = {k: 0 for k in ("n_fallback", "n_substepped", "n_cleanup", "n_factorisations",
                               "n_lean")}  # fmt: skip
    st = Stepper(cur, backbone, prev, nl, DGAMMA, FTOL, "fire", True, params, fire_params,
                 counters)  # fmt: skip
    step = st.take(cur, target)
    new = st.settle(step)[0]
    return new, bool(step.plastic)


def compare(n: int, seed: int, gamma_max: float) -> dict:
    t0 = time.perf_counter()
    start = prepare(n, 3, PHI, seed, ftol=FTOL).packing
    params, fire_params = AQSParameters(), FireParameters()
    nl = NeighborList(start)
    row, backbone = observe(start, nl)
    start, row, backbone, fac, _, _ = descend(
        start, row, backbone, nl, FTOL, params.max_fire_iter, fire_params
    )  # as shear() starts
    prev = {"gamma": start.strain, **row}
    counters = {k: 0 for k in ("n_fallback", "n_substepped", "n_cleanup", "n_factorisations",
                               "n_lean")}  # fmt: skip
    fast = Stepper(start, backbone, prev, nl, DGAMMA, FTOL, "linear", True, params, fire_params,
                   counters, fac=fac)  # fmt: skip
    steps = int(round(gamma_max / DGAMMA))
    cur = start
    fast_flags, fire_flags, same = [], [], []
    for k in range(1, steps + 1):
        target = start.strain + k * DGAMMA
        fire_min, fire_plastic = fire_step(cur, backbone, prev, target, params, fire_params)
        step = fast.take(cur, target)
        new, row, new_backbone, _, cleaned = fast.settle(step)
        fast.advance(step, new, row, new_backbone, cleaned, target, last=k == steps)
        fast_flags.append(bool(step.plastic))
        fire_flags.append(fire_plastic)
        same.append(same_minimum(new, fire_min, nl, params))
        cur, backbone, prev = new, new_backbone, {"gamma": target, **row}
    fast_a, fire_a, same_a = map(np.array, (fast_flags, fire_flags, same))
    steps_idx = np.arange(1, steps + 1)
    return {
        "N": n,
        "seed": seed,
        "steps": steps,
        "fast_plastic": steps_idx[fast_a].tolist(),
        "fire_plastic": steps_idx[fire_a].tolist(),
        "same_minimum": int(same_a.sum()),
        "flags_differ_same_minimum": steps_idx[same_a & (fast_a != fire_a)].tolist(),
        "different_minima": [
            (int(s), bool(f), bool(g))
            for s, f, g in zip(steps_idx[~same_a], fast_a[~same_a], fire_a[~same_a], strict=True)
        ],  # fmt: skip
        "seconds": time.perf_counter() - t0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=len(SAMPLES))
    ap.add_argument("--gamma-max", type=float, default=0.2)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    results = []
    print(
        "| N | seed | steps | plastic fast | plastic FIRE | same minimum | flags differ there "
        "| different minima (step: fast/FIRE flag) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for n, seed in SAMPLES[: args.samples]:
        r = compare(n, seed, args.gamma_max)
        results.append(r)
        diff = ", ".join(f"{s}: {'P' if f else 'e'}/{'P' if g else 'e'}"
                         for s, f, g in r["different_minima"]) or "—"  # fmt: skip
        print(f"| {n} | {seed} | {r['steps']} | {len(r['fast_plastic'])} | "
              f"{len(r['fire_plastic'])} | {r['same_minimum']} | "
              f"{r['flags_differ_same_minimum'] or '—'} | {diff} |", flush=True)  # fmt: skip
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=1)


if __name__ == "__main__":
    main()
