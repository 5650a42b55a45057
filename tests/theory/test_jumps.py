"""The printed jump distribution: accuracy against 50-digit mpmath, normalisation, asymptotics,
first-order results, sampling."""

import math

import mpmath as mp
import numpy as np
import pytest
from _mp_reference import PowerLawReference, pdf_cdf
from scipy import stats
from scipy.integrate import quad
from scipy.special import erfc

from jamlab.theory import (
    ParisiFunction,
    PrintedJumpDistribution,
    jump_distribution,
    jump_rate_first_order,
    overlap_atoms_first_order,
    overlap_density_first_order,
    stress_jump_density_first_order,
)
from jamlab.theory.jumps import rho_and_erfc

RATIOS = [1e-12, 1e-6, 1e-2, 1.0, 10.0]  # |ΔE| / |δγ|


def _rel(a, b):
    return abs(float(a) - float(b)) / abs(float(b))


@pytest.mark.parametrize("x", [-400.0, -60.0, -21.0, -19.9, -3.0, -1e-3, 0.0, 2.5, 19.9, 50.0])
def test_rho_and_erfc_against_mpmath(x):
    mp.mp.dps = 50
    xm = mp.mpf(x)
    rho_ref = mp.exp(-xm * xm / 4) / mp.sqrt(mp.pi) + xm / 2 * mp.erfc(-xm / 2)
    ec_ref = mp.erfc(-xm / 2)
    rho, ec = rho_and_erfc(np.array([x]))
    # e^{-x²/4} inherits the relative rounding of x amplified by x²/2
    tol = 4e-16 * (10 + x * x)
    if rho_ref > 1e-300:
        assert _rel(rho[0], rho_ref) < tol
    else:
        assert rho[0] < 1e-290
    if ec_ref > 1e-300:
        assert _rel(ec[0], ec_ref) < tol
    else:
        assert ec[0] < 1e-290


@pytest.mark.slow
@pytest.mark.parametrize("mu", [0.706346, 0.5])
@pytest.mark.parametrize("q_max", [1.0, 0.99])
@pytest.mark.parametrize("dgamma", [1e-4, 1e-2, 0.3])
def test_pdf_and_cdf_match_mpmath(mu, q_max, dgamma):
    ref = PowerLawReference(mu, q_max=q_max)
    dist = jump_distribution(ParisiFunction.power_law(mu, q_max=q_max), dgamma)
    dE = -dgamma * np.array(RATIOS)
    pdf, cdf = dist.pdf(dE), dist.cdf(dE)
    for i, e in enumerate(dE):
        p_ref, c_ref = pdf_cdf(ref, e, dgamma)
        if p_ref > 1e-290:
            assert _rel(pdf[i], p_ref) < 1e-8, (e, pdf[i], p_ref)
        else:  # below the float64 range (R = e^-C with C ~ 1e4): must underflow too
            assert pdf[i] < 1e-280
        assert _rel(cdf[i], c_ref) < 1e-8, (e, cdf[i], c_ref)


def test_pdf_with_atom_at_zero_matches_mpmath():
    # y0 > 0 puts an atom in y' at q = 0
    ref = PowerLawReference(0.706346, amplitude=0.5, y0=0.7, q_max=0.99)
    dist = jump_distribution(ParisiFunction.power_law(0.706346, 0.5, 0.7, 0.99), -0.05)
    for r in (1e-9, 0.3, 4.0):
        e = -0.05 * r
        p_ref, c_ref = pdf_cdf(ref, e, 0.05)
        assert _rel(dist.pdf(e), p_ref) < 1e-8
        assert _rel(dist.cdf(e), c_ref) < 1e-8


