"""Power-law MLE: closed forms, quadrature, scipy distributions and the `powerlaw` package."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy import integrate, stats
from scipy.optimize import minimize_scalar

from jamlab.analysis import (
    fit_power_law,
    mle_tau,
    power_law_cdf,
    power_law_loglik,
    power_law_pdf,
    sample_power_law,
)

powerlaw = pytest.importorskip("powerlaw")


def _pl_fit(data, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return powerlaw.Fit(data, discrete=False, verbose=False, **kw)


def _pl_loglik(data, tau, x_min, x_max):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dist = powerlaw.Power_Law(
            xmin=x_min, xmax=x_max, parameters=[tau], discrete=False, verbose=0
        )
        return float(np.sum(np.log(dist.pdf(data))))


# --- model functions -------------------------------------------------------------------------


@pytest.mark.parametrize("tau", [0.5, 1.0 - 1e-9, 1.0, 1.0 + 1e-9, 1.41, 2.5])
def test_truncated_loglik_against_quadrature(tau):
    a, b = 0.3, 2.0e3
    x = sample_power_law(1.2, a, b, 300, seed=1)
    norm, _ = integrate.quad(lambda v: v**-tau, a, b, limit=200, points=[1, 10, 100])
    direct = float(np.sum(-tau * np.log(x))) - x.size * math.log(norm)
    assert power_law_loglik(x, tau, a, b) == pytest.approx(direct, rel=1e-9)


@pytest.mark.parametrize(("tau", "x_max"), [(1.5, None), (1.0, 50.0), (0.7, 50.0), (2.2, 50.0)])
def test_cdf_is_integral_of_pdf(tau, x_max):
    a = 2.0
    for x in [2.5, 7.0, 40.0]:
        integral, _ = integrate.quad(lambda v: power_law_pdf(v, tau, a, x_max), a, x)
        assert power_law_cdf(x, tau, a, x_max) == pytest.approx(integral, rel=1e-9)
    top = x_max if x_max is not None else np.inf
    total, _ = integrate.quad(lambda v: power_law_pdf(v, tau, a, x_max), a, top)
    assert total == pytest.approx(1.0, rel=1e-8)


def test_sampler_matches_scipy_distributions():
    pure = sample_power_law(1.5, 2.0, None, 4000, seed=3)
    assert stats.kstest(pure, stats.pareto(b=0.5, scale=2.0).cdf).pvalue > 1e-3
    flat = sample_power_law(1.0, 1.0, 1e4, 4000, seed=4)
    assert stats.kstest(flat, stats.loguniform(1.0, 1e4).cdf).pvalue > 1e-3
    trunc = sample_power_law(1.41, 1.0, 1e3, 4000, seed=5)
    # scipy's truncpareto: density ∝ x^(−b−1) on [scale, c·scale]
    assert stats.kstest(trunc, stats.truncpareto(b=0.41, c=1e3).cdf).pvalue > 1e-3
    assert trunc.min() >= 1.0 and trunc.max() <= 1e3


# --- MLE at fixed cut-offs ------------------------------------------------------------------


@pytest.mark.parametrize("tau", [1.41, 1.5])
def test_pure_mle_equals_powerlaw_package(tau):
    x = sample_power_law(tau, 1.0, None, 5000, seed=11)
    fit = fit_power_law(x, x_min=1.0)
    ref = _pl_fit(x, xmin=1.0).power_law
    assert fit.tau == pytest.approx(ref.alpha, rel=1e-12)
    assert fit.tau_stderr == pytest.approx(ref.standard_err, rel=1e-12)
    assert abs(fit.tau - tau) < 4 * fit.tau_stderr
    # powerlaw evaluates the empirical CDF at data points only: same D to within 1/n
    assert abs(fit.ks_distance - ref.D) <= 1.0 / fit.n_tail + 1e-12


@pytest.mark.parametrize(("tau", "x_max"), [(1.0, 1e4), (1.41, 1e3), (1.5, 1e4), (0.8, 1e3)])
def test_truncated_mle_maximises_powerlaw_package_likelihood(tau, x_max):
    x = sample_power_law(tau, 1.0, x_max, 5000, seed=12)
    fit = fit_power_law(x, x_min=1.0, x_max=x_max)
    assert fit.loglik == pytest.approx(_pl_loglik(x, fit.tau, 1.0, x_max), rel=1e-10)
    best = minimize_scalar(
        lambda t: -_pl_loglik(x, t, 1.0, x_max),
        bounds=(fit.tau - 0.1, fit.tau + 0.1),
        method="bounded",
        options={"xatol": 1e-10},
    )
    assert best.x == pytest.approx(fit.tau, rel=1e-6)
    assert abs(fit.tau - tau) < 4 * fit.tau_stderr


def test_truncated_mle_near_one_matches_powerlaw_fit():
    # For τ̂ ≤ 1.5 powerlaw.Fit maximises its truncated likelihood numerically (Nelder–Mead,
    # tol 1e-4); above 1.5 it returns the pure closed form even with xmax, so compare here only.
    x = sample_power_law(1.0, 1.0, 1e4, 5000, seed=13)
    fit = fit_power_law(x, x_min=1.0, x_max=1e4)
    assert _pl_fit(x, xmin=1.0, xmax=1e4).power_law.alpha == pytest.approx(fit.tau, abs=1e-3)


def test_tau_exactly_one_for_log_symmetric_data():
    # Data symmetric in log x about the centre of [x_min, x_max] have mean(t) = L/2 = h'(0) L
    t = np.linspace(0.1, 0.9, 41) * math.log(1e3)
    tau, err = mle_tau(np.exp(t), 1.0, 1e3)
    assert tau == pytest.approx(1.0, abs=1e-12)
    var_t = (1 / 12) * math.log(1e3) ** 2  # variance of log x under the log-uniform law
    assert err == pytest.approx(1 / math.sqrt(41 * var_t), rel=1e-10)


@pytest.mark.parametrize(("tau", "x_max"), [(1.0, 1e3), (1.41, 1e3), (1.5, None)])
def test_stderr_matches_spread_over_repetitions(tau, x_max):
    rng = np.random.default_rng(21)
    taus, errs = [], []
    for _ in range(300):
        t, e = mle_tau(sample_power_law(tau, 1.0, x_max, 400, seed=rng), 1.0, x_max)
        taus.append(t)
        errs.append(e)
    assert np.std(taus, ddof=1) == pytest.approx(np.mean(errs), rel=0.15)
    assert abs(np.mean(taus) - tau) < 4 * np.std(taus) / math.sqrt(300) + 3 * np.mean(errs) / 400


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(min_value=1.0, max_value=100.0), min_size=2, max_size=40),
    st.floats(min_value=1.5, max_value=1e3),
)
@example(values=[1.0, 1.0078125], x_max_factor=2.0)  # τ̂ ≈ 257: once underflowed the test's weight
def test_truncated_mle_solves_score_equation(values, x_max_factor):
    x = np.array(values)
    x_max = 100.0 * x_max_factor
    big_l = math.log(x_max)
    t = np.log(x)
    if np.ptp(t) == 0 and t[0] in (0.0, big_l):
        return
    tau, _ = mle_tau(x, 1.0, x_max)
    # score = 0  <=>  mean(log x) = E_τ[log x], with E_τ by quadrature over t in [0, L]
    # weight e^{(1−τ)s} divided by its maximum over [0, L], so it never underflows everywhere
    log_w_max = max(0.0, (1 - tau) * big_l)
    w = lambda s: math.exp((1 - tau) * s - log_w_max)  # noqa: E731 - scaled weight
    # the weight is concentrated within ~1/|1−τ| of one end: tell quad where to look
    scale = min(big_l, 1.0 / max(abs(1 - tau), 1e-300))
    pts = [p for p in (scale, big_l - scale) if 0 < p < big_l]
    num, _ = integrate.quad(lambda s: s * w(s), 0, big_l, epsabs=0, epsrel=1e-12, points=pts)
    den, _ = integrate.quad(w, 0, big_l, epsabs=0, epsrel=1e-12, points=pts)
    assert num / den == pytest.approx(t.mean(), rel=1e-7, abs=1e-9 * big_l)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(min_value=1.0, max_value=1e6), min_size=2, max_size=40))
def test_pure_mle_solves_score_equation(values):
    x = np.array(values)
    if np.all(x == 1.0):
        return
    tau, err = mle_tau(x, 1.0)
    # d/dτ [n log(τ−1) − τ Σ log x] = n/(τ−1) − Σ log x
    assert x.size / (tau - 1) == pytest.approx(np.sum(np.log(x)), rel=1e-10)
    assert err == pytest.approx((tau - 1) / math.sqrt(x.size), rel=1e-12)


# --- free x_min, bootstrap, goodness of fit ---------------------------------------------------


@pytest.mark.parametrize(
    ("tau", "x_max"), [(1.0, 1e4), (1.41, None), (1.41, 1e4), (1.5, None), (1.5, 1e4)]
)
def test_recovery_with_free_xmin_and_bootstrap(tau, x_max):
    x = sample_power_law(tau, 1.0, x_max, 2000, seed=31)
    fit = fit_power_law(x, x_max=x_max, n_boot=80, seed=32, max_candidates=60)
    assert fit.method == ("pure" if x_max is None else "truncated")
    assert abs(fit.tau - tau) < 4 * fit.tau_stderr
    assert fit.ci_low <= tau <= fit.ci_high
    assert fit.ci_low < fit.tau < fit.ci_high


@pytest.mark.parametrize("tau", [1.41, 1.5])
def test_xmin_lands_in_tail_and_agrees_with_powerlaw(tau):
    rng = np.random.default_rng(41)
    x_tail = 3.0
    body = np.exp(rng.normal(-1.0, 0.4, 1000))  # P(body > x_tail) ~ 1e-8
    x = np.concatenate([body, sample_power_law(tau, x_tail, None, 1500, seed=rng)])
    fit = fit_power_law(x)
    assert fit.x_min >= 0.9 * x_tail
    assert abs(fit.tau - tau) < 4 * fit.tau_stderr
    ref = _pl_fit(x)
    assert ref.xmin >= 0.9 * x_tail
    assert abs(fit.tau - ref.power_law.alpha) < 4 * max(fit.tau_stderr, ref.power_law.standard_err)


def test_goodness_of_fit_separates_power_law_from_exponential():
    good = sample_power_law(1.5, 1.0, None, 800, seed=51)
    bad = np.random.default_rng(52).exponential(1.0, 800) + 1.0
    p_good = fit_power_law(good, x_min=1.0, n_gof=60, seed=53).p_value
    p_bad = fit_power_law(bad, x_min=1.0, n_gof=60, seed=53).p_value
    assert p_good > 0.05
    assert p_bad < 0.05


def test_invalid_input_messages():
    with pytest.raises(ValueError, match="tau"):
        sample_power_law(1.0, 1.0, None, 10, seed=0)
    with pytest.raises(ValueError, match="x_max"):
        fit_power_law([1.0, 2.0, 3.0], x_min=2.0, x_max=1.0)
    with pytest.raises(ValueError, match="NaN"):
        fit_power_law([1.0, np.nan])
    with pytest.raises(ValueError, match="min_tail"):
        fit_power_law(np.arange(1.0, 10.0), min_tail=50)
