"""Speed of the printed jump distribution: pdf at 1000 points for 5 values of δγ (target < 1 s).

Prints the time beside the target as a ratio, and the worst relative error against the 50-digit
mpmath reference of the tests on a few points. Never asserts a time.

    .venv/bin/python benchmarks/bench_theory.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from jamlab.theory import ParisiFunction, jump_distribution

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "theory"))
from _mp_reference import PowerLawReference, pdf_cdf  # noqa: E402

TARGET_S = 1.0
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


if __name__ == "__main__":
    main()