def test_no_jump_probability_against_mpmath_and_spec():
    # R(0) with a cut-off, from the definition at ΔE = 0
    mp.mp.dps = 30
    dg, mu, qm = 0.3, 0.706346, 0.99
    um = 1 - mp.mpf(qm)

    def Y(u):  # noqa: N802
        ymax = um**-mu - 1
        prim = lambda v: v ** (1 - mu) / (1 - mu) - v  # noqa: E731
        return prim(u) - prim(um) + um * ymax

    def f(u):
        x = dg * Y(u) / mp.sqrt(u)
        rho = mp.exp(-x * x / 4) / mp.sqrt(mp.pi) + x / 2 * mp.erfc(-x / 2)
        return mu * u ** (-mu - 1) * mp.sqrt(u) * rho

    C0 = dg * mp.quad(f, [um, 0.001, 0.01, 0.1, 1])
    dist = jump_distribution(ParisiFunction.power_law(mu, q_max=qm), dg)
    assert _rel(dist.p_no_jump, mp.exp(-C0)) < 1e-10
    # the cdf below 0 tends to 1 - R(0), then jumps to 1
    assert dist.cdf(-1e-200) == pytest.approx(1 - dist.p_no_jump, rel=1e-12)
    assert dist.cdf(0.0) == 1.0 and dist.sf(0.0) == 0.0 and dist.pdf(0.0) == 0.0
    # SPEC §1: y = 2.5 q, q_max = 0.9, δγ = 0.3 gives R(0) = 0.69 by the printed formula
    lin = jump_distribution(ParisiFunction.linear(2.5, q_max=0.9), 0.3)
    assert lin.p_no_jump == pytest.approx(0.69, abs=0.005)
    # μ >= 1/2 without cut-off: the system always jumps
    assert jump_distribution(ParisiFunction.power_law(0.5), 1e-3).p_no_jump == 0.0


def test_symmetry_and_bad_dgamma():
    pf = ParisiFunction.power_law(0.706346, q_max=0.999)
    dE = -np.logspace(-9, -1, 7)
    a, b = jump_distribution(pf, 0.01), jump_distribution(pf, -0.01)
    np.testing.assert_array_equal(a.pdf(dE), b.pdf(dE))
    assert a.p_no_jump == b.p_no_jump
    for bad in (0.0, math.inf, math.nan):
        with pytest.raises(ValueError, match="dgamma"):
            jump_distribution(pf, bad)
    with pytest.raises(ValueError, match="dE <= 0"):
        a.C(1e-3)
    assert isinstance(a, PrintedJumpDistribution)


def test_step_function_against_direct_sum():
    # for a k-RSB y' is a sum of atoms: C is a finite sum, computed here independently
    q = np.array([0.0, 0.4, 0.9])
    y = np.array([0.8, 1.5, 4.0])
    st = ParisiFunction.steps(q, y)
    dg = 0.2
    edges = np.append(q, 1.0)
    Yq = np.array([np.sum(y[i:] * np.diff(edges)[i:]) for i in range(3)])
    m = np.diff(np.concatenate([[0.0], y]))
    dist = jump_distribution(st, dg)
    for e in (-1e-6, -0.01, -0.3):
        x = (e + dg**2 * Yq) / (np.sqrt(1 - q) * dg)
        rho = np.exp(-(x**2) / 4) / math.sqrt(math.pi) + x / 2 * erfc(-x / 2)
        C = dg * np.sum(m * np.sqrt(1 - q) * rho)
        dC = 0.5 * np.sum(m * erfc(-x / 2))
        assert dist.C(e) == pytest.approx(C, rel=1e-13)
        assert dist.pdf(e) == pytest.approx(math.exp(-C) * dC, rel=1e-13)


def test_tabulated_matches_linear():
    # two code paths for the same y(q) = 0.3 + 2 q, q_max = 0.95
    lin = jump_distribution(ParisiFunction.linear(2.0, y0=0.3, q_max=0.95), 0.05)
    tab = jump_distribution(ParisiFunction.tabulated([0.0, 0.95], [0.3, 2.2]), 0.05)
    dE = -np.logspace(-10, 0, 9)
    np.testing.assert_allclose(tab.pdf(dE), lin.pdf(dE), rtol=1e-12)
    assert tab.p_no_jump == pytest.approx(lin.p_no_jump, rel=1e-13)


