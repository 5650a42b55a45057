"""Exponent helpers against the numbers quoted in SPEC §1 and the paper."""

import numpy as np
import pytest

from jamlab.theory import kappa, mu_jamming, tau_from_mu, tau_jamming


def test_jamming_values_from_spec():
    assert mu_jamming() == pytest.approx(0.706346, abs=5e-7)
    assert tau_jamming() == pytest.approx(1.412693, abs=5e-7)
    assert kappa() == pytest.approx(1.415736, abs=5e-7)
    theta = 0.42311
    # the two forms quoted in SPEC: (3+θ)/(2+θ) = 1 + 1/(2+θ)
    assert tau_jamming(theta) == pytest.approx(1 + 1 / (2 + theta), rel=1e-15)


def test_unsat_and_sk_limit():
    assert tau_from_mu(0.5) == 1.0


@pytest.mark.parametrize("bad", [0.0, 1.0, -0.2, float("nan")])
def test_tau_from_mu_rejects_bad_mu(bad):
    with pytest.raises(ValueError, match="mu"):
        tau_from_mu(bad)


def test_mu_jamming_rejects_bad_theta():
    with pytest.raises(ValueError, match="theta"):
        mu_jamming(-3.0)


@pytest.mark.parametrize("bad", [-1.0, -1.5, -1.9, -2.0, -2.5, -5.0, float("nan"), float("inf")])
def test_theta_outside_physical_range_is_refused(bad):
    """θ <= -1 gives μ_J = (3+θ)/(2(2+θ)) outside (1/2, 1) (μ_J(-1.5) = 1.5, κ(-1.9) = 0.18
    used to be returned): refused by mu_jamming, kappa and tau_jamming alike."""
    for f in (mu_jamming, kappa, tau_jamming):
        with pytest.raises(ValueError, match=r"theta must be a finite number > -1.*got"):
            f(bad)


@pytest.mark.parametrize("theta", [-0.999, -0.5, 0.0, 0.42311, 10.0])
def test_theta_in_range_gives_mu_in_tau_range(theta):
    mu = mu_jamming(theta)
    assert 0.5 < mu < 1.0
    assert mu == (3.0 + theta) / (2.0 * (2.0 + theta))
    assert kappa(theta) == 1.0 / mu and tau_jamming(theta) == 2.0 * mu


def test_numpy_scalars_are_numbers():
    assert mu_jamming(np.float64(0.42311)) == mu_jamming(0.42311)
    assert mu_jamming(np.int64(0)) == 0.75
    assert kappa(np.float32(0.5)) == kappa(0.5)
    assert tau_from_mu(np.float64(0.75)) == 1.5


@pytest.mark.parametrize("bad", [0.3, 0.4999, 0.1])
def test_tau_from_mu_refuses_mu_below_one_half(bad):
    """τ = 2μ holds only for 1/2 <= μ < 1 (SPEC §1); tau_from_mu(0.3) used to return 0.6."""
    with pytest.raises(ValueError, match=r"mu must lie in \[1/2, 1\) \(tau = 2 mu holds only"):
        tau_from_mu(bad)
    assert tau_from_mu(0.5) == 1.0 and tau_from_mu(0.99) == 1.98
