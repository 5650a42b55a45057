"""``jamlab.analysis.size_difference``: τ of two sizes in one window, with packings as units —
checked on sizes drawn from known laws (independent avalanches, a shift of τ, packings that
differ) and the combined scores against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.analysis import combined_scores, size_difference
from law_draws import cutoff_power_law

X_MIN = 1.0


def _packings(rng, taus, s_c: float, m: int) -> list[np.ndarray]:
    return [cutoff_power_law(rng, t, s_c, m, X_MIN) for t in taus]


def test_independent_avalanches_give_the_asymptotic_error():
    """Every avalanche independent (one law for all packings): the packing bootstrap's σ of Δτ
    is the asymptotic one, and the two sizes' τ are the law's."""
    rng = np.random.default_rng(1)
    groups = {500: _packings(rng, [1.5] * 40, 50.0, 60),
              1000: _packings(rng, [1.5] * 20, 100.0, 120)}
    r = size_difference(groups, X_MIN, boot=400, seed=0)
    assert r.n == (500, 1000) and r.packings == (40, 20) and r.tails == (2400, 2400)
    assert abs(r.tau[0] - 1.5) < 4 * r.sigma[0] and abs(r.tau[1] - 1.5) < 4 * r.sigma[1]
    assert 0.8 < r.boot_sigma / np.hypot(*r.sigma) < 1.25
    assert abs(r.z_boot) < 4 and 0.0 < r.fraction_not_above < 1.0
    assert r.delta == r.tau[1] - r.tau[0]


def test_a_shift_of_tau_is_found():
    rng = np.random.default_rng(2)
    groups = {250: _packings(rng, [1.3] * 30, 200.0, 100),
              500: _packings(rng, [1.7] * 30, 200.0, 100)}
    r = size_difference(groups, X_MIN, boot=200, seed=0)
    assert abs(r.delta - 0.4) < 4 * r.boot_sigma and r.z_boot > 5
    assert r.fraction_not_above == 0.0


def test_packings_that_differ_widen_the_error():
    """Each packing with its own τ (spread 0.25): the avalanches of one packing are not
    independent draws of the pooled law, and resampling packings shows it."""
    rng = np.random.default_rng(3)
    groups = {n: _packings(rng, rng.normal(1.6, 0.25, 20).clip(1.15, None), 100.0, 150)
              for n in (500, 1000)}
    r = size_difference(groups, X_MIN, boot=300, seed=0)
    assert r.boot_sigma > 1.5 * np.hypot(*r.sigma)


def test_two_sizes_give_the_slope_of_their_difference():
    """With two sizes the slope dτ/d ln N is Δτ / ln(N₁/N₀), its resampled σ is Δτ's over the
    same ratio, and the two z are one."""
    rng = np.random.default_rng(6)
    groups = {500: _packings(rng, [1.5] * 10, 50.0, 60), 1000: _packings(rng, [1.6] * 10, 90.0, 60)}
    r = size_difference(groups, X_MIN, boot=30, seed=0)
    assert r.slope == pytest.approx(r.delta / np.log(2.0), rel=1e-12)
    assert r.slope_sigma == pytest.approx(r.boot_sigma / np.log(2.0), rel=1e-12)
    assert r.z_slope == pytest.approx(r.z_boot, rel=1e-12)


def test_three_sizes_a_slope_in_log_n_is_found():
    """τ = 1.3, 1.5, 1.7 at N = 250, 500, 1000 (a slope 0.2 / ln 2 in ln N) is found within its
    resampled σ and told from 0; the slope is numpy's least-squares line through the three
    fits; Δτ is the largest N's against the smallest's. One τ at every N: no slope found."""
    rng = np.random.default_rng(7)
    ns = (250, 500, 1000)
    taus = dict(zip(ns, (1.3, 1.5, 1.7), strict=True))
    groups = {n: _packings(rng, [taus[n]] * 15, 100.0, 80) for n in ns}
    r = size_difference(groups, X_MIN, boot=60, seed=0)
    assert r.n == ns and len(r.tau) == len(r.sigma) == len(r.tails) == 3
    assert r.slope == pytest.approx(np.polyfit(np.log(ns), r.tau, 1)[0], rel=1e-10)
    assert abs(r.slope - 0.2 / np.log(2.0)) < 4 * r.slope_sigma and r.z_slope > 5
    assert r.delta == r.tau[2] - r.tau[0]
    flat = {n: _packings(rng, [1.5] * 15, 100.0, 80) for n in ns}
    assert abs(size_difference(flat, X_MIN, boot=60, seed=0).z_slope) < 4


def test_the_combined_scores_are_the_normal_and_chi2_ones():
    chi2, p_chi2, s, p_s = combined_scores([1.0, -1.0, 2.0])
    assert chi2 == pytest.approx(6.0) and s == pytest.approx(2.0 / np.sqrt(3.0))
    # χ²_3 survival at 6 and the two-sided normal p at 2/√3, by their closed forms
    from math import erfc, exp, pi, sqrt

    assert p_chi2 == pytest.approx(erfc(sqrt(3.0)) + sqrt(2 * 6.0 / pi) * exp(-3.0), rel=1e-12)
    assert p_s == pytest.approx(erfc(2.0 / np.sqrt(3.0) / sqrt(2.0)), rel=1e-12)


def test_bad_groups_are_refused():
    rng = np.random.default_rng(4)
    one = {500: _packings(rng, [1.5] * 3, 10.0, 20)}
    with pytest.raises(ValueError, match="need two sizes N or more"):
        size_difference(one, X_MIN, boot=10)
    two = {**one, 1000: [np.array([0.5, 0.7])]}
    with pytest.raises(ValueError, match="N = 1000: 0 sizes at or above"):
        size_difference(two, X_MIN, boot=10)
    with pytest.raises(ValueError, match="boot must be >= 2"):
        size_difference({**one, 1000: one[500]}, X_MIN, boot=1)


def test_strain_step_slopes_pair_the_resamples_and_extrapolate():
    """``strain_step_slopes``: with the same packings at k = 1 and 2 the rows and their σ are one
    and the extrapolation 2 τ(δγ) − τ(2 δγ) is that row again; the k = 1 row is
    ``size_difference``'s slope and σ (the same packing picks); every slope is numpy's
    least-squares line through its row; a k = 2 whose largest N is flatter moves the
    extrapolated τ of that N up by the difference."""
    from jamlab.analysis import strain_step_slopes

    rng = np.random.default_rng(8)
    ns = (250, 500, 1000)
    one = {n: _packings(rng, [1.5] * 12, 100.0, 80) for n in ns}
    r = strain_step_slopes({1: one, 2: one}, X_MIN, boot=40, seed=3)
    assert r.k == (1, 2) and r.n == ns and r.tau.shape == (3, 3)
    np.testing.assert_array_equal(r.tau[0], r.tau[1])
    np.testing.assert_array_equal(r.tau[2], r.tau[0])
    assert r.slope_sigma[0] == r.slope_sigma[1] == r.slope_sigma[2]
    d = size_difference(one, X_MIN, boot=40, seed=3)
    assert r.slope[0] == pytest.approx(d.slope, rel=1e-12)
    assert r.slope_sigma[0] == pytest.approx(d.slope_sigma, rel=1e-12)
    for row, slope in zip(r.tau, r.slope, strict=True):
        assert slope == pytest.approx(np.polyfit(np.log(ns), row, 1)[0], rel=1e-10)
    two = {**one, 1000: _packings(rng, [1.3] * 12, 100.0, 80)}
    s = strain_step_slopes({1: one, 2: two, 4: two}, X_MIN, boot=40, seed=3)
    assert s.k == (1, 2, 4) and s.tau.shape == (4, 3)
    assert s.tau[3, 2] == 2 * s.tau[0, 2] - s.tau[1, 2] and s.tau[3, 2] > s.tau[0, 2]
    assert s.slope[1] < s.slope[0] < s.slope[3]


def test_strain_step_slopes_refusals():
    from jamlab.analysis import strain_step_slopes

    rng = np.random.default_rng(9)
    g = {n: _packings(rng, [1.5] * 4, 100.0, 40) for n in (250, 500)}
    fewer = {250: g[250][:3], 500: g[500]}
    for groups, boot in (({1: g}, 10), ({1: g, 4: g}, 10), ({1: g, 2: g}, 1),
                         ({1: g, 2: fewer}, 10), ({1: g, 2: {250: g[250]}}, 10)):
        with pytest.raises(ValueError):
            strain_step_slopes(groups, X_MIN, boot=boot)
