"""Small-strain checks of the cascade sampler against the first-order theory (SPEC §1).

First order in ``δγ`` (derived in docs/theory-vs-cascade.md): a state of the ``q_i``-cluster
seen from the ground state has ``ΔU`` density ``Δy_i`` at ``ΔU = 0+`` and stress difference
``N(0, 2(1 - q_i))``; it becomes the new ground state when ``ΔU < δγ ΔΣ``. Hence per unit
``δγ``: jump probability at overlap ``q_i`` is ``Δy_i √((1-q_i)/π)`` and the stress jumps have
density ``θ(ΔΣ) ΔΣ Σ_i Δy_i exp(-ΔΣ²/(4(1-q_i)))/√(4π(1-q_i))``.

Tolerances: ``Z`` binomial standard errors plus an explicit allowance for the ``O(δγ)``
corrections, ``|relative error| <= 1.5 δγ`` (the exact recursion gives ``~0.4 δγ``).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from jamlab.theory.cascade import sample_cascade_jumps

Z = 5.0


def linear_levels(slope: float, q_max: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``y = slope q`` on ``[0, q_max]`` in ``k`` levels: ``q_i = q_max (i-1)/(k-1)``, ``y_i`` the
    mean of ``y`` over ``[q_i, q_{i+1}]``, ``y_k = y(q_max)``."""
    q = q_max * np.arange(k) / (k - 1)
    y = np.empty(k)
    y[:-1] = slope * 0.5 * (q[:-1] + q[1:])
    y[-1] = slope * q_max
    return q, y


def first_order_masses(q: np.ndarray, y: np.ndarray) -> np.ndarray:
    dy = np.diff(np.concatenate(([0.0], y)))
    return dy * np.sqrt((1 - q) / np.pi)


def stress_jump_cdf(s: np.ndarray, q: np.ndarray, y: np.ndarray) -> np.ndarray:
    """cdf of ΔΣ among jumps: mixture of ``1 - exp(-s²/(4(1-q_i)))`` with weights the masses."""
    w = first_order_masses(q, y)
    w = w / w.sum()
    return np.sum(w[None, :] * -np.expm1(-(s[:, None] ** 2) / (4 * (1 - q[None, :]))), axis=1)


@pytest.mark.parametrize(
    "q,y,dg",
    [
        (np.array([0.0, 0.3, 0.6, 0.85]), np.array([0.6, 1.0, 1.8, 3.0]), 0.02),
        (*linear_levels(2.5, 0.9, 32), 0.02),
    ],
)
def test_jump_rate_and_overlap_masses(q, y, dg):
    masses = first_order_masses(q, y)
    rate = masses.sum()
    n = int(6000 / (rate * dg))
    r = sample_cascade_jumps(q, y, dg, n, seed=31)
    p = float(np.mean(r.jumped))
    p_th = rate * dg
    tol = Z * np.sqrt(p_th / n) + 1.5 * dg * p_th
    assert abs(p - p_th) < tol, (p / dg, rate)
    # overlap density: the atoms, grouped into at most 4 bins of consecutive levels
    groups = np.array_split(np.arange(q.size), min(4, q.size))
    for g in groups:
        pg = float(np.mean(np.isin(r.q_jump, q[g])))
        pg_th = masses[g].sum() * dg
        tol = Z * np.sqrt(pg_th / n) + 1.5 * dg * pg_th
        assert abs(pg - pg_th) < tol, (q[g], pg / dg, pg_th / dg)


def test_stress_jump_density():
    q, y = linear_levels(2.5, 0.9, 16)
    dg = 0.01
    rate = first_order_masses(q, y).sum()
    n = int(5000 / (rate * dg))
    r = sample_cascade_jumps(q, y, dg, n, seed=32)
    s = r.dSigma[r.jumped]
    # at first order every jump raises the stress
    assert np.mean(s > 0) > 1 - 0.05
    ks = stats.kstest(s, lambda x: stress_jump_cdf(np.atleast_1d(x), q, y)).statistic
    crit = np.sqrt(-0.5 * np.log(1e-6 / 2)) / np.sqrt(s.size)
    assert ks < crit + 2 * dg, ks
    # first moment per unit δγ: Σ_i Δy_i ∫ s² φ_{2(1-q_i)}(s) ds over s > 0 = Σ Δy_i (1-q_i)
    dy = np.diff(np.concatenate(([0.0], y)))
    m1 = float(np.sum(np.where(r.jumped, r.dSigma, 0.0))) / (n * dg)
    m1_th = float(np.sum(dy * (1 - q)))
    se = np.std(np.where(r.jumped, r.dSigma, 0.0)) / np.sqrt(n) / dg
    assert abs(m1 - m1_th) < Z * se + 1.5 * dg * m1_th, (m1, m1_th)
    # the density as printed (4π(1-q) in both places): levels weighted by Δy_i, widths √π larger
    def printed_cdf(x):
        x = np.atleast_1d(x)
        w = dy / dy.sum()
        return np.sum(w[None, :] * -np.expm1(-(x[:, None] ** 2) / (4 * np.pi * (1 - q))), axis=1)

    assert stats.kstest(s, printed_cdf).statistic > 5 * (crit + 2 * dg)
