"""The multi-band solution of the exact recursion (``BandedRecursion``,
``exact_energy_jump_law``): against the uniform-grid solution, the one-level closed form, the
derivative of its own ``R``, ``docs/theory-vs-cascade.md`` Table 6, and its convergence in the
levels and the cut-off without a cut-off down to ``|ΔE| = 1e-3 |δγ|``."""

import numpy as np
import pytest

from jamlab.theory import ParisiFunction, exact_energy_jump_law
from jamlab.theory.exact import CascadeRecursion, one_level_R
from jamlab.theory.exact_bands import BandedRecursion
from jamlab.theory.exact_law import continuum_levels, geometric_levels

MU_J = 0.706346
RS = np.array([1e-3, 3e-3, 1e-2, 3e-2, 0.1])


@pytest.mark.parametrize(
    ("levels", "dg"),
    [
        pytest.param((np.array([0.0, 0.5]), np.array([0.8, 2.0])), 0.5, id="k2"),
        pytest.param(continuum_levels(ParisiFunction.linear(2.5, 0.0, 0.9), 64), 0.1, id="lin64"),
        pytest.param(geometric_levels(ParisiFunction.power_law(MU_J), 40, 1 - 1e-6), 0.1,
                     id="pow-geo-1e-6"),
        pytest.param(geometric_levels(ParisiFunction.power_law(0.5), 40, 1 - 1e-5), 0.01,
                     id="pow0.5-geo-1e-5"),
    ],
)
def test_bands_equal_uniform_grid(levels, dg):
    x = -dg * np.concatenate([[0.0], RS, [0.3, 1.0, 3.0]])
    # the uniform grid refined twice over its defaults (at the defaults it is off by 3e-8 in R at
    # r = 3e-3 for pow-geo-1e-6, y_k σ_k = 5.9; the bands agree with the refined grid to 1e-13
    # in R and 1e-10 in the density, as does the grid refined four times)
    uni = CascadeRecursion(*levels, dg, points_per_sd=3.0, points_per_scale=8.0)
    band = BandedRecursion(*levels, dg)
    R, P = band.R_and_pdf(x)
    assert np.max(np.abs(R - uni.R(x))) < 1e-10
    assert np.max(np.abs(P[1:] / uni.dE_pdf(x[1:]) - 1)) < 1e-9


def test_one_level_closed_form():
    for y, dg, q1 in [(1.3, 0.4, 0.0), (5.0, 0.05, 0.0)]:
        band = BandedRecursion(np.array([q1]), np.array([y]), dg)
        for r in (0.0, 0.01, 0.3, 2.0):
            ref = one_level_R(-r * dg, y, dg, v=1.0 - q1)
            assert abs(float(band.R(-r * dg)[0]) - ref) < 1e-10, (y, dg, r)


def test_pdf_is_minus_derivative_of_R():
    law = exact_energy_jump_law(ParisiFunction.power_law(MU_J), 0.1)
    for x in -0.1 * RS:
        e = 1e-4 * abs(x)
        fd = (law.R(x - e) - law.R(x)) / e  # -R'(x - e/2), a central difference
        xm = x - e / 2
        assert abs(fd / law.pdf(xm) - 1) < 1e-6, x


@pytest.mark.parametrize(("dg", "ref"), [(0.05, 0.955203), (0.1, 0.911855), (0.3, 0.752504),
                                         (0.5, 0.614475)])
def test_continuum_linear_table6(dg, ref):
    law = exact_energy_jump_law(ParisiFunction.linear(2.5, 0.0, 0.9), dg)
    assert abs(law.p_no_jump - ref) < 1.5e-6


@pytest.mark.parametrize("dg", [0.1, 0.01])
def test_no_cutoff_converged_at_small_dE(dg):
    """Without a cut-off (``power_law(μ_J)``, ``q_max = 1``) at ``|ΔE|/δγ = 1e-3 … 0.1``: doubling
    the levels and moving the merging cut-off from ``1 - 1e-10`` to ``1 - 1e-12`` change ``R``
    by less than 1e-5 (measured: 1.6e-7 and 4.9e-7) and the density by less than 1e-4
    relative."""
    pf = ParisiFunction.power_law(MU_J)
    x = -dg * RS
    base = exact_energy_jump_law(pf, dg)
    R, P = np.asarray(base.R(x)), np.asarray(base.pdf(x))
    for other in (exact_energy_jump_law(pf, dg, levels=512),
                  exact_energy_jump_law(pf, dg, q_cut=1 - 1e-10)):
        assert np.max(np.abs(np.asarray(other.R(x)) - R)) < 1e-5
        assert np.max(np.abs(np.asarray(other.pdf(x)) / P - 1)) < 1e-4
    # the cut-off of the old default (1 - 1e-5) is visibly wrong at r = 1e-3: the test can fail
    coarse = exact_energy_jump_law(pf, dg, q_cut=1 - 1e-5)
    assert abs(float(coarse.R(x[0])) - R[0]) > 1e-3


