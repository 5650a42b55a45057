"""The public analysis helpers refuse NaN/inf (and other impossible numbers) with a one-line
``ValueError`` naming the argument and the value, where they returned NaN or a plausible but
wrong number before. Each refusal sits beside its valid neighbour, checked against a closed form
or a hand calculation."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jamlab.analysis.avalanches import jumps_from_trace, noise_floor
from jamlab.analysis.cutoff_powerlaw import (
    cutoff_power_law_cdf,
    cutoff_power_law_ks,
    cutoff_power_law_logpdf,
    cutoff_shape_profile,
    fit_cutoff_power_law,
)
from jamlab.analysis.exponent_fit import empirical_cdf, finite_size_cutoff, fit_exponent
from jamlab.analysis.finite_size import cutoff_size
from jamlab.analysis.histograms import log_histogram
from jamlab.analysis.moduli import fit_log_slope, moduli_from_stress_jumps
from jamlab.analysis.powerlaw import (
    finite_data,
    fit_power_law,
    power_law_cdf,
    power_law_gof,
    power_law_loglik,
    power_law_pdf,
    sample_power_law,
)

NAN, INF = math.nan, math.inf
MAD_TO_SIGMA = 1.482602218505602

# ---------------------------------------------------------------------------------------------
# 1. fit_log_slope


@pytest.mark.parametrize("which", ["x", "y", "y_err"])
@pytest.mark.parametrize("bad", [NAN, INF])
def test_fit_log_slope_refuses_non_finite(which, bad):
    args = {"x": [1.0, 2.0, 4.0], "y": [3.0, 2.0, 1.5], "y_err": [0.1, 0.1, 0.1]}
    args[which] = list(args[which])
    args[which][1] = bad
    with pytest.raises(ValueError, match=f"^{which} holds NaN or inf: {bad!r} at flat index 1$"):
        fit_log_slope(**args)


def test_fit_log_slope_on_an_exact_power_law():
    """``y = 3 x^(−1/2)``: slope −1/2, intercept log 3, χ² 0."""
    x = np.array([1.0, 2.0, 4.0, 8.0])
    fit = fit_log_slope(x, 3.0 * x**-0.5, [0.1, 0.2, 0.1, 0.3])
    assert fit.slope == pytest.approx(-0.5, abs=1e-14)
    assert fit.intercept == pytest.approx(math.log(3.0), abs=1e-14)
    assert fit.chi2 == pytest.approx(0.0, abs=1e-20) and fit.dof == 2


def test_moduli_from_stress_jumps_refuses_non_finite_strain_steps():
    jumps = [np.full((2, 4), 2e-3), np.full((2, 4), 4e-3)]
    for bad in (NAN, INF):
        with pytest.raises(ValueError, match="strain_steps must be finite and > 0"):
            moduli_from_stress_jumps(jumps, [1e-3, bad])
    # ΔΣ = 2δγ at both steps: ⟨μ_1⟩ = 2, ⟨μ_1²⟩ = 4 (inf gave μ_1 = 0 before)
    m = moduli_from_stress_jumps(jumps, [1e-3, 2e-3])
    np.testing.assert_allclose(m.mu1, [2.0, 2.0], rtol=1e-14)
    np.testing.assert_allclose(m.mu1_sq, [4.0, 4.0], rtol=1e-14)


# ---------------------------------------------------------------------------------------------
# 2. cutoff_size


@pytest.mark.parametrize("bad", [NAN, INF, -INF])
def test_cutoff_size_refuses_non_finite(bad):
    with pytest.raises(ValueError, match=f"^sizes holds NaN or inf: {bad!r} at flat index 1$"):
        cutoff_size([1.0, bad, 3.0])


@pytest.mark.parametrize("bad", [0.0, -2.0])
def test_cutoff_size_refuses_non_positive(bad):
    with pytest.raises(ValueError, match=f"^sizes must be positive, got {bad!r} at flat index 1$"):
        cutoff_size([1.0, bad, 3.0])


def test_cutoff_size_by_hand():
    assert cutoff_size([1.0, 2.0, 3.0]) == pytest.approx((1 + 4 + 9) / (1 + 2 + 3), rel=1e-15)
    assert math.isnan(cutoff_size([]))


# ---------------------------------------------------------------------------------------------
# 3. noise_floor: NaN is a missing step, inf is refused


def _hand_floor() -> tuple[float, float]:
    """δγ = 1, ΔΣ = 2 on every step: r = ΔE − 1 = [0, 0.1, −0.3, 0.3, 0.2] on the five present
    steps; median 0.1, |r − 0.1| = [0.1, 0, 0.4, 0.2, 0.1], median 0.1."""
    return 0.1, MAD_TO_SIGMA * 0.1


def test_noise_floor_leaves_nan_steps_out():
    med, sigma = _hand_floor()
    de = np.array([1.0, 1.1, NAN, 0.7, 1.3, 1.2, 1.0])
    ds = np.array([2.0, 2.0, 2.0, 2.0, 2.0, 2.0, NAN])
    nf = noise_floor(de, ds, 1.0)  # sigma and median were NaN before
    assert nf.n_elastic == 5
    assert nf.median == pytest.approx(med, abs=1e-15)
    assert nf.sigma == pytest.approx(sigma, rel=1e-12)
    assert nf.modulus == 2.0
    # the same with a per-step strain that is NaN exactly where the step is missing
    steps = np.array([1.0, 1.0, NAN, 1.0, 1.0, 1.0, NAN])
    assert noise_floor(de, ds, steps) == nf


def test_noise_floor_of_a_padded_trace():
    """A trace padded with NaN (a shorter sample of an ensemble) through jumps_from_trace."""
    med, sigma = _hand_floor()
    gamma = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, NAN])
    stress = np.array([0.0, 2.0, 4.0, 6.0, 8.0, 10.0, NAN])
    # E_{n+1} = E_n + ΔE_n + δγ Σ_n with ΔE = 1 + r
    energy = np.cumsum([0.0, 1.0, 1.1 + 2.0, 0.7 + 4.0, 1.3 + 6.0, 1.2 + 8.0, NAN])
    de, ds, dg = jumps_from_trace(gamma, energy, stress)
    nf = noise_floor(de, ds, dg)
    assert nf.n_elastic == 5
    assert nf.median == pytest.approx(med, abs=1e-12)
    assert nf.sigma == pytest.approx(sigma, rel=1e-10)


def test_noise_floor_counts_elastic_steps_after_leaving_nan_out():
    match = r"^need >= 3 elastic steps, got 2 \(2 NaN steps left out\)$"
    with pytest.raises(ValueError, match=match):
        noise_floor([1.0, NAN, 1.1, NAN], [2.0, 2.0, 2.0, 2.0], 1.0)


@pytest.mark.parametrize("which", ["energy_jump", "stress_jump", "strain_step"])
@pytest.mark.parametrize("bad", [INF, -INF])
def test_noise_floor_refuses_inf(which, bad):
    args = {"energy_jump": [1.0, 1.1, 0.7, 1.3], "stress_jump": [2.0] * 4,
            "strain_step": [1.0] * 4}
    args[which] = list(args[which])
    args[which][2] = bad
    with pytest.raises(ValueError, match=f"^{which} holds {bad!r} at flat index 2: "):
        noise_floor(**args)


@pytest.mark.parametrize("step", [NAN, [1.0, 1.0, NAN, 1.0]])
def test_noise_floor_refuses_nan_strain_step_of_a_present_step(step):
    with pytest.raises(ValueError, match="^strain_step is NaN at flat index"):
        noise_floor([1.0, 1.1, 0.7, 1.3], [2.0] * 4, step)


# ---------------------------------------------------------------------------------------------
# 4. power laws


@pytest.mark.parametrize("x_max", [None, 10.0])
@pytest.mark.parametrize("tau", [NAN, INF, -INF])
def test_power_law_helpers_refuse_non_finite_tau(tau, x_max):
    # before: NaN, 0 or 1 everywhere (truncated), NaN pdf, cdf 1 and samples all at x_min (pure)
    calls = (
        lambda: power_law_pdf([2.0], tau, 1.0, x_max),
        lambda: power_law_cdf([2.0], tau, 1.0, x_max),
        lambda: power_law_loglik([2.0, 3.0], tau, 1.0, x_max),
        lambda: sample_power_law(tau, 1.0, x_max, size=3),
    )
    for call in calls:
        with pytest.raises(ValueError, match=f"^tau={tau!r} must be finite$"):
            call()


def test_power_law_pdf_and_cdf_at_nan_and_inf_points():
    x = [NAN, INF, 2.0]
    pdf = power_law_pdf(x, 2.5, 1.0)
    cdf = power_law_cdf(x, 2.5, 1.0)
    assert math.isnan(pdf[0]) and pdf[1] == 0.0  # pdf(NaN) was 0 before
    assert math.isnan(cdf[0]) and cdf[1] == 1.0
    # closed forms: p(x) = (τ−1) x^(−τ), F(x) = 1 − x^(1−τ) at x_min = 1
    assert pdf[2] == pytest.approx(1.5 * 2.0**-2.5, rel=1e-14)
    assert cdf[2] == pytest.approx(1.0 - 2.0**-1.5, rel=1e-14)
    trunc = power_law_pdf(x, 1.0, 1.0, 10.0)
    assert math.isnan(trunc[0]) and trunc[1] == 0.0
    assert trunc[2] == pytest.approx(1.0 / (2.0 * math.log(10.0)), rel=1e-14)
    assert power_law_cdf([INF], 1.0, 1.0, 10.0)[0] == 1.0


@pytest.mark.parametrize("x_max", [None, 10.0])
@pytest.mark.parametrize("bad", [NAN, INF])
def test_power_law_loglik_refuses_non_finite_data(bad, x_max):
    # NaN was silently ignored, inf gave −inf (pure) or was ignored (truncated)
    with pytest.raises(ValueError, match=f"^data holds NaN or inf: {bad!r} at flat index 1$"):
        power_law_loglik([2.0, bad], 2.0, 1.0, x_max)


def test_power_law_loglik_closed_form():
    x = np.array([1.5, 2.0, 7.0])
    expected = 3 * math.log(1.2 / 1.0) - 2.2 * float(np.log(x).sum())
    assert power_law_loglik(x, 2.2, 1.0) == pytest.approx(expected, rel=1e-14)


def test_power_law_gof_refuses_a_fit_with_non_finite_tau():
    x = sample_power_law(1.5, 1.0, size=200, seed=1)
    fit = fit_power_law(x, x_min=1.0)
    with pytest.raises(ValueError, match="^tau=inf must be finite$"):  # returned NaN before
        power_law_gof(x, replace(fit, tau=INF), n_sims=3)


def test_finite_data_names_the_argument_and_the_value():
    with pytest.raises(ValueError, match=r"^sizes holds NaN or inf: -inf at flat index 3$"):
        finite_data([[1.0, 2.0], [3.0, -INF]], "sizes")
    np.testing.assert_array_equal(finite_data([[1.0, 2.0], [3.0, 4.0]]), [1.0, 2.0, 3.0, 4.0])


# ---------------------------------------------------------------------------------------------
# 4b. the power law with a cut-off


@pytest.mark.parametrize("stretch", [0.0, -1.0, NAN, INF])
def test_cutoff_cdf_and_logpdf_refuse_a_bad_stretch(stretch):
    # 0 raised ZeroDivisionError and −1 gave a CDF of −201 before
    for call in (lambda: cutoff_power_law_cdf([2.0], 1.5, 10.0, 1.0, stretch=stretch),
                 lambda: cutoff_power_law_logpdf([2.0], 1.5, 10.0, 1.0, stretch)):
        with pytest.raises(ValueError, match=f"^stretch must be finite and > 0, got {stretch!r}$"):
            call()


def test_cutoff_cdf_and_logpdf_at_nan_and_inf_points():
    """τ = 0: ``p(x) = e^(−(x − x_min)/x_c)/x_c``, ``F(x) = 1 − e^(−(x − x_min)/x_c)``."""
    x_c, x_min = 10.0, 1.0
    x = np.array([NAN, INF, -INF, 0.5, 4.0])
    cdf = cutoff_power_law_cdf(x, 0.0, x_c, x_min)  # raised on NaN/inf before
    assert math.isnan(cdf[0])
    np.testing.assert_array_equal(cdf[1:4], [1.0, 0.0, 0.0])
    assert cdf[4] == pytest.approx(-math.expm1(-(4.0 - x_min) / x_c), rel=1e-12)
    assert cutoff_power_law_cdf([INF], 1.5, x_c, x_min, stretch=0.5)[0] == 1.0
    logp = cutoff_power_law_logpdf(x, 0.0, x_c, x_min)
    assert math.isnan(logp[0])  # −inf (a density of 0) before
    np.testing.assert_array_equal(logp[1:4], [-INF, -INF, -INF])
    assert logp[4] == pytest.approx(-(4.0 - x_min) / x_c - math.log(x_c), rel=1e-12)


@pytest.mark.parametrize(("data", "match"), [
    ([2.0, NAN], r"^data holds NaN or inf: nan at flat index 1$"),
    ([2.0, INF], r"^data holds NaN or inf: inf at flat index 1$"),
    ([0.5, 2.0], r"^the data hold 0\.5, below x_min=1\.0: "),
    ([], r"^the data are empty"),
])
def test_cutoff_ks_refuses_bad_data(data, match):
    with pytest.raises(ValueError, match=match):
        cutoff_power_law_ks(data, 1.5, 10.0, 1.0)


def test_cutoff_ks_of_one_datum():
    """One datum at ``x``: ``D = max(1 − F(x), F(x))``, ``F`` the closed form at τ = 0."""
    f = -math.expm1(-(4.0 - 1.0) / 10.0)
    assert cutoff_power_law_ks([4.0], 0.0, 10.0, 1.0) == pytest.approx(max(1 - f, f), rel=1e-12)


def test_cutoff_x_min_any_real_number_but_not_a_bool():
    y = sample_power_law(1.5, 1.0, size=200, seed=2)
    ref = cutoff_shape_profile(y, 1.0, (0.5, 1.0))
    for x_min in (np.float32(1.0), np.float64(1.0), 1, np.int64(1)):
        # np.float32 was refused
        assert repr(cutoff_shape_profile(y, x_min, (0.5, 1.0))) == repr(ref)
    assert cutoff_shape_profile(y, np.float32(1.0), (0.5, 1.0)).x_min == 1.0
    # a.k.a. fit_cutoff_power_law's a = 1 fit (the profile's docstring)
    assert fit_cutoff_power_law(y, np.float32(1.0)).tau == ref.taus[1]
    for call in (lambda: cutoff_shape_profile(y, True), lambda: fit_cutoff_power_law(y, True)):
        with pytest.raises(ValueError, match="^x_min must be finite and > 0, got True$"):
            call()


# ---------------------------------------------------------------------------------------------
# 6. histograms and exponents


@pytest.mark.parametrize("bad", [NAN, INF, -INF])
def test_log_histogram_refuses_non_finite_data(bad):
    # inf was counted in the normaliser and left out of the bins before
    with pytest.raises(ValueError, match=f"^data holds NaN or inf: {bad!r} at flat index 2$"):
        log_histogram([1.5, 2.5, bad])


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"bins_per_decade": NAN}, r"^bins_per_decade=nan must be finite and >= 1$"),
    ({"n_total": NAN}, r"^n_total=nan must be a whole number$"),
    ({"n_total": 4.5}, r"^n_total=4\.5 must be a whole number$"),
])
def test_log_histogram_refuses_bad_options(kwargs, match):
    with pytest.raises(ValueError, match=match):
        log_histogram([1.5, 2.5, 15.0], **kwargs)


def test_log_histogram_by_hand():
    """Edges 1, 10, 100; counts 2 and 1; ``density = c/(N w)`` with N = 3 and 4."""
    h = log_histogram([1.5, 2.5, 15.0], 1, range=(1.0, 100.0))
    np.testing.assert_allclose(h.edges, [1.0, 10.0, 100.0], rtol=1e-15)
    np.testing.assert_allclose(h.density, [2 / (3 * 9), 1 / (3 * 90)], rtol=1e-14)
    g = log_histogram([1.5, 2.5, 15.0], 1, range=(1.0, 100.0), n_total=4.0)
    np.testing.assert_allclose(g.density, [2 / (4 * 9), 1 / (4 * 90)], rtol=1e-14)


@pytest.mark.parametrize("bad", [NAN, INF])
def test_empirical_cdf_and_fit_exponent_refuse_non_finite_samples(bad):
    samples = [np.linspace(0.01, 1.0, 50), np.array([0.2, bad, 0.5])]
    match = f"^samples\\[1\\] holds NaN or inf: {bad!r} at flat index 1$"
    with pytest.raises(ValueError, match=match):
        empirical_cdf(samples, [0.5])
    for method in ("cdf", "plain", "mle"):
        with pytest.raises(ValueError, match=match):
            fit_exponent(samples, (0.01, 1.0), method, n_boot=5)


def test_empirical_cdf_at_nan_points():
    f = empirical_cdf([[1.0, 2.0], [3.0]], [NAN, 2.0, INF, 0.5])
    assert math.isnan(f[0])  # 1 before
    np.testing.assert_array_equal(f[1:], [2 / 3, 1.0, 0.0])


@pytest.mark.parametrize("n_points", [1, 2])
def test_fit_exponent_needs_three_points(n_points):
    # 2 points leave the window-CDF fit no interior point: it returned its search bound (a = 5)
    samples = [np.random.default_rng(k).random(100) for k in range(4)]
    with pytest.raises(ValueError, match=f"^n_points must be an integer >= 3, got {n_points}$"):
        fit_exponent(samples, (0.01, 1.0), n_points=n_points)


def test_finite_size_cutoff_refuses_a_non_finite_exponent():
    for bad in (INF, NAN):
        with pytest.raises(ValueError, match=f"^exponent must be finite and > -1, got {bad!r}$"):
            finite_size_cutoff([10, 100], bad)  # inf gave the prefactor at every N before
    np.testing.assert_allclose(finite_size_cutoff([10, 100], 1.0, 2.0),
                               [2 / math.sqrt(10), 2 / 10], rtol=1e-15)


@pytest.mark.parametrize("fit", ["pure", "cutoff"])
@pytest.mark.parametrize(
    ("option", "value"),
    [("max_candidates", 0), ("max_candidates", -3), ("max_candidates", 2.5),
     ("max_candidates", True), ("n_boot", -1), ("n_boot", 1.5), ("min_tail", 2.5),
     ("seed", -1)],
)
def test_fit_options_are_counts(fit, option, value):
    """The fits' counts were unchecked: max_candidates=0 gave 'no valid fit' (pure) or a
    TypeError from unpacking None (cut-off), -3 numpy's 'Number of samples', 2.5 a TypeError,
    n_boot=-1 and min_tail=2.5 were used as given. Each is now refused, naming the option."""
    from jamlab.analysis.cutoff_powerlaw import fit_cutoff_power_law
    from jamlab.analysis.powerlaw import fit_power_law, sample_power_law

    x = sample_power_law(1.5, x_min=1.0, size=300, seed=1)
    f = fit_power_law if fit == "pure" else fit_cutoff_power_law
    with pytest.raises(ValueError, match=f"^{option} must be"):
        f(x, **{option: value})


def test_noise_floor_takes_the_jumps_shape_of_steps():
    """A 2-D ensemble (samples × steps) with its 2-D strain steps failed inside numpy ('input
    operand has more dimensions …'): the steps were broadcast to the flattened jumps. The same
    data flattened by hand is the reference."""
    rng = np.random.default_rng(0)
    dE = 1e-8 + 1e-12 * rng.normal(size=(3, 20))
    dS = np.full((3, 20), 2e-4)
    steps = np.full((3, 20), 1e-4)
    flat = noise_floor(dE.ravel(), dS.ravel(), steps.ravel())
    assert noise_floor(dE, dS, steps) == flat
    assert noise_floor(dE, dS, np.full((3, 1), 1e-4)) == flat
    with pytest.raises(ValueError, match=r"^strain_step \(2,\) does not broadcast"):
        noise_floor(dE, dS, np.array([1e-4, 1e-4]))