def _mass(dist, dgamma):
    """∫ pdf d|ΔE| from 1e-300 to 60|δγ|, in t = log|ΔE| (composite Gauss–Legendre)."""
    t_lo, t_hi = math.log(1e-300), math.log(60 * abs(dgamma))
    edges = np.linspace(t_lo, t_hi, int((t_hi - t_lo) / 0.2) + 1)
    x, w = np.polynomial.legendre.leggauss(12)
    a, b = edges[:-1, None], edges[1:, None]
    t = (0.5 * (a + b) + 0.5 * (b - a) * x).ravel()
    wt = (0.5 * (b - a) * w).ravel()
    e = np.exp(t)
    return float(np.sum(wt * e * dist.pdf(-e)))


@pytest.mark.slow
@pytest.mark.parametrize(
    "mu,q_max,dgamma", [(0.706346, 1.0, 1e-2), (0.706346, 0.99, 0.3), (0.5, 0.99, 1e-2)]
)
def test_normalisation(mu, q_max, dgamma):
    dist = jump_distribution(ParisiFunction.power_law(mu, q_max=q_max), dgamma)
    # mass below 1e-300: R(-1e-300) - R(0), which is < 1e-290 in all three cases
    assert dist.R(-1e-300) - dist.p_no_jump < 1e-290
    assert abs(dist.p_no_jump + _mass(dist, dgamma) - 1.0) < 1e-8
    if q_max == 1.0:
        assert dist.p_no_jump == 0.0


def test_log_slope_approaches_minus_two_mu():
    mu = 0.706346
    deviations = []
    for dg in (1e-4, 1e-6, 1e-8):
        dist = jump_distribution(ParisiFunction.power_law(mu), dg)
        # geometric centre of the window |δγ|^(1+1/(2μ-1)) << |ΔE| << |δγ|
        lo = dg ** (1 + 1 / (2 * mu - 1))
        centre = math.sqrt(lo * dg)
        h = 1e-3
        lp = dist.logpdf(np.array([-centre * math.exp(-h), -centre * math.exp(h)]))
        slope = (lp[1] - lp[0]) / (2 * h)
        deviations.append(abs(slope + 2 * mu))
    assert deviations[0] > deviations[1] > deviations[2]
    assert deviations[2] < 1e-3


def test_first_order_rate_and_overlap_density():
    mu, A, y0, qm = 0.706346, 1.3, 0.4, 0.999
    pf = ParisiFunction.power_law(mu, amplitude=A, y0=y0, q_max=qm)
    um = 1 - qm
    closed = (y0 + A * mu * (1 - um ** (0.5 - mu)) / (0.5 - mu)) / math.sqrt(math.pi)
    rate = jump_rate_first_order(pf)
    assert rate == pytest.approx(closed, rel=1e-12)
    # ∫ P[q] dq + atoms = rate
    dens = quad(lambda q: overlap_density_first_order(pf, q), 0, qm, limit=400, epsrel=1e-12)[0]
    qa, ma = overlap_atoms_first_order(pf)
    np.testing.assert_allclose(qa, [0.0])
    assert dens + ma.sum() == pytest.approx(rate, rel=1e-9)
    # first order of the printed formula: 1 - R(0, δγ) = |δγ| rate + O(δγ²)
    dg = 1e-7
    dist = jump_distribution(pf, dg)
    assert (1 - dist.p_no_jump) / dg == pytest.approx(rate, rel=1e-4)
    # divergent case
    assert jump_rate_first_order(ParisiFunction.power_law(0.6)) == math.inf


@pytest.mark.parametrize(
    "pf",
    [ParisiFunction.power_law(0.706346, y0=0.2, q_max=0.9999), ParisiFunction.linear(2.5, 0.1)],
)
def test_stress_jump_density_integrates_to_rate(pf):
    rate = jump_rate_first_order(pf)
    f = lambda t: math.exp(t) * stress_jump_density_first_order(pf, math.exp(t))  # noqa: E731
    total = quad(f, math.log(1e-8), math.log(20.0), limit=400, epsrel=1e-11)[0]
    assert total == pytest.approx(rate, rel=1e-8)
    assert stress_jump_density_first_order(pf, -0.3) == 0.0


