"""The compiled joint likelihood and its Nelder–Mead search (``jamlab.analysis.likelihood_kernels``)
against scipy's ``minimize(method="Nelder-Mead")`` on the same likelihood, the truncated power
law's score root against scipy's ``brentq``, and the likelihood and ``log Γ(a, z)`` against
mpmath and scipy's Python ufuncs."""

import math

import mpmath
import numpy as np
import pytest
from scipy import optimize, special

from jamlab.analysis.cutoff_powerlaw import log_upper_gamma
from jamlab.analysis.likelihood_kernels import joint_nll, minimize_joint_nll

NS = np.array([250.0, 500.0, 1000.0, 2000.0])


def _stats(rng, stretch):
    """Sufficient statistics of a synthetic ensemble: counts, Σ log S, Σ S^a above the floors."""
    floors = np.sqrt(NS / NS[0])
    k, sl, ss = [], [], []
    for n, fl in zip(NS, floors, strict=True):
        s = fl * (1.0 - rng.random(int(rng.integers(20, 200)))) ** (-1.0 / 0.4)
        s = s[s < 30.0 * n / NS[0] * rng.uniform(0.5, 2.0)]  # a cut-off of sorts
        k.append(s.size)
        sl.append(np.log(s).sum())
        ss.append((s**stretch).sum())
    log_rel = np.log(NS / math.exp(np.mean(np.log(NS))))
    return (log_rel, floors, np.array(k, dtype=float), np.array(sl), np.array(ss), stretch)


def _scipy(x0, lower, upper, args, xatol, fatol, maxiter):
    r = optimize.minimize(joint_nll, x0, args=args, method="Nelder-Mead",
                          bounds=np.column_stack([lower, upper]),
                          options={"xatol": xatol, "fatol": fatol, "maxiter": maxiter})
    return r.x, r.fun, r.nit


def test_the_search_is_scipys_nelder_mead_step_for_step(monkeypatch):
    # numpy's argsort of four values is not stable where it dispatches to a SIMD sort, so scipy's
    # path through exactly equal values depends on the machine; with a stable one it is the
    # compiled search's, bit for bit (x, the minimum and the iteration count)
    stable = np.argsort
    monkeypatch.setattr(np, "argsort", lambda a, *p, **k: stable(a, kind="stable"))
    rng = np.random.default_rng(3)
    lower, upper = np.array([-1.0, -3.0, -3.0]), np.array([5.0, 12.0, 6.0])
    cases = 0
    for trial in range(12):
        args = _stats(rng, (1.0, 0.5, 2.0)[trial % 3])
        starts = [np.array([1.5, 4.0, 1.0]), np.array([0.3, 9.0, 0.5]),
                  upper - 1e-6,  # the initial simplex crosses the upper bounds: reflected
                  np.array([4.9, -2.9, 5.9]), np.array([1.2, 0.0, 0.0])]  # zeros: other steps
        for x0 in starts:
            for tol, maxiter in (((1e-7, 1e-9), 4000), ((1e-8, 1e-10), 4000), ((1e-4, 1e-4), 25)):
                want = _scipy(x0, lower, upper, args, *tol, maxiter)
                got = minimize_joint_nll(x0, lower, upper, args, *tol, maxiter)
                assert np.array_equal(got[0], want[0]), (trial, x0, tol)
                assert got[1] == want[1] and got[2] == want[2], (trial, x0, tol)
                cases += 1
    assert cases == 12 * 5 * 3


def test_the_search_finds_the_minimum_of_a_known_likelihood():
    # the compiled search against a scan: no point of a fine grid around its minimum is lower
    rng = np.random.default_rng(8)
    args = _stats(rng, 1.0)
    lower, upper = np.array([-1.0, -3.0, -3.0]), np.array([5.0, 12.0, 6.0])
    x, fun, _ = minimize_joint_nll(np.array([1.5, 4.0, 1.0]), lower, upper, args, 1e-9, 1e-12,
                                   4000)
    assert fun == joint_nll(x, *args)
    for d in np.linspace(-1e-3, 1e-3, 5):
        for axis in range(3):
            y = x.copy()
            y[axis] += d
            assert joint_nll(y, *args) >= fun - 1e-9


def _mp_log_upper_gamma(a, z):
    with mpmath.workdps(40):
        return float(mpmath.log(mpmath.gammainc(mpmath.mpf(a), mpmath.mpf(z))))


