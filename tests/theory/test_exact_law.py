"""The whole exact jump law (ΔE, overlap, ΔU, ΔΣ) against the exact cascade sampler, its
normalisation by independent quadrature, and its continuum limit."""

import math

import numpy as np
import pytest
from scipy import integrate, stats
from scipy.integrate import quad

from jamlab.theory import ParisiFunction, exact_jump_law, sample_cascade_jumps
from jamlab.theory.exact import CascadeRecursion, one_level_R

LINEAR = ParisiFunction.linear(2.5, 0.0, 0.9)
POWER = ParisiFunction.power_law(0.7, 0.5, 0.5, 0.95)
K2 = (np.array([0.0, 0.5]), np.array([0.8, 2.0]))

# (levels, dgamma, n samples, seed)
CASES = [
    pytest.param(K2, 0.5, 40_000, 11, id="k2-dg0.5"),
    pytest.param(K2, -0.2, 40_000, 12, id="k2-dg-0.2"),
    pytest.param(LINEAR.discretise(16), 0.1, 60_000, 13, id="k16-dg0.1"),
    pytest.param(POWER.discretise(16), 0.5, 12_000, 14, id="k16pow-dg0.5"),
    pytest.param(LINEAR.discretise(64), 0.3, 15_000, 15, id="k64-dg0.3"),
]


def _cond_mean(pdf, a, b, points=None):
    m0 = quad(pdf, a, b, limit=400, points=points, epsabs=1e-13)[0]
    m1 = quad(lambda s: s * pdf(s), a, b, limit=400, points=points, epsabs=1e-13)[0]
    return m1 / m0