def test_stress_jump_density_against_mpmath():
    # one point of the derived formula for the singular y(q) without cut-off
    mp.mp.dps = 30
    mu, d = 0.706346, 0.05
    f = lambda u: mu * u ** (-mu - 1) * mp.exp(-d * d / (4 * u)) / mp.sqrt(4 * mp.pi * u)  # noqa
    pts = [0, d * d / 100, d * d / 10, d * d, 10 * d * d, 0.1, 1]
    ref = d * mp.quad(f, pts)
    got = stress_jump_density_first_order(ParisiFunction.power_law(mu), d)
    assert _rel(got, ref) < 1e-10


def test_rvs_follows_cdf_with_atom():
    pf = ParisiFunction.power_law(0.706346, q_max=0.99)
    dist = jump_distribution(pf, 0.3)
    n = 4000
    x = dist.rvs(n, seed=7)
    np.testing.assert_array_equal(x, dist.rvs(n, seed=7))
    assert np.all(x <= 0)
    zeros = np.mean(x == 0.0)
    p0 = dist.p_no_jump
    assert abs(zeros - p0) < 4 * math.sqrt(p0 * (1 - p0) / n)
    # jumps: conditional cdf (1 - R(ΔE)) / (1 - R(0)) is uniform under the sample
    neg = x[x < 0]
    u = np.asarray(dist.cdf(neg)) / (1 - p0)
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    # and the inversion is exact: C at the sample equals -log(1 - V)
    v = np.random.default_rng(7).random(n)
    jumped = v < 1 - p0
    np.testing.assert_allclose(dist.C(x[jumped]), -np.log1p(-v[jumped]), rtol=1e-10)


LIN_DIST = jump_distribution(ParisiFunction.linear(2.5, 0.0, 0.9), 0.1)  # C(0) = 0.1015...


@pytest.mark.parametrize("method", ["pdf", "cdf", "sf", "logpdf", "C", "dC", "R"])
def test_nan_dE_is_refused(method):
    """A NaN ΔE is a ValueError for every method (it used to give pdf 0, cdf 1, sf 0, logpdf
    -inf); its finite neighbours, numpy scalars included, still give the same numbers."""
    f = getattr(LIN_DIST, method)
    for bad in (math.nan, np.float32("nan"), np.array([-0.05, np.nan])):
        with pytest.raises(ValueError, match="dE must not be NaN, got nan"):
            f(bad)
    good = np.array([-0.5, -0.05, -1e-6])
    vals = np.asarray(f(good))
    assert vals.shape == (3,) and np.all(np.isfinite(vals))
    for x, val in zip(good, vals, strict=True):
        assert f(np.float64(x)) == val and f(float(x)) == val
    assert f(np.float32(-0.05)) == f(float(np.float32(-0.05)))


def test_cdf_sf_pdf_at_nonnegative_and_infinite_dE_unchanged():
    d = LIN_DIST
    assert d.cdf(0.0) == 1.0 and d.sf(0.0) == 0.0 and d.pdf(0.0) == 0.0
    assert d.cdf(2.0) == 1.0 and d.sf(np.inf) == 0.0 and d.logpdf(1.0) == -math.inf
    assert d.cdf(-np.inf) == 0.0 and d.sf(-np.inf) == 1.0 and d.pdf(-np.inf) == 0.0


@pytest.mark.parametrize("bad", [1e6, 0.2, 0.0, -1.0, math.nan, math.inf, -math.inf])
def test_ppf_log_refuses_c_without_a_root(bad):
    """``C(ΔE) = c`` has a root ``ΔE <= 0`` only for ``0 < c <= C(0)``: outside it (and for NaN)
    ppf_log used to return -1e-305, -3.45 or NaN; now a ValueError naming c."""
    with pytest.raises(ValueError, match=r"c must lie in \(0, C\(0\)\].*got"):
        LIN_DIST.ppf_log([bad])
    with pytest.raises(ValueError, match=r"c must lie in"):
        LIN_DIST.ppf_log([0.05, bad])
    # just above C(0) (one ulp) is refused, C(0) itself is the root ΔE → 0⁻
    c0 = LIN_DIST.C(0.0)
    with pytest.raises(ValueError, match=r"c must lie in"):
        LIN_DIST.ppf_log(np.nextafter(c0, 1.0))
    root0 = LIN_DIST.ppf_log([c0])
    assert root0.shape == (1,) and -1e-300 < root0[0] <= 0.0


