"""The cut-off's shape test with whole samples as units, against exact identities of the
composite likelihood, the package's two independent fitters, and Monte Carlo.

- Exact: duplicating every avalanche within its sample doubles ``W`` and ``λ̂`` and leaves the
  adjusted test unchanged (the naive one grows more confident: the fallacy the test corrects);
  with each avalanche its own sample the design effect ``λ̂`` is 1.
- The fits at ``a = 1``: ``τ`` of :func:`fit_cutoff_power_law` (one group) and of
  :func:`fit_joint_scaling` (sizes side by side); the free fit is at least as likely as
  ``fit_joint_scaling``'s at fixed ``a``.
- Monte Carlo (``scripts/shape_test_size.py``'s copula, marginal exactly the exponential
  cut-off): ``λ̂ ≈ 1`` for independent sizes, ``λ̂ > 1`` for correlated ones.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module

from jamlab.analysis import (
    clustered_shape_test,
    fit_cutoff_power_law,
    fit_joint_scaling,
    sample_cutoff_power_law,
)


def _samples(seed: int, k: int, m: int, stretch: float, x_c: float = 100.0, tau: float = 1.2
             ) -> list:
    rng = np.random.default_rng(seed)
    return [sample_cutoff_power_law(m, tau, x_c, 1.0, rng, stretch=stretch) for _ in range(k)]


def test_duplicated_avalanches_double_w_and_lambda_not_the_adjusted_test():
    samples = _samples(1, 20, 40, 0.3)
    one = clustered_shape_test(samples, 1.0)
    two = clustered_shape_test([np.concatenate([s, s]) for s in samples], 1.0)
    assert one.lr > 4.0  # the shape is resolved: the identity is not 0 = 2 · 0
    assert two.lr == pytest.approx(2.0 * one.lr, rel=1e-4)
    assert two.scale == pytest.approx(2.0 * one.scale, rel=1e-3)
    assert two.lr / two.scale == pytest.approx(one.lr / one.scale, rel=1e-3)
    assert two.stretch == pytest.approx(one.stretch, rel=1e-4)
    assert two.p_naive < one.p_naive
    assert two.n_tail == 2 * one.n_tail and two.samples == one.samples == 20


def test_one_avalanche_per_sample_has_no_design_effect():
    x = np.concatenate(_samples(5, 1, 300, 1.0, x_c=300.0, tau=1.4))
    r = clustered_shape_test([[v] for v in x], 1.0)
    assert r.samples == 300
    assert r.scale == pytest.approx(1.0, rel=1e-9)


def test_exponential_fit_matches_fit_cutoff_power_law():
    samples = _samples(7, 12, 40, 1.0, x_c=300.0, tau=1.4)
    floor = 2.0
    r = clustered_shape_test(samples, floor)
    x = np.concatenate(samples)
    ref = fit_cutoff_power_law(x[x >= floor], floor)
    assert r.tau_null == pytest.approx(ref.tau, abs=2e-4)
    assert r.n_tail == ref.n_tail


def test_joint_model_matches_fit_joint_scaling():
    rng = np.random.default_rng(11)
    by_n = {n: [sample_cutoff_power_law(30, 1.4, 40.0 * (n / 250) ** 0.8, 1.0, rng,
                                        stretch=0.6) for _ in range(12)]
            for n in (250, 500, 1000)}
    r = clustered_shape_test(by_n, 1.0)
    assert r.n == (250, 500, 1000) and r.samples == 36
    exp_fit = fit_joint_scaling(by_n, 1.0, n_boot=2)
    stretched = fit_joint_scaling(by_n, 1.0, n_boot=2, stretch=0.6)
    assert r.tau_null == pytest.approx(exp_fit.tau, abs=2e-3)
    assert r.lr >= 2.0 * (stretched.loglik - exp_fit.loglik) - 1e-4
    assert 0.35 < r.stretch < 0.95


def test_a_stretched_tail_is_found_with_independent_samples():
    r = clustered_shape_test(_samples(1, 60, 40, 0.3), 1.0)
    assert 0.15 < r.stretch < 0.45 and not r.at_bound
    assert r.p_naive < 1e-4 and r.p_adjusted < 1e-3
    assert r.tau_se_robust > 0 and r.log_stretch_se > 0


def test_scale_measures_the_correlation_within_samples():
    size = script_module("shape_test_size")
    rng = np.random.default_rng(2)
    free = [clustered_shape_test(size.copula_samples(rng, 0.0, 20, 40), 1.0).scale
            for _ in range(8)]
    tied = [clustered_shape_test(size.copula_samples(rng, 0.6, 20, 40), 1.0).scale
            for _ in range(8)]
    assert 0.6 < np.nanmedian(free) < 1.5
    assert np.nanmedian(tied) > 1.5


@pytest.mark.parametrize(("args", "message"), [
    (([np.ones(30)], 0.0), "floor"),
    (([np.full(10, 2.0)] * 2, 1.0), "need >= 3 samples"),
    (({250: [np.full(30, 2.0)] * 3}, 1.0), "two sizes"),
    (([np.array([1.0, -1.0])] * 3, 1.0), "positive"),
])
def test_bad_input(args, message):
    with pytest.raises(ValueError, match=message):
        clustered_shape_test(*args)
