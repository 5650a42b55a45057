"""ParisiFunction: values against closed forms and quadrature, discretise semantics, validation."""

import math

import mpmath as mp
import numpy as np
import pytest
from scipy.integrate import quad

from jamlab.theory import ParisiFunction


def _Y_by_quad(pf, q):  # noqa: N802
    # independent: integrate y itself
    val, _ = quad(
        lambda t: pf.y(t),
        q,
        1.0,
        limit=200,
        epsabs=0,
        epsrel=1e-12,
        points=[pf.q_max] if pf.q_max < 1 else None,
    )
    return val


@pytest.mark.parametrize(
    "mu,amp,y0,q_max", [(0.706346, 1.0, 0.0, 1.0), (0.5, 2.0, 0.3, 0.99), (0.3, 0.7, 0.1, 0.9)]
)
def test_power_law_values(mu, amp, y0, q_max):
    pf = ParisiFunction.power_law(mu, amplitude=amp, y0=y0, q_max=q_max)
    q = np.array([0.0, 0.1, 0.5, 0.85, 0.95, 0.999])
    expect = y0 + amp * ((1 - np.minimum(q, q_max)) ** (-mu) - 1)
    np.testing.assert_allclose(pf.y(q), expect, rtol=1e-14)
    assert pf.atom0 == y0
    # Y(q) = ∫_q^1 y = ∫_0^{1-q} y(1-u) du, by 30-digit mpmath quadrature of the definition
    mp.mp.dps = 30
    u_min = 1 - mp.mpf(q_max)
    for qq in (0.0, 0.4, 0.97):

        def y_mp(u):
            return y0 + amp * (max(u, u_min) ** (-mu) - 1)

        u0 = 1 - mp.mpf(qq)
        # geometric breakpoints resolve the u^-mu end-point singularity
        pts = sorted(
            {mp.mpf(0), u0, *(u0 * mp.mpf(10) ** -j for j in range(1, 40, 3))}
            | ({u_min} if 0 < u_min < u0 else set())
        )
        ref = mp.quad(y_mp, pts)
        assert abs(pf.Y(qq) - float(ref)) <= 1e-13 * float(ref)
    # dy is the derivative of y below q_max and vanishes above
    h = 1e-6
    for qq in (0.2, 0.6):
        fd = (pf.y(qq + h) - pf.y(qq - h)) / (2 * h)
        assert pf.dy(qq) == pytest.approx(fd, rel=1e-7)
    if q_max < 1:
        assert pf.dy(0.5 * (q_max + 1)) == 0.0
        assert pf.y(1.0) == pytest.approx(pf.y(q_max), rel=1e-15)


def test_linear_and_tabulated_agree_with_quadrature():
    lin = ParisiFunction.linear(2.5, y0=0.2, q_max=0.9)
    tab = ParisiFunction.tabulated([0.0, 0.3, 0.7, 1.0], [0.1, 0.4, 0.4, 2.0], q_max=0.8)
    for pf in (lin, tab):
        for q in (0.0, 0.25, 0.5, 0.85, 0.95):
            assert pf.Y(q) == pytest.approx(_Y_by_quad(pf, q), rel=1e-10, abs=1e-14)
    assert lin.y(0.5) == pytest.approx(0.2 + 2.5 * 0.5)
    assert lin.dy(0.5) == 2.5 and lin.dy(0.95) == 0.0
    assert tab.y(0.5) == pytest.approx(0.4) and tab.dy(0.5) == 0.0
    assert tab.dy(0.2) == pytest.approx(1.0)
    assert tab.y(0.9) == pytest.approx(tab.y(0.8)) == pytest.approx(0.4 + 1.6 / 0.3 * 0.1)
    assert lin.atom0 == 0.2 and tab.atom0 == 0.1


def test_steps_function():
    st = ParisiFunction.steps([0.0, 0.5, 0.8], [0.5, 1.0, 3.0])
    np.testing.assert_allclose(st.y([0.0, 0.49, 0.5, 0.9, 1.0]), [0.5, 0.5, 1.0, 3.0, 3.0])
    assert st.Y(0.0) == pytest.approx(0.5 * 0.5 + 1.0 * 0.3 + 3.0 * 0.2)
    assert st.Y(0.6) == pytest.approx(1.0 * 0.2 + 3.0 * 0.2)
    q, m = st.atoms()
    np.testing.assert_allclose(q, [0.0, 0.5, 0.8])
    np.testing.assert_allclose(m, [0.5, 0.5, 2.0])
    assert st.atom0 == 0.5
    assert st.dy(0.3) == 0.0
    # no level at q = 0: y vanishes below q_1 and there is no atom at 0
    st2 = ParisiFunction.steps([0.2], [1.0])
    assert st2.atom0 == 0.0 and st2.y(0.1) == 0.0 and st2.Y(0.0) == pytest.approx(0.8)