def test_ppf_log_in_range_solves_C():
    c = np.array([1e-3, 0.05, np.float32(0.1)])
    dE = LIN_DIST.ppf_log(c)
    assert np.all(dE < 0.0)
    np.testing.assert_allclose(LIN_DIST.C(dE), c, rtol=1e-10)
    np.testing.assert_array_equal(LIN_DIST.ppf_log(np.float64(0.05)), dE[1:2])
    # without a cut-off (μ = 1/2) C(0) = inf: every finite c > 0 has a root
    half = jump_distribution(ParisiFunction.power_law(0.5), 1e-3)
    root = half.ppf_log([0.01])
    assert root[0] < 0.0 and half.C(root) == pytest.approx([0.01], rel=1e-10)
    with pytest.raises(ValueError, match=r"C\(0\)\] = \(0, inf\]"):
        half.ppf_log([math.inf])


@pytest.mark.parametrize("pf,dgamma", [(ParisiFunction.linear(2.5, 0.0, 0.9), 0.1),
                                       (ParisiFunction.power_law(0.7), 1e-3)])
def test_ppf_log_is_a_root_far_in_the_tail(pf, dgamma):
    """Small ``c`` (the far tail, where ``C`` falls faster than exponentially): the four Newton
    steps on ``C`` used to stop short (``C(root)/c − 1`` = 1e-2 at c = 1e-10, 1e2 at 1e-30, 1e165
    at 1e-300 for the linear y); the roots now solve ``C = c`` to rounding, and they are ordered
    (``C`` decreases with ``|ΔE|``)."""
    dist = jump_distribution(pf, dgamma)
    c = np.array([1e-3, 1e-10, 1e-30, 1e-100, 1e-300])
    root = dist.ppf_log(c)
    np.testing.assert_allclose(dist.C(root) / c, 1.0, rtol=0, atol=1e-12)
    assert np.all(np.diff(root) < 0)


# (ΔE, C, ∂C/∂ΔE) from C ~ 1e-3 down to C ~ 1e-300: 20-digit mpmath (60 digits, the integrals in
# s = -log(1-q) with panels graded towards q = 0 and every feature, the integrands scaled to O(1)
# for mp.quad's absolute tolerance; a 40-digit run on other panels agrees to 1e-40)
FAR_TAIL = {
    "power_law": (
        ParisiFunction.power_law(0.7),
        1e-3,
        [
            (-0.0002821, "0.00099997157574203843974", "3.5882096379872680196"),
            (-0.006223, "9.9968701132771221943e-11", "3.6749719555822446412e-7"),
            (-0.01106, "1.0131170734119291879e-20", "5.9505267426710382444e-17"),
            (-0.0145, "1.0185652853914800244e-30", "7.6563012931661687429e-27"),
            (-0.01974, "1.0149036873854981233e-50", "1.0218263087265480112e-46"),
            (-0.02905, "1.0705689934246776231e-100", "1.5695059113094685794e-96"),
            (-0.04195, "9.0921463867925838578e-201", "1.91560943278431338e-196"),
            (-0.05174, "1.0324941181140844978e-300", "2.6789048101406160825e-296"),
        ],
    ),
    "linear": (
        ParisiFunction.linear(2.5, 0.0, 0.9),
        0.1,
        [
            (-0.2744, "0.0009996656224910700441", "0.021630621394602261023"),
            (-0.7793, "9.9920427381350656683e-11", "4.2858317786194824173e-9"),
            (-1.214, "9.9976882989057957054e-21", "6.3192228625453821966e-19"),
            (-1.538, "1.0278016456542528011e-30", "8.0989818316994936946e-29"),
            (-2.044, "9.698707678269110879e-51", "1.003859731374846872e-48"),
            (-2.957, "1.0573444908720739565e-100", "1.5709421833164849192e-98"),
            (-4.234, "1.1078923092105952449e-200", "2.348991853991584343e-198"),
            (-5.209, "9.6440622039735943377e-301", "2.5132247200480396176e-298"),
        ],
    ),
}


