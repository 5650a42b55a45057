"""Input that would give a plausible-looking but wrong number is refused (an audit of the public
analysis functions, 2026-12-06): each case here returned a value before. The valid neighbour of
each case still gives its result, checked against a closed form where there is one."""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.analysis import (
    avalanche_sizes,
    cutoff_shape_profile,
    fit_cutoff_power_law,
    fit_power_law,
    jumps_from_trace,
    mle_tau,
    moduli_from_trace,
)
from jamlab.analysis.cutoff_powerlaw import TAU_BOUNDS


def test_a_single_value_fixes_no_exponent():
    for fit in (lambda: fit_cutoff_power_law(np.ones(20), x_min=1.0),
                lambda: cutoff_shape_profile(np.ones(20), 1.0)):
        with pytest.raises(ValueError, match="a single value fixes no exponent"):
            fit()


def test_tau_on_its_search_bound_is_flagged():
    """Data that rise with x (density ∝ x on [1, 11]) have no decreasing power law: the fit ends
    on τ's lower bound and says so; a Pareto sample (τ = 1.5, no cut-off) does not."""
    rising = np.sqrt(np.random.default_rng(0).random(100)) * 10 + 1
    f = fit_cutoff_power_law(rising, x_min=1.0)
    assert f.tau == pytest.approx(TAU_BOUNDS[0]) and f.tau_at_bound
    pareto = np.random.default_rng(0).pareto(0.5, 500) + 1.0
    g = fit_cutoff_power_law(pareto, x_min=1.0)
    assert not g.tau_at_bound and 1.3 < g.tau < 1.7
    # numpy scalars are numbers: the same fit
    assert fit_cutoff_power_law(pareto, x_min=np.float32(1.0)).tau == g.tau


def test_mle_tau_refuses_nan_and_inf():
    for bad in ([np.nan, 2.0, 3.0], [np.inf, 2.0, 3.0]):
        with pytest.raises(ValueError, match="NaN or inf"):
            mle_tau(bad, 1.0)
    # the closed form of the pure model, τ = 1 + n / Σ log(x/x_min)
    x = np.array([2.0, 3.0, 5.0])
    assert mle_tau(x, 1.0)[0] == pytest.approx(1 + 3 / np.log(x).sum(), rel=1e-14)


def test_fit_power_law_with_x_min_given_needs_two_tail_data():
    with pytest.raises(ValueError, match="1 datum in x >= 1.5"):
        fit_power_law([1.0, 2.0], x_min=1.5)
    f = fit_power_law([1.0, 2.0, 3.0], x_min=1.5)
    assert f.n_tail == 2
    assert f.tau == pytest.approx(1 + 2 / np.log(np.array([2.0, 3.0]) / 1.5).sum(), rel=1e-14)


def test_moduli_lags_are_integers():
    stress = np.cumsum(np.random.default_rng(0).normal(size=(3, 21)), axis=1)
    for lags in ([1.5], [np.nan]):
        with pytest.raises(ValueError, match="lags must be integers"):
            moduli_from_trace(stress, 1e-3, lags)
    with pytest.raises(ValueError, match="strain_step"):
        moduli_from_trace(stress, np.inf, [1])
    m = moduli_from_trace(stress, 1e-3, [2.0])  # an integral float is a lag
    # lag 2, overlapping: the mean of (Σ_{n+2} − Σ_n)/(2 δγ) over n, averaged over samples
    want = np.mean([np.mean((s[2:] - s[:-2]) / 2e-3) for s in stress])
    assert m.strain_step[0] == 2e-3 and m.mu1[0] == pytest.approx(want, rel=1e-12)


def test_inf_jumps_and_repeated_strains_are_refused():
    with pytest.raises(ValueError, match="inf"):
        avalanche_sizes([-np.inf, -1.0], plastic=[True, True])
    # NaN is a missing step (ensembles of unequal length): not counted
    assert avalanche_sizes([-1.0, np.nan, -2.0], plastic=[True] * 3).tolist() == [1.0, 2.0]
    with pytest.raises(ValueError, match="the strain repeats at step 1"):
        jumps_from_trace([0.0, 1.0, 1.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    de, ds, dg = jumps_from_trace([0.0, 1.0, 3.0], [0.0, 2.0, 1.0], [1.0, 2.0, 0.0])
    # ΔE_n = E_{n+1} − E_n − δγ_n Σ_n
    assert de.tolist() == [1.0, -5.0] and ds.tolist() == [1.0, -2.0] and dg.tolist() == [1.0, 2.0]
