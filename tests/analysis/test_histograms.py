"""Log-binned density histograms: normalisation, bins, Poisson errors."""

import math

import numpy as np
import pytest
from scipy import stats

from jamlab.analysis import log_histogram


def test_density_integrates_to_fraction_in_range(rng):
    x = np.concatenate([rng.pareto(0.5, 3000) + 1.0, np.zeros(200), -np.ones(50)])
    hist = log_histogram(x, bins_per_decade=8, range=(1.0, 1e3))
    inside = np.count_nonzero((x >= 1.0) & (x <= 1e3))
    assert hist.n_in_range == inside
    assert np.sum(hist.density * hist.widths) == pytest.approx(inside / x.size, rel=1e-12)
    per_step = log_histogram(x, bins_per_decade=8, range=(1.0, 1e3), n_total=10 * x.size)
    assert np.sum(per_step.density * per_step.widths) == pytest.approx(inside / (10 * x.size))


def test_matches_numpy_density_on_same_edges(rng):
    x = rng.lognormal(0.0, 2.0, 5000)
    hist = log_histogram(x, bins_per_decade=5)
    ref, _ = np.histogram(x, bins=hist.edges, density=True)
    assert hist.n_in_range == x.size
    np.testing.assert_allclose(hist.density, ref, rtol=1e-12)
    np.testing.assert_allclose(hist.centres, np.sqrt(hist.edges[1:] * hist.edges[:-1]))


def test_default_edges_on_universal_decade_grid(rng):
    x = rng.uniform(0.013, 870.0, 100)
    hist = log_histogram(x, bins_per_decade=4)
    k = np.log10(hist.edges) * 4
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    assert hist.edges[0] <= x.min() and hist.edges[-1] > x.max()
    assert np.all(np.diff(k) == pytest.approx(1.0))


def test_density_agrees_with_pareto_within_poisson_errors():
    tau, n = 1.5, 20000
    x = stats.pareto(b=tau - 1).rvs(size=n, random_state=np.random.default_rng(7))
    hist = log_histogram(x, bins_per_decade=5, range=(1.0, 1e4))
    cdf = stats.pareto(b=tau - 1).cdf(hist.edges)
    expected = np.diff(cdf) / hist.widths
    ok = hist.counts >= 20
    pulls = (hist.density[ok] - expected[ok]) / hist.density_err[ok]
    assert np.all(np.abs(pulls) < 4.5)
    np.testing.assert_allclose(
        hist.density_err[ok], np.sqrt(hist.counts[ok]) / (n * hist.widths[ok])
    )
    chi2 = float(np.sum(pulls**2))
    assert chi2 < stats.chi2(ok.sum()).ppf(0.999)


def test_errors():
    with pytest.raises(ValueError, match="range"):
        log_histogram([1.0, 2.0], range=(0.0, 1.0))
    with pytest.raises(ValueError, match="positive"):
        log_histogram([0.0, -1.0])
    with pytest.raises(ValueError, match="n_total"):
        log_histogram([1.0, 2.0, 3.0], n_total=2)
    assert math.isfinite(log_histogram([5.0]).density.sum())
