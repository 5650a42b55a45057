"""The exact ΔE law without a cut-off at small |ΔE| (docs/theory-vs-cascade.md §8, Table 8).

For y = power_law(mu) (q_max = 1) and |ΔE| = r δγ, r = 1e-3 … 0.1, prints as markdown:
  (a) R and δγ·P(ΔE) from ``exact_energy_jump_law`` (multi-band grid, levels geometric in 1 - q,
      its default merging cut-off, 1 - q_cut = 1e-12 here except 1.1e-12 for mu_J at δγ = 0.1,
      Richardson 256/512 levels);
  (b) their change when the levels are doubled and when 1 - q_cut goes 1e-8 → 1e-10 → the default;
  (c) why the uniform-grid ``exact_jump_law`` could not get there: its R with q_cut = 1 - 1e-4 and
      1 - 1e-5, and the graded levels of ``continuum_levels`` (q_cut = 1 - 1e-8, on the bands);
  (d) the local log-slopes d log P / d log|ΔE|, exact and printed.

    PYTHONPATH=src .venv/bin/python scripts/exact_bands_convergence.py [mu ...]

About 1 min on one core for the default mu = 0.706346 and 0.5.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from jamlab.theory import ParisiFunction, exact_energy_jump_law, jump_distribution  # noqa: E402
from jamlab.theory.exact_bands import BandedRecursion  # noqa: E402
from jamlab.theory.exact_law import continuum_levels, exact_jump_law  # noqa: E402

RS = np.array([1e-3, 3e-3, 1e-2, 3e-2, 0.1])
DGS = (0.1, 0.01)


def fmt(a: np.ndarray, p: int = 6) -> str:
    return " | ".join(f"{v:.{p}g}" for v in a)


def slope(f, x: np.ndarray) -> np.ndarray:
    e = 1e-3
    lo, hi = np.asarray(f(x * (1 - e))), np.asarray(f(x * (1 + e)))
    return (np.log(hi) - np.log(lo)) / (np.log1p(e) - np.log1p(-e))


def main(mus: list[float]) -> None:
    head = " | ".join(f"r = {r:g}" for r in RS)
    for mu in mus:
        pf = ParisiFunction.power_law(mu)
        print(f"\n### power_law({mu}), no cut-off\n")
        print(f"| δγ | quantity | {head} |")
        print("|---|---|" + "---|" * RS.size)
        for dg in DGS:
            x = -dg * RS
            t0 = time.perf_counter()
            law = exact_energy_jump_law(pf, dg)
            R, P = np.asarray(law.R(x)), np.asarray(law.pdf(x))
            cost = time.perf_counter() - t0
            fine = exact_energy_jump_law(pf, dg, levels=512)
            dK = np.abs(np.asarray(fine.R(x)) - R)
            dKp = np.abs(np.asarray(fine.pdf(x)) / P - 1)
            qc = {e: exact_energy_jump_law(pf, dg, q_cut=1 - 10.0 ** -e) for e in (8, 10)}
            d8 = np.abs(np.asarray(qc[8].R(x)) - np.asarray(qc[10].R(x)))
            d10 = np.abs(np.asarray(qc[10].R(x)) - R)
            d10p = np.abs(np.asarray(qc[10].pdf(x)) / P - 1)
            rows = [("R exact", fmt(R, 8)), ("δγ P exact", fmt(dg * P, 7)),
                    ("ΔR, levels ×2", fmt(dK, 1)), ("ΔP/P, levels ×2", fmt(dKp, 1)),
                    ("ΔR, 1-q_cut 1e-8→1e-10", fmt(d8, 1)),
                    ("ΔR, 1-q_cut 1e-10→default", fmt(d10, 1)),
                    ("ΔP/P, 1-q_cut 1e-10→default", fmt(d10p, 1))]
            for e in (4, 5):
                old = exact_jump_law(pf, dg, q_cut=1 - 10.0 ** -e)
                rows.append((f"R uniform grid, 1-q_cut = 1e-{e} (old)",
                             fmt(np.asarray(old.R(x)), 6)))
            grad = [BandedRecursion(*continuum_levels(pf, n, 1 - 1e-8), dg) for n in (64, 128)]
            Rg = (4 * grad[1].R(x) - grad[0].R(x)) / 3
            rows.append(("R, continuum_levels 64/128, 1-q_cut = 1e-8", fmt(Rg, 6)))
            printed = jump_distribution(pf, dg)
            se = slope(law.pdf, x)
            sp = slope(printed.pdf, x)
            rows.append(("slope exact / printed",
                         " | ".join(f"{a:.3f} / {b:.3f}" for a, b in zip(se, sp, strict=True))))
            rows.append(("P exact / P printed",
                         fmt(P / np.asarray(printed.pdf(x)), 3)))
            for name, val in rows:
                print(f"| {dg:g} | {name} | {val} |")
            print(f"| {dg:g} | cost of the first row (s, 5 points, from scratch) | {cost:.2f} |"
                  + " |" * (RS.size - 1))


if __name__ == "__main__":
    main([float(a) for a in sys.argv[1:]] or [0.706346, 0.5])