@pytest.mark.parametrize(("levels", "dg", "n", "seed"), CASES)
def test_exact_law_against_sampler(levels, dg, n, seed):
    law = exact_jump_law(levels, dg)
    smp = sample_cascade_jumps(*levels, dg, n, seed=seed)
    p0 = law.p_no_jump
    # no-jump probability
    p_s, se = smp.p_no_jump()
    assert abs(p_s - p0) < 5 * math.sqrt(p0 * (1 - p0) / n), (p_s, p0)
    # overlap law: every level's frequency (levels grouped into at most 8 bins) within 5σ
    q_at, m_at = law.overlap.atoms()
    edges = np.unique(np.concatenate([q_at[:-1][:: max(1, (q_at.size - 1) // 8)], [1.0]]))
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        p = float(np.sum(m_at[(q_at >= a) & (q_at < b)]))
        f = float(np.mean((smp.q_jump >= a) & (smp.q_jump < b)))
        assert abs(f - p) < 5 * math.sqrt(p * (1 - p) / n) + 1e-12, (a, b, f, p)
    jm = smp.jumped
    nj = int(jm.sum())
    scale = 1.0 - p0
    # ΔE | jump
    dE = smp.dE[jm]
    ks = stats.kstest(dE, lambda x: np.asarray(law.cdf(np.minimum(x, -1e-300))) / scale)
    assert ks.pvalue > 1e-6, ks
    mean = _cond_mean(lambda x: float(law.pdf(x)), -40 * abs(dg), 0.0)
    assert abs(dE.mean() - mean) < 5 * dE.std() / math.sqrt(nj), (dE.mean(), mean)
    # ΔU | jump
    dU = smp.dU[jm]
    ks = stats.kstest(dU, lambda u: (np.asarray(law.du.cdf(u)) - p0) / scale)
    assert ks.pvalue > 1e-6, ks
    mean = _cond_mean(lambda u: float(law.du.pdf(u)), 0.0, 40 * abs(dg))
    assert abs(dU.mean() - mean) < 5 * dU.std() / math.sqrt(nj), (dU.mean(), mean)
    # ΔΣ | jump (same sign as δγ)
    dS = smp.dSigma[jm]
    assert np.all(np.sign(dS) == np.sign(dg))
    if dg > 0:
        ks = stats.kstest(dS, lambda s: (np.asarray(law.dsigma.cdf(s)) - p0) / scale)
        mean = _cond_mean(lambda s: float(law.dsigma.pdf(s)), 0.0, 30.0)
    else:
        ks = stats.kstest(dS, lambda s: np.asarray(law.dsigma.cdf(s)) / scale)
        mean = _cond_mean(lambda s: float(law.dsigma.pdf(s)), -30.0, 0.0)
    assert ks.pvalue > 1e-6, ks
    assert abs(dS.mean() - mean) < 5 * dS.std() / math.sqrt(nj), (dS.mean(), mean)


@pytest.mark.parametrize("k", [2, 16, 64])
@pytest.mark.parametrize("dg", [0.1, 0.5])
def test_normalisation_by_independent_quadrature(k, dg):
    levels = K2 if k == 2 else LINEAR.discretise(k)
    law = exact_jump_law(levels, dg)
    p0 = law.p_no_jump
    lo = -40 * dg
    tot_e = p0 + quad(lambda x: float(law.pdf(x)), lo, 0.0, limit=400, epsabs=1e-14)[0]
    tot_u = p0 + quad(lambda u: float(law.du.pdf(u)), 0.0, -lo, limit=400, epsabs=1e-14)[0]
    tot_s = p0 + quad(lambda s: float(law.dsigma.pdf(s)), 0.0, 30.0, limit=400,
                      epsabs=1e-14)[0]
    tot_q = float(np.sum(law.overlap.atoms()[1]))
    for tot in (tot_e, tot_u, tot_s, tot_q):
        assert tot == pytest.approx(1.0, abs=1e-8)
    # the cdfs reach 1 and agree with the integrated densities
    assert law.cdf(-1e-12) == pytest.approx(1 - p0, abs=1e-8)
    assert law.du.cdf(-lo) == pytest.approx(1.0, abs=1e-8)
    assert law.dsigma.cdf(30.0) == pytest.approx(1.0, abs=1e-8)
    x = -0.3 * dg
    assert law.cdf(x) == pytest.approx(
        quad(lambda t: float(law.pdf(t)), lo, x, limit=400, epsabs=1e-14)[0], abs=1e-8)


def test_one_level_law_against_closed_form():
    """k = 1: R(x) = ∫ φ(σ0)/(1 + A_x(σ0)) (nested quadrature) and the derivative of it."""
    law = exact_jump_law((np.array([0.0]), np.array([1.0])), 0.5)
    for x in (0.0, -0.05, -0.2, -1.0):
        assert float(law.R(x)) == pytest.approx(one_level_R(x, 1.0, 0.5), abs=1e-9)
    x, eps = -0.2, 1e-4
    fd = -(one_level_R(x + eps, 1.0, 0.5) - one_level_R(x - eps, 1.0, 0.5)) / (2 * eps)
    assert float(law.pdf(x)) == pytest.approx(fd, rel=1e-6)


def test_winner_walk_identity():
    """The joint density of (ΔE, ΔU) (winner's walk) integrated over ΔU equals -R' (from the
    f recursion's derivative): two different computations, equal by ``(e^{f_i})' =
    y_i ∫ dw e^{y_k w} G_i(·; w)``."""
    q, y = LINEAR.discretise(8)
    rec = CascadeRecursion(q, y, 0.3)
    wn = np.linspace(0.0, rec.w_hi, 4001)
    xs = np.array([-0.05, -0.2, -0.6])
    J = rec.joint_on_nodes(xs, wn) * np.exp(rec.y[-1] * wn)[None, :]
    marg = integrate.simpson(J, x=wn, axis=1)
    assert marg == pytest.approx(rec.dE_pdf(xs), rel=1e-5)


def test_continuum_linear_against_k512_and_table():
    """Continuum R(0) for y = 2.5q, q_max = 0.9 against the k = 512 recursion (1e-4) and
    docs/theory-vs-cascade.md Table 2 (k = 64 cascade sampled: within its 5σ)."""
    law = exact_jump_law(LINEAR, 0.3, levels=256)
    r512 = float(exact_jump_law(LINEAR, 0.3, k=512).p_no_jump)
    assert law.p_no_jump == pytest.approx(r512, abs=1e-4)
    assert law.R_error < 1e-5
    assert abs(law.p_no_jump - 0.7491) < 5 * 0.0025


def test_continuum_converged_in_levels():
    pf = ParisiFunction.power_law(0.706346, q_max=0.99)
    a = exact_jump_law(pf, 0.2, levels=128)
    b = exact_jump_law(pf, 0.2, levels=256)
    assert a.p_no_jump == pytest.approx(b.p_no_jump, abs=1e-5)
    xs = -0.2 * np.array([0.01, 0.1, 1.0])
    assert np.asarray(a.R(xs)) == pytest.approx(np.asarray(b.R(xs)), abs=1e-5)


def test_trivial_and_bad_input():
    law = exact_jump_law(LINEAR, 0.0, k=8)
    assert law.p_no_jump == 1.0 and law.cdf(-1.0) == 0.0
    with pytest.raises(ValueError, match="dgamma"):
        exact_jump_law(LINEAR, float("nan"), k=8)
    with pytest.raises(ValueError, match="cut-off"):
        exact_jump_law(ParisiFunction.power_law(0.3), 0.1)


@pytest.mark.parametrize("pf", [LINEAR, POWER], ids=["linear", "power"])
def test_continuum_first_order_jump_rate(pf):
    """(1 - R(0))/δγ → (1/√π) ∫ dq y'(q) √(1-q) (exact at first order, SPEC §1): linear
    extrapolation from δγ = 2e-3 and 4e-3 of the continuum law."""
    from jamlab.theory import jump_rate_first_order

    rates = [(1 - exact_jump_law(pf, d).p_no_jump) / d for d in (2e-3, 4e-3)]
    extrapolated = 2 * rates[0] - rates[1]
    assert extrapolated == pytest.approx(jump_rate_first_order(pf), rel=2e-4)