@pytest.mark.parametrize("stretch", [1.0, 0.5, 2.0])
def test_the_likelihood_against_mpmath(stretch):
    rng = np.random.default_rng(4)
    args = _stats(rng, stretch)
    log_rel, floors, k, sl, ss, _ = args
    for params in ([1.4, 3.0, 1.0], [2.7, 5.5, 0.3], [0.6, 1.0, -0.5], [1.0, 2.0, 2.0]):
        tau, log_ref, beta = params
        want = 0.0
        for i in range(NS.size):
            log_star = log_ref + beta * log_rel[i]
            a, z = (1.0 - tau) / stretch, (floors[i] * math.exp(-log_star)) ** stretch
            log_z = (1.0 - tau) * log_star - math.log(stretch) + _mp_log_upper_gamma(a, z)
            want += tau * sl[i] + ss[i] * math.exp(-stretch * log_star) + k[i] * log_z
        assert joint_nll(np.array(params), *args) == pytest.approx(want, rel=1e-11)


def _log_upper_gamma_python(a, z):
    """The pure-Python form the compiled one replaced (scipy's ufuncs; for the bit comparison)."""
    def scaled(a, z):
        if 0.0 < abs(a) < 1e-5:
            edge = math.copysign(1e-5, a)
            g0, g1 = scaled(0.0, z), scaled(edge, z)
            return g0 + (g1 - g0) * (a / edge)
        if a > 0:
            return float(special.gammaincc(a, z) * special.gamma(a)) * math.exp(z)
        if a == 0:
            return float(special.exp1(z)) * math.exp(z)
        return (scaled(a + 1.0, z) - z**a) / a

    if z > 50.0:
        term = total = 1.0
        for k in range(1, 13):
            term *= (a - k) / z
            total += term
        return (a - 1.0) * math.log(z) - z + math.log(total)
    return math.log(scaled(a, z)) - z


def test_log_upper_gamma_is_the_python_form_bit_for_bit():
    # the same C functions reached through scipy's Cython exports: the same doubles
    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(-6, 4, 2000), rng.uniform(-2e-5, 2e-5, 200),
                        [0.0, -1.0, -2.0, 1.0, 1e-5, -1e-5, 2.5]])
    z = np.concatenate([10 ** rng.uniform(-6, 2.5, 2000), rng.uniform(45, 55, 200),
                        [50.0, 1.0, 0.1, 2.0, 3.0, 4.0, 50.000001]])
    for x, y in zip(a.tolist(), z.tolist(), strict=True):
        assert log_upper_gamma(x, y) == _log_upper_gamma_python(x, y), (x, y)
    for a_, z_ in ((0.5, 2.0), (-2.5, 0.3), (3.0, 70.0)):
        assert log_upper_gamma(a_, z_) == pytest.approx(_mp_log_upper_gamma(a_, z_), rel=1e-12)
    with pytest.raises(ValueError, match="finite a and z > 0"):
        log_upper_gamma(1.0, 0.0)
    with pytest.raises(ValueError, match="finite a and z > 0"):
        log_upper_gamma(math.nan, 1.0)


def _h1_python(u):
    """The pure-Python ``h'(u)`` the compiled one replaced (for the bit comparison)."""
    if abs(u) < 1e-2:
        return 0.5 + u / 12 - u**3 / 720
    if u > 0:
        return -1.0 / math.expm1(-u) - 1.0 / u
    return 1.0 + 1.0 / math.expm1(u) - 1.0 / u


def test_the_truncated_score_root_is_scipys_brentq_bit_for_bit():
    from jamlab.analysis.likelihood_kernels import truncated_score, truncated_score_root

    rng = np.random.default_rng(6)
    us = np.concatenate([rng.uniform(-1e-2, 1e-2, 2000), rng.normal(0, 5, 2000),
                         rng.normal(0, 300, 500), [0.0, 1e-2, -1e-2]])
    for u in us.tolist():
        assert truncated_score(u) == _h1_python(u), u
    targets = np.concatenate([rng.uniform(0, 1, 3000), 10 ** rng.uniform(-8, -0.5, 500),
                              1 - 10 ** rng.uniform(-8, -0.5, 500), [0.5]])
    rtol = 4 * np.finfo(float).eps
    for t in targets.tolist():
        lo, hi = -8.0, 8.0
        while _h1_python(lo) > t:
            lo *= 2
        while _h1_python(hi) < t:
            hi *= 2
        want = optimize.brentq(lambda v, t=t: _h1_python(v) - t, lo, hi, xtol=1e-14, rtol=rtol)
        assert truncated_score_root(t, 1e-14, rtol, 100) == want, t
    with pytest.raises(RuntimeError, match="did not converge"):
        truncated_score_root(0.3, 1e-300, rtol, 2)
