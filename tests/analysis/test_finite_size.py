"""Finite-size scaling of avalanche sizes against synthetic ensembles of known ``β``.

The generator is independent of the module: sizes from ``P(S) ∝ S^(−τ) exp(−S/S*)`` on
``S ≥ s_0`` (a Pareto sample thinned by ``exp(−S/S*)``), ``S* = A N^β``. With ``s_0/S* ≤ 1e-4``
the exact cut-off ``⟨S²⟩/⟨S⟩ = S* Γ(3−τ, s_0/S*)/Γ(2−τ, s_0/S*)`` is ``S*(2 − τ)`` to < 0.2 %, so
``S_c ~ N^β`` holds with the generator's ``β``.
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import gamma as gamma_fn
from scipy.special import gammaincc

from jamlab.analysis.finite_size import (
    collapse,
    collapse_quality,
    cutoff_size,
    fit_cutoff_scaling,
)

TAU, BETA, S0, AMP = 1.15, 1.2, 1.0, 1e3
NS = (64, 128, 256, 512)


def _draw(rng, s_star, k):
    out = []
    while len(out) < k:
        s = S0 * (1.0 - rng.random(4 * k + 8)) ** (-1.0 / (TAU - 1.0))
        s = s[rng.random(s.size) < np.exp(-s / s_star)]
        out.extend(s.tolist())
    return np.array(out[:k])


def _ensemble(seed, samples=30, per_sample=20):
    rng = np.random.default_rng(seed)
    return {n: [_draw(rng, AMP * (n / NS[0]) ** BETA, rng.poisson(per_sample))
                for _ in range(samples)] for n in NS}


def _exact_cutoff(s_star):
    a = S0 / s_star
    up = lambda s: gammaincc(s, a) * gamma_fn(s)  # noqa: E731  upper incomplete Γ(s, a)
    return s_star * up(3 - TAU) / up(2 - TAU)


def _moment(k, s_star):
    """``∫_{s_0}^∞ S^(k−τ) exp(−S/S*) dS`` by quadrature in ``u = log S``."""
    f = lambda u: math.exp((k + 1 - TAU) * u - math.exp(u) / s_star)  # noqa: E731
    return quad(f, math.log(S0), math.log(s_star) + 6, limit=200)[0]


def _exact_mean(s_star):
    return _moment(1, s_star) / _moment(0, s_star)


def test_cutoff_size_by_hand():
    assert cutoff_size([1.0, 2.0, 3.0]) == pytest.approx((1 + 4 + 9) / 6)
    assert math.isnan(cutoff_size([]))


def test_beta_recovered_within_its_interval_in_most_trials():
    hits, trials = 0, 60
    betas = []
    for seed in range(trials):
        fit = fit_cutoff_scaling(_ensemble(seed), n_boot=200, seed=seed)
        lo, hi = fit.beta_ci95
        hits += lo <= BETA <= hi
        betas.append(fit.beta)
    assert hits >= 0.9 * trials, (hits, trials)
    betas = np.array(betas)
    # unbiased: the mean over trials within 3 standard errors of the truth
    assert abs(betas.mean() - BETA) < 3 * betas.std(ddof=1) / math.sqrt(trials)


def test_cutoffs_and_mean_against_the_exact_moments():
    fits = [fit_cutoff_scaling(_ensemble(1000 + t), n_boot=50, seed=t) for t in range(30)]
    cut = np.array([f.cutoff for f in fits])
    exact = np.array([_exact_cutoff(AMP * (n / NS[0]) ** BETA) for n in NS])
    # the estimator over independent ensembles: its mean within 3 standard errors of the exact
    # cut-off at every N
    se = cut.std(axis=0, ddof=1) / math.sqrt(len(fits))
    assert np.all(np.abs(cut.mean(axis=0) - exact) < 3 * se), (cut.mean(axis=0), exact, se)
    # ⟨S⟩ against its exact value (the lower cut-off s_0 matters for it: not a pure power of N)
    mean = np.array([f.mean for f in fits])
    exact_mean = np.array([_exact_mean(AMP * (n / NS[0]) ** BETA) for n in NS])
    se = mean.std(axis=0, ddof=1) / math.sqrt(len(fits))
    assert np.all(np.abs(mean.mean(axis=0) - exact_mean) < 3 * se), (mean.mean(0), exact_mean)
    assert _exact_cutoff(1e3) == pytest.approx(_moment(2, 1e3) / _moment(1, 1e3), rel=1e-6)
    ens = _ensemble(1000)
    assert fits[0].avalanches.tolist() == [sum(a.size for a in ens[n]) for n in NS]
    assert fits[0].samples.tolist() == [30] * len(NS)


def test_collapse_is_best_near_the_true_beta():
    ens = _ensemble(5, samples=60)
    pooled = {n: np.concatenate(s) for n, s in ens.items()}
    grid = np.linspace(0.0, 2.4, 49)
    q = collapse_quality(pooled, TAU, grid)
    assert abs(grid[np.nanargmin(q)] - BETA) <= 0.2
    c = collapse(pooled, TAU, BETA)
    assert c.quality == pytest.approx(q[np.argmin(abs(grid - BETA))])
    assert c.quality < 0.5 * collapse(pooled, TAU, 0.0).quality
    assert set(c.x) == set(NS)


def test_bad_input():
    with pytest.raises(ValueError, match="two sizes"):
        fit_cutoff_scaling({64: [np.array([1.0, 2.0])], 128: [np.empty(0)]})
    with pytest.raises(ValueError, match="positive"):
        fit_cutoff_scaling({64: [np.array([1.0, -2.0])], 128: [np.array([1.0])]})
