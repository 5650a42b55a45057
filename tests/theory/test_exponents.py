"""Exponent helpers against the numbers quoted in SPEC §1 and the paper."""

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
