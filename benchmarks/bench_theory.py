"""Speed of the jump distributions. Never asserts a time; prints each beside its target.

1. Printed formula: pdf at 1000 points for 5 values of δγ (target < 1 s), and the worst relative
   error against the 50-digit mpmath reference of the tests on a few points.
2. Exact continuum law (``exact_jump_law``, k → ∞ by Richardson from 64 and 128 graded levels):
   P(ΔE|δγ) at 200 points for one δγ, from scratch (target <= 10 s on one core), with the change
   against 128/256 levels (convergence).
3. The same on the multi-band grid (``exact_energy_jump_law``, no cut-off, 200 points down to
   |ΔE| = 1e-3 δγ, Richardson from 256 and 512 levels geometric in 1 - q), same target.

    .venv/bin/python benchmarks/bench_theory.py

BLAS is pinned to one thread (one core, as the target says).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import sys  # noqa: E402
import time
from pathlib import Path

import numpy as np  # noqa: E402

from jamlab.theory import (  # noqa: E402
    ParisiFunction,
    exact_energy_jump_law,
    exact_jump_law,
    jump_distribution,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "theory"))
from _mp_reference import PowerLawReference, pdf_cdf  # noqa: E402

TARGET_S = 1.0
TARGET_EXACT_S = 10.0
MU = 0.706346
DGAMMAS = [0.3, 1e-2, 1e-3, 1e-4, 1e-6]


def main() -> None:
    pf = ParisiFunction.power_law(MU)
    dists = [jump_distribution(pf, dg) for dg in DGAMMAS]
    grids = [-dg * np.logspace(-12, 1, 1000) for dg in DGAMMAS]
    dists[0].pdf(grids[0][:10])  # warm-up (imports, caches)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for dist, dE in zip(dists, grids, strict=True):
            dist.pdf(dE)
        best = min(best, time.perf_counter() - t0)
    print(
        f"pdf, 5 x 1000 points, mu={MU}, no cut-off: {best:.3f} s "
        f"(target {TARGET_S:g} s, ratio {best / TARGET_S:.2f})"
    )

    worst_pdf = worst_cdf = 0.0
    for q_max in (1.0, 0.99):
        ref = PowerLawReference(MU, q_max=q_max)
        for dg in (1e-2, 1e-4):
            dist = jump_distribution(ParisiFunction.power_law(MU, q_max=q_max), dg)
            for r in (1e-3, 0.3, 3.0):
                p_ref, c_ref = pdf_cdf(ref, -dg * r, dg)
                worst_pdf = max(worst_pdf, abs(dist.pdf(-dg * r) / float(p_ref) - 1))
                worst_cdf = max(worst_cdf, abs(dist.cdf(-dg * r) / float(c_ref) - 1))
    print(
        f"worst relative error vs 50-digit mpmath (12 points): pdf {worst_pdf:.1e}, "
        f"cdf {worst_cdf:.1e} (target 1e-8)"
    )

    exact_cases = [
        ("power law mu_J, q_max = 0.99", ParisiFunction.power_law(MU, q_max=0.99), None),
        ("power law mu_J, no cut-off (q_cut = 1 - 1e-4)", ParisiFunction.power_law(MU), 1 - 1e-4),
        ("linear 2.5 q, q_max = 0.9", ParisiFunction.linear(2.5, 0.0, 0.9), None),
    ]
    dg = 0.1
    dE = -dg * np.logspace(-2.5, 0.5, 200)
    for name, pf, q_cut in exact_cases:
        t0 = time.perf_counter()
        law = exact_jump_law(pf, dg, q_cut=q_cut)
        p = np.asarray(law.pdf(dE))
        el = time.perf_counter() - t0
        ref = exact_jump_law(pf, dg, q_cut=q_cut, levels=128)
        change = float(np.max(np.abs(np.asarray(ref.R(dE)) - np.asarray(law.R(dE)))))
        rel = float(np.max(np.abs(np.asarray(ref.pdf(dE)) / p - 1)))
        print(
            f"exact continuum P(dE|dgamma={dg:g}), 200 points, {name}: {el:.2f} s "
            f"(target {TARGET_EXACT_S:g} s, ratio {el / TARGET_EXACT_S:.2f}); "
            f"change with twice the levels: R {change:.1e}, pdf {rel:.1e} relative"
        )

    # the multi-band grid (exact_energy_jump_law): no cut-off, down to |dE| = 1e-3 dgamma
    dE = -dg * np.logspace(-3, 0.5, 200)
    pf = ParisiFunction.power_law(MU)
    t0 = time.perf_counter()
    law = exact_energy_jump_law(pf, dg)
    p = np.asarray(law.pdf(dE))
    el = time.perf_counter() - t0
    ref = exact_energy_jump_law(pf, dg, levels=512)
    change = float(np.max(np.abs(np.asarray(ref.R(dE)) - np.asarray(law.R(dE)))))
    rel = float(np.max(np.abs(np.asarray(ref.pdf(dE)) / p - 1)))
    print(
        f"exact continuum P(dE|dgamma={dg:g}), 200 points down to |dE| = 1e-3 dgamma, multi-band "
        f"grid, power law mu_J, no cut-off (1 - q_cut = {1 - law.q_top:.2g}): {el:.2f} s "
        f"(target {TARGET_EXACT_S:g} s, ratio {el / TARGET_EXACT_S:.2f}); "
        f"change with twice the levels: R {change:.1e}, pdf {rel:.1e} relative"
    )


if __name__ == "__main__":
    main()