@pytest.mark.timeout(30)
@pytest.mark.parametrize("case", sorted(FAR_TAIL))
def test_far_tail_C_and_dC_single_and_batch_against_mpmath(case):
    """C and ∂C/∂ΔE keep their relative accuracy far in the tail, alone or in any batch.

    The shared panels used to miss the integrands' mass there (within s ~ 4/x(0)² of q = 0):
    alone, C was off by 2e-6 at C = 1e-30 and by 86 % at 1e-300, and in a batch by what the other
    rows' panels happened to resolve (1e-4 at 1e-300 for the power law, 23 % for the linear y).
    Now: within 1.3e-14 of mpmath (asserted 1e-12, float64 loses ~x(0)²/2 ulps there), and the
    far-tail rows (own panels) equal alone, in the batch and mixed with other rows."""
    pf, dgamma, table = FAR_TAIL[case]
    dist = jump_distribution(pf, dgamma)
    dE = np.array([row[0] for row in table])
    C_ref = np.array([float(mp.mpf(row[1])) for row in table])
    dC_ref = np.array([float(mp.mpf(row[2])) for row in table])
    others = -abs(dgamma) * np.geomspace(1e-6, 5.0, 50)  # rows that used to refine the tail
    mixed = np.concatenate([others, dE])
    results = {
        "batch": (dist.C(dE), dist.dC(dE)),
        "single": (
            np.array([dist.C(dE[i : i + 1])[0] for i in range(dE.size)]),
            np.array([dist.dC(dE[i : i + 1])[0] for i in range(dE.size)]),
        ),
        "mixed": (dist.C(mixed)[others.size :], dist.dC(mixed)[others.size :]),
    }
    for name, (C, dC) in results.items():
        np.testing.assert_allclose(C, C_ref, rtol=1e-12, atol=0, err_msg=name)
        np.testing.assert_allclose(dC, dC_ref, rtol=1e-12, atol=0, err_msg=name)
        np.testing.assert_allclose(C, results["batch"][0], rtol=1e-14, atol=0, err_msg=name)
        np.testing.assert_allclose(dC, results["batch"][1], rtol=1e-14, atol=0, err_msg=name)
        far = C_ref < 1e-15
        np.testing.assert_allclose(C[far], results["batch"][0][far], rtol=1e-15, atol=0)
        np.testing.assert_allclose(dC[far], results["batch"][1][far], rtol=1e-15, atol=0)
    # the pdf R ∂C/∂ΔE (R = 1 to rounding there) inherits the accuracy of ∂C/∂ΔE
    np.testing.assert_allclose(dist.pdf(dE[-3:]), dC_ref[-3:], rtol=1e-12, atol=0)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda d: d.rvs(-1, seed=1), "^size must be an integer >= 0, got -1$"),
        (lambda d: d.rvs(2.5, seed=1), "^size must be an integer >= 0, got 2.5$"),
        (lambda d: d.rvs((3, -2), seed=1), "^size must be an integer >= 0, got -2$"),
        (lambda d: d.rvs(3, seed=-1), r"^seed must be an integer in \[0, "),
    ],
)
def test_rvs_refuses_bad_size_and_seed(call, message):
    """numpy's 'negative dimensions are not allowed', a TypeError for 2.5 and 'expected
    non-negative integer' before: now one line naming the argument."""
    d = jump_distribution(ParisiFunction.linear(1.0, 0.1, 0.9), 0.1)
    with pytest.raises(ValueError, match=message):
        call(d)
    assert d.rvs((2, 3), seed=1).shape == (2, 3) and d.rvs(0, seed=1).shape == (0,)
