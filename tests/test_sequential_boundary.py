"""``scripts/sequential_boundary.py`` against independent values: Pocock's published constants
(Jennison & Turnbull 2000, Table 2.1, α = 0.05 two-sided), the bivariate normal CDF of scipy
(Genz's algorithm) for two looks, a Monte Carlo of the correlated z's for unequal looks, and its
refusals (exit code 2)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal, norm

from script_helpers import script_module


@pytest.fixture(scope="module")
def sb():
    return script_module("sequential_boundary")


def test_pocock_constants(sb):
    published = {1: 1.960, 2: 2.178, 3: 2.289, 4: 2.361, 5: 2.413}
    for k, c in published.items():
        sigma = 1.0 / np.sqrt(np.arange(1, k + 1))  # equal increments of information
        assert sb.boundary(sigma) == pytest.approx(c, abs=6e-4)


def test_two_looks_against_the_bivariate_normal(sb):
    sigma = np.array([0.03, 0.02])
    rho = sigma[1] / sigma[0]
    c = 2.1
    stay = multivariate_normal(mean=[0, 0], cov=[[1, rho], [rho, 1]]).cdf(
        [c, c], lower_limit=[-c, -c])
    assert sb.stay_probability(c, 1.0 / sigma**2) == pytest.approx(stay, abs=2e-5)


def test_unequal_looks_against_monte_carlo(sb):
    sigma = np.array([0.021, 0.017, 0.0165, 0.016])
    info = 1.0 / sigma**2
    rng = np.random.default_rng(7)
    m = 400_000
    score = np.cumsum(rng.standard_normal((m, sigma.size)) * np.sqrt(np.diff(info, prepend=0)),
                      axis=1)
    z = np.abs(score / np.sqrt(info)).max(axis=1)
    c = sb.boundary(sigma)
    crossed = np.mean(z > c)
    assert abs(crossed - 0.05) < 4 * np.sqrt(0.05 * 0.95 / m)
    naive = np.mean(z > norm.isf(0.025))
    exact = 1 - sb.stay_probability(norm.isf(0.025), info)
    assert abs(naive - exact) < 4 * np.sqrt(exact * (1 - exact) / m)
    assert exact > 0.05  # several looks cross the single-look rule more often


@pytest.mark.parametrize("argv", [["--sigma", "0.02", "0.03"], ["--sigma", "0.02", "0.02"],
                                  ["--sigma", "-0.01"], ["--sigma", "0.02", "--alpha", "1.5"]])
def test_refusals(sb, argv):
    with pytest.raises(SystemExit) as err:
        sb.main(argv)
    assert err.value.code == 2


def test_prints_the_boundary(sb, capsys):
    sb.main(["--sigma", "1", str(1 / np.sqrt(2))])
    out = capsys.readouterr().out
    assert "boundary |z| > 2.178" in out
