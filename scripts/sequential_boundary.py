"""The two-sided boundary for a test looked at several times (group-sequential, Pocock form).

A z-test applied at K interim looks crosses ``|z| > 1.96`` under the null more often than 5 % of
the time. With an estimate whose standard error at look ``k`` is ``σ_k`` (cumulative data, so
``Z_k`` are jointly Gaussian with ``corr(Z_i, Z_j) = σ_j / σ_i`` for ``i < j``: the canonical
joint distribution, Jennison & Turnbull 2000, §3.1), this prints the constant ``c`` such that
``P(max_k |Z_k| > c) = α`` under zero effect, and the probability that the 1.96 rule crosses at
some look. Computed by the recursive numerical integration of Armitage, McPherson & Rowe (1969):
the density of the score ``S_k = Z_k √I_k`` (``I_k = 1/σ_k²``) on the continuation region, carried
from look to look by Gaussian increments of variance ``I_k − I_{k−1}``.

    PYTHONPATH=src python scripts/sequential_boundary.py --sigma 0.021 0.017 0.017 0.016

With equal increments of information this is Pocock's constant (K = 2 … 5 at α = 0.05: 2.178,
2.289, 2.361, 2.413; tests/test_sequential_boundary.py).
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.optimize import brentq
from scipy.stats import norm

GRID = 801  # points per look's region (Pocock's constants to 4 digits from 501)


def stay_probability(c: float, info: np.ndarray) -> float:
    """``P(|Z_k| <= c for every look k)`` under zero effect, ``info`` the increasing ``I_k``."""
    info = np.asarray(info, dtype=np.float64)
    if info.ndim != 1 or info.size == 0 or np.any(info <= 0) or np.any(np.diff(info) <= 0):
        raise ValueError("information must be positive and increasing (σ_k decreasing)")
    # Simpson's rule on each look's grid (GRID odd): these weights times the grid spacing / 3
    simpson = np.full(GRID, 2.0)
    simpson[1::2] = 4.0
    simpson[0] = simpson[-1] = 1.0
    edge = c * np.sqrt(info[0])
    x = np.linspace(-edge, edge, GRID)
    density = norm.pdf(x, scale=np.sqrt(info[0]))
    for k in range(1, info.size):
        step = np.sqrt(info[k] - info[k - 1])
        edge = c * np.sqrt(info[k])
        y = np.linspace(-edge, edge, GRID)
        # the previous look's density carried to each new point, integrated by Simpson's rule
        kernel = norm.pdf((y[:, None] - x[None, :]) / step) / step
        density = kernel @ (simpson * density) * ((x[1] - x[0]) / 3.0)
        x = y
    return float(np.sum(simpson * density) * (x[1] - x[0]) / 3.0)


def boundary(sigma: list[float] | np.ndarray, alpha: float = 0.05) -> float:
    """The constant ``c`` with ``P(max_k |Z_k| > c) = alpha`` for standard errors ``sigma``."""
    info = 1.0 / np.asarray(sigma, dtype=np.float64) ** 2
    return float(brentq(lambda c: 1.0 - stay_probability(c, info) - alpha, 1.0, 6.0, xtol=1e-6))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sigma", type=float, nargs="+", required=True,
                        help="the estimate's standard error at each look, in order")
    parser.add_argument("--alpha", type=float, default=0.05)
    args = parser.parse_args(argv)
    if not 0 < args.alpha < 1:
        parser.error("--alpha must be in (0, 1)")
    sigma = np.asarray(args.sigma)
    if np.any(sigma <= 0) or np.any(np.diff(sigma) >= 0):
        parser.error("--sigma must be positive and strictly decreasing (information grows)")
    info = 1.0 / sigma**2
    c = boundary(sigma, args.alpha)
    naive = 1.0 - stay_probability(float(norm.isf(args.alpha / 2)), info)
    print(f"looks: {sigma.size}; information fractions: "
          + ", ".join(f"{f:.3f}" for f in info / info[-1]))
    print(f"boundary |z| > {c:.3f} for a {args.alpha:g} chance of crossing at any look")
    print(f"the single-look rule |z| > {norm.isf(args.alpha / 2):.3f} applied at every look "
          f"crosses with probability {naive:.4f}")


if __name__ == "__main__":
    main()