@pytest.mark.parametrize(
    "pf",
    [
        ParisiFunction.power_law(0.706346, q_max=0.99),
        ParisiFunction.power_law(0.5, y0=0.4),
        ParisiFunction.linear(2.5, q_max=0.9),
    ],
)
def test_discretise_semantics(pf):
    k = 7
    q, y = pf.discretise(k)
    assert q.dtype == np.float64 and y.dtype == np.float64
    assert len(q) == len(y) == k and q[0] == 0.0
    assert np.all(np.diff(y) > 0) and y[0] > 0
    if pf.q_max < 1:
        np.testing.assert_allclose(q, pf.q_max * np.arange(k) / (k - 1), rtol=1e-15)
        edges = np.append(q, None)[:-1]
        assert y[-1] == pytest.approx(pf.y(pf.q_max), rel=1e-15)
        for i in range(k - 1):
            mean = quad(lambda t: pf.y(t), q[i], q[i + 1], epsrel=1e-12)[0] / (q[i + 1] - q[i])
            assert y[i] == pytest.approx(mean, rel=1e-9)
        del edges
    else:
        np.testing.assert_allclose(q, np.arange(k) / k, rtol=1e-15)
        qe = np.append(q, 1.0)
        for i in range(k):
            mean = quad(lambda t: pf.y(t), qe[i], qe[i + 1], epsrel=1e-12, limit=200)[0]
            assert y[i] == pytest.approx(mean / (qe[i + 1] - qe[i]), rel=1e-8)
    assert y[0] >= pf.atom0
    # back to a step function: it takes the level values on each level
    st = ParisiFunction.steps(q, y)
    np.testing.assert_allclose(st.y(q), y)


def test_discretise_merges_flat_parts():
    # y flat at 1 on [0.25, 0.75]: the levels inside the plateau merge into one
    tab = ParisiFunction.tabulated([0.0, 0.25, 0.75, 1.0], [0.5, 1.0, 1.0, 2.0])
    q, y = tab.discretise(8)
    assert np.all(np.diff(y) > 0)
    # levels at 0.25 and 0.375, 0.5, 0.625 all have mean 1: only 0.25 survives
    np.testing.assert_allclose(q, [0.0, 0.125, 0.25, 0.75, 0.875])
    const = ParisiFunction.linear(0.0, y0=1.5, q_max=0.5)
    q, y = const.discretise(5)
    np.testing.assert_allclose(q, [0.0])
    np.testing.assert_allclose(y, [1.5])


@pytest.mark.parametrize(
    "make,word",
    [
        (lambda: ParisiFunction.power_law(1.2), "mu"),
        (lambda: ParisiFunction.power_law(0.0), "mu"),
        (lambda: ParisiFunction.power_law(math.nan), "mu"),
        (lambda: ParisiFunction.power_law(0.5, amplitude=-1), "amplitude"),
        (lambda: ParisiFunction.power_law(0.5, y0=-0.1), "y0"),
        (lambda: ParisiFunction.power_law(0.5, q_max=1.5), "q_max"),
        (lambda: ParisiFunction.power_law(0.5, q_max=0.0), "q_max"),
        (lambda: ParisiFunction.linear(-1.0), "slope"),
        (lambda: ParisiFunction.tabulated([0, 0.5, 1], [1, 0.5, 2]), "non-decreasing"),
        (lambda: ParisiFunction.tabulated([0, 0.5, 1], [-1, 0.5, 2]), "y must be >= 0"),
        (lambda: ParisiFunction.tabulated([0, 0.5, 1.2], [0, 0.5, 2]), "q must lie in [0, 1]"),
        (lambda: ParisiFunction.tabulated([0, 0.5, 0.5], [0, 0.5, 2]), "strictly increasing"),
        (lambda: ParisiFunction.tabulated([0, np.inf], [0, 1]), "finite"),
        (lambda: ParisiFunction.steps([0, 1.0], [1, 2]), "[0, 1)"),
        (lambda: ParisiFunction.power_law(0.5).y(1.5), "q must lie in [0, 1]"),
        (lambda: ParisiFunction.power_law(0.5).Y(-0.1), "q must lie in [0, 1]"),
        (lambda: ParisiFunction.power_law(0.5, q_max=0.9).discretise(1), "k must be >= 2"),
        (lambda: ParisiFunction.steps([0.0, 0.5], [0.0, 1.0]).discretise(2), "y vanishes"),
    ],
)
def test_invalid_input_names_the_value(make, word):
    with pytest.raises(ValueError) as err:
        make()
    assert word in str(err.value)