def test_bad_input():
    pf = ParisiFunction.power_law(MU_J)
    with pytest.raises(ValueError, match="q_cut"):
        exact_energy_jump_law(pf, 0.1, q_cut=1 - 1e-14)
    with pytest.raises(ValueError, match="dgamma"):
        exact_energy_jump_law(pf, 0.0)
    with pytest.raises(ValueError, match="levels"):
        exact_energy_jump_law(pf, 0.1, levels=4)
    with pytest.raises(ValueError, match="R is defined"):
        exact_energy_jump_law(pf, 0.1).R(0.01)


def test_large_dgamma_strong_top_level():
    """At δγ = 0.5 the default cut-off is lowered to keep y_k δγ √(1 - q_k) <= 100 (μ_J:
    1 - q_cut ≈ 2.7e-9); the law is finite, a probability, monotone, and moving the cut-off to
    1 - 1e-8 changes R at r >= 0.03 by less than 1e-5."""
    pf = ParisiFunction.power_law(MU_J)
    law = exact_energy_jump_law(pf, 0.5)
    assert 1e-9 < 1 - law.q_top < 1e-8
    x = -0.5 * np.logspace(-3, 1, 30)
    R = np.asarray(law.R(x))
    assert np.all(np.isfinite(R)) and np.all(np.isfinite(np.asarray(law.pdf(x))))
    assert np.all(R > -1e-12) and np.all(R < 1 + 1e-12)
    assert np.all(np.diff(R) >= -1e-12)  # R(x) = P(ΔE >= x) grows as x falls
    other = exact_energy_jump_law(pf, 0.5, q_cut=1 - 1e-8)
    xs = -0.5 * np.array([0.03, 0.1, 0.3, 1.0])
    assert np.max(np.abs(np.asarray(other.R(xs)) - np.asarray(law.R(xs)))) < 1e-5


@pytest.mark.parametrize(("q1", "y", "dg"), [(0.0, 2.0, 0.5), (0.3, 1.0, -1.3)])
def test_energy_law_far_below_against_one_level_R(q1, y, dg):
    """The bands lose precision far below the law (R = 1 + 1e-11 at x = -1e5 for k = 2, 4.3 at
    -1e16, 0 at -1e18 and -∞, cdf(-∞) = 1): below -24ℓ_1 - 2δγ²Y(q_1) + 12σ_k (the edge of
    CascadeRecursion's grid; P(ΔE < x_lo) < 1e-14) R = 1 and the density 0; one_level_R (the
    quadrature of the closed form) is the reference; above it the bands' own values."""
    levels = (np.array([q1]), np.array([y]))
    law = exact_energy_jump_law(levels, dg)
    band = BandedRecursion(*levels, dg)
    lo = 12.0 * (band.sigma[-1] - 2.0 * band.ell[0]) - 2.0 * band.tilt[0]
    x = np.array([0.0, -0.3 * abs(dg), -abs(dg), lo, lo - 1e-9, -50.0, -1e5, -1e16, -1e18, -1e300,
                  -np.inf])
    ref = np.array([one_level_R(v, y, dg, v=1.0 - q1) for v in x])
    R = np.asarray(law.R(x))
    np.testing.assert_allclose(R, ref, rtol=0.0, atol=1e-12)
    assert ref[-1] == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_array_equal(R[x < lo], 1.0)
    np.testing.assert_array_equal(np.asarray(law.pdf(x))[x < lo], 0.0)
    np.testing.assert_array_equal(np.asarray(law.cdf(x))[x < lo], 0.0)
    assert law.R(-np.inf) == 1.0 and law.cdf(-np.inf) == 0.0 and law.sf(-np.inf) == 1.0
    # the valid neighbours: x >= lo keep the bands' values bit for bit, also mixed with x below
    inside = x >= lo
    Rb, Pb = band.R_and_pdf(x[inside])
    np.testing.assert_array_equal(R[inside], Rb)
    np.testing.assert_array_equal(np.asarray(law.pdf(x[1:]))[inside[1:]], Pb[1:])
    np.testing.assert_array_equal(np.asarray(law.R(x[inside])), Rb)
    assert np.all(np.diff(R) >= -1e-15)


def test_energy_law_refuses_nan():
    """R(nan) gave nan, pdf/cdf/sf(nan) 0, 1, 0; each now refuses it, naming the argument."""
    for law in (exact_energy_jump_law((np.array([0.0, 0.5]), np.array([0.8, 2.0])), 0.5),
                exact_energy_jump_law(ParisiFunction.linear(2.5, 0.0, 0.9), 0.1, levels=8)):
        for method in ("R", "pdf", "cdf", "sf"):
            f = getattr(law, method)
            for bad in (np.nan, [-0.1, np.nan], np.full((2, 3), np.nan)):
                with pytest.raises(ValueError, match="^dE must not be NaN, got dE = nan$"):
                    f(bad)
            v = f(-0.1)
            assert isinstance(v, float) and np.isfinite(v) and v >= 0.0
            np.testing.assert_allclose(f([-0.1, -0.2]), [v, f(-0.2)], rtol=1e-14, atol=1e-15)
        assert 0.0 < law.R(-0.1) < 1.0 and law.cdf(-0.1) == pytest.approx(1.0 - law.R(-0.1))
