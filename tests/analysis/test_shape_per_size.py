"""One τ for sizes whose cut-off moves in scale and shape (jamlab.analysis.shape_per_size)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jamlab.analysis.cutoff_powerlaw import (
    cutoff_power_law_logpdf,
    cutoff_shape_profile,
    sample_cutoff_power_law,
)
from jamlab.analysis.shape_per_size import fixed_tau_loglik, shared_tau

X_MIN = 1e-8


def packings(rng, total, tau, x_c, a, count=20):
    return [sample_cutoff_power_law(total // count, tau, x_c, X_MIN, rng, stretch=a)
            for _ in range(count)]


@pytest.mark.parametrize(("tau", "a"), [(1.3, 1.0), (1.45, 0.4), (1.1, 1.7)])
def test_fixed_tau_profile_is_the_brute_force_maximum(tau, a):
    """The profile over x_c against the log-likelihood summed from the pdf on a dense grid of
    x_c: the maximum found is the vertex of the parabola through the grid's best point and its
    neighbours (the log-likelihood is smooth in log x_c there)."""
    x = sample_cutoff_power_law(800, 1.3, 1e-6, X_MIN, np.random.default_rng(7), stretch=0.6)
    ll, x_c = fixed_tau_loglik(x, X_MIN, tau, a)
    grid = np.exp(np.linspace(np.log(1e-8), np.log(1e-3), 4001))
    brute = np.array([cutoff_power_law_logpdf(x, tau, c, X_MIN, stretch=a).sum() for c in grid])
    k = int(np.argmax(brute))
    assert 0 < k < grid.size - 1
    assert ll >= brute[k] - 1e-9
    lo, mid, hi = brute[k - 1 : k + 2]
    vertex = mid + (hi - lo) ** 2 / (8.0 * (2.0 * mid - lo - hi))
    assert ll == pytest.approx(vertex, abs=1e-6)
    assert grid[max(k - 1, 0)] <= x_c <= grid[min(k + 1, grid.size - 1)]


def test_profile_over_tau_meets_the_two_parameter_fit():
    """Maximised over τ as well, the fixed-τ profile gives the log-likelihood of
    cutoff_shape_profile's two-parameter fit at each shape (another optimiser)."""
    x = sample_cutoff_power_law(1500, 1.35, 3e-7, X_MIN, np.random.default_rng(11), stretch=0.7)
    shapes = (0.5, 1.0)
    prof = cutoff_shape_profile(x, X_MIN, shapes)
    for a, tau, ll in zip(prof.stretches, prof.taus, prof.logliks, strict=True):
        taus = np.linspace(tau - 0.01, tau + 0.01, 41)
        best = max(fixed_tau_loglik(x, X_MIN, float(t), a)[0] for t in taus)
        assert best == pytest.approx(ll, abs=2e-4)
        assert fixed_tau_loglik(x, X_MIN, tau, a)[0] == pytest.approx(ll, abs=1e-6)


def test_one_tau_with_moving_shapes_is_not_rejected_and_covers_the_truth():
    rng = np.random.default_rng(3)
    groups = {250: packings(rng, 3000, 1.3, 1e-6, 1.0), 2000: packings(rng, 6000, 1.3, 1e-5, 0.4)}
    r = shared_tau(groups, X_MIN, boot=4, seed=1)
    assert r.n == (250, 2000) and r.tails == (3000, 6000) and r.boot_used == 4
    assert r.tau_low < 1.3 < r.tau_high
    assert r.tau_low < r.tau < r.tau_high
    assert r.p_value > 0.01
    # the separate fits are never worse than the joint one
    assert sum(r.loglik_each) >= r.loglik - 1e-6
    # without resamples: the same joint fit and separate τ, no σ for the slope
    r0 = shared_tau(groups, X_MIN, boot=0, seed=1)
    assert r0.boot_used == 0 and math.isnan(r0.slope_sigma)
    assert (r0.tau, r0.tau_low, r0.tau_high, r0.lr, r0.slope) == (
        r.tau, r.tau_low, r.tau_high, r.lr, r.slope)


def test_different_taus_are_told_apart():
    rng = np.random.default_rng(5)
    groups = {250: packings(rng, 3000, 1.15, 1e-6, 1.0), 2000: packings(rng, 6000, 1.6, 1e-5, 1.0)}
    r = shared_tau(groups, X_MIN, boot=20, seed=2)
    assert r.slope > 0 and r.z_slope > 3
    assert r.p_value < 0.05


def test_bad_input():
    rng = np.random.default_rng(1)
    one = {250: packings(rng, 400, 1.3, 1e-6, 1.0)}
    with pytest.raises(ValueError, match="two sizes"):
        shared_tau(one, X_MIN)
    with pytest.raises(ValueError, match="boot"):
        shared_tau({**one, 500: one[250]}, X_MIN, boot=1)
    with pytest.raises(ValueError, match="boot"):
        shared_tau({**one, 500: one[250]}, X_MIN, boot=-2)
    with pytest.raises(ValueError, match="at least 10"):
        fixed_tau_loglik(np.array([1e-8, 2e-8]), X_MIN, 1.3, 1.0)
