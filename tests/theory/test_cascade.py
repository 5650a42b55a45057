"""The best-first cascade sampler is exact: one-level closed form, brute-force enumeration,
the exact recursion, symmetry, reproducibility and input validation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, stats

from jamlab.theory.cascade import (
    brute_force_cascade_jumps,
    cascade_constants,
    sample_cascade_jumps,
    sample_cascade_tree,
)
from jamlab.theory.exact import exact_jump_R, one_level_R

Z = 5.0  # tolerance in standard errors


def binom_se(p: float, n: int) -> float:
    return float(np.sqrt(max(p * (1 - p), 1.0 / n) / n))


def ks_threshold(n: int, m: int, alpha: float = 1e-6) -> float:
    """Two-sample KS critical value at level ``alpha`` (asymptotic)."""
    return float(np.sqrt(-0.5 * np.log(alpha / 2)) * np.sqrt((n + m) / (n * m)))


def one_level_R_direct(x: float, y: float, d: float) -> float:
    """k = 1, v = 1: R(x) = ∫ φ(σ0) / (1 + A_x(σ0)) by nested quadrature of
    A_x(σ0) = ∫_{σ > σ0 - x/d} φ(σ) (e^{y(x + d(σ - σ0))} - 1) dσ (no closed form used)."""

    def A(s0: float) -> float:
        lo = s0 - x / d
        val, _ = integrate.quad(
            lambda s: stats.norm.pdf(s) * np.expm1(y * (x + d * (s - s0))), lo, lo + 40.0,
            epsabs=1e-12, limit=200,
        )
        return val

    val, _ = integrate.quad(lambda s0: stats.norm.pdf(s0) / (1 + A(s0)), -10, 10, epsabs=1e-11,
                            limit=200)
    return val


def test_one_level_closed_form_matches_nested_quadrature():
    for x in (0.0, -0.2, -1.0):
        assert one_level_R(x, 1.0, 0.5) == pytest.approx(one_level_R_direct(x, 1.0, 0.5), abs=1e-8)
    assert one_level_R(0.0, 1.0, 0.5) == pytest.approx(0.744414083, abs=1e-9)


def test_one_level_no_jump_probability_and_cdf():
    n = 200_000
    r = sample_cascade_jumps([0.0], [1.0], 0.5, n, seed=11)
    p_exact = one_level_R(0.0, 1.0, 0.5)
    p, _ = r.p_no_jump()
    assert abs(p - p_exact) < Z * binom_se(p_exact, n)
    # the paper's χ (0.629) is excluded
    assert abs(p - 0.629) > 50 * binom_se(p_exact, n)
    for x in (-0.05, -0.2, -0.5, -1.0, -2.0):
        R = one_level_R(x, 1.0, 0.5)
        assert abs(r.R(x)[0] - R) < Z * binom_se(R, n), x
    assert np.all(r.dE <= 0)
    np.testing.assert_allclose(r.dE, r.dU - 0.5 * r.dSigma, atol=1e-12)


@pytest.mark.parametrize(
    "q,y,dg",
    [([0.0], [1.0], 0.5), ([0.3], [1.0], -0.8), ([0.0, 0.5], [0.2, 1.0], 0.5),
     ([0.2, 0.6], [0.3, 1.0], 0.7)],
)
def test_best_first_matches_brute_force(q, y, dg):
    n = 15_000
    a = sample_cascade_jumps(q, y, dg, 4 * n, seed=1)
    b = brute_force_cascade_jumps(q, y, dg, n, seed=2)
    # overlap categories (including "no jump"): each frequency within Z combined standard errors
    for qv in [*q, 1.0]:
        pa = np.mean(a.q_jump == qv)
        pb = np.mean(b.q_jump == qv)
        se = np.sqrt(binom_se(pa, a.n) ** 2 + binom_se(pb, b.n) ** 2)
        assert abs(pa - pb) < Z * se, (qv, pa, pb)
    ja, jb = a.jumped, b.jumped
    for field in ("dE", "dU", "dSigma"):
        xa = getattr(a, field)[ja]
        xb = getattr(b, field)[jb]
        ks = stats.ks_2samp(xa, xb).statistic
        assert ks < ks_threshold(xa.size, xb.size), (field, ks)


def test_exact_recursion_reduces_to_one_level():
    for x in (0.0, -0.3):
        assert exact_jump_R([0.0], [1.0], 0.5, x)[0] == pytest.approx(
            one_level_R(x, 1.0, 0.5), abs=1e-6)
    assert exact_jump_R([0.4], [1.7], 0.3, 0.0)[0] == pytest.approx(
        one_level_R(0.0, 1.7, 0.3, v=0.6), abs=1e-6)


def test_exact_recursion_matches_brute_force_two_levels():
    q, y, dg, n = [0.0, 0.5], [0.2, 1.0], 0.5, 40_000
    b = brute_force_cascade_jumps(q, y, dg, n, seed=5)
    xs = np.array([0.0, -0.1, -0.4, -1.0])
    R = exact_jump_R(q, y, dg, xs)
    for x, Rx in zip(xs, R, strict=True):
        assert abs(b.R(x)[0] - Rx) < Z * binom_se(Rx, n), x


@pytest.mark.parametrize("k,dg", [(3, 0.7), (16, 0.3)])
def test_sampler_matches_exact_recursion_many_levels(k, dg):
    q = 0.9 * np.arange(k) / (k - 1)
    y = 2.5 * np.linspace(0.05, 0.9, k)
    n = 100_000
    r = sample_cascade_jumps(q, y, dg, n, seed=k)
    xs = np.array([0.0, -0.05, -0.2, -0.6])
    R = exact_jump_R(q, y, dg, xs)
    for x, Rx in zip(xs, R, strict=True):
        assert abs(r.R(x)[0] - Rx) < Z * binom_se(Rx, n), (x, r.R(x)[0], Rx)


def test_sign_symmetry_and_reproducibility():
    q, y = [0.0, 0.4, 0.8], [0.5, 1.0, 2.0]
    a = sample_cascade_jumps(q, y, 0.3, 2000, seed=7)
    b = sample_cascade_jumps(q, y, 0.3, 2000, seed=7)
    np.testing.assert_array_equal(a.dE, b.dE)
    c = sample_cascade_jumps(q, y, -0.3, 2000, seed=7)
    # same realisation with every stress flipped
    np.testing.assert_allclose(c.dE, a.dE, atol=1e-12)
    np.testing.assert_allclose(c.dSigma, -a.dSigma, atol=1e-12)
    z = sample_cascade_jumps(q, y, 0.0, 500, seed=3)
    assert np.all(z.q_jump == 1.0) and np.all(z.dE == 0.0)


def test_constants_reduce_to_spec_at_zero_strain():
    from scipy.special import gamma

    q, y = [0.0, 0.3, 0.7], [0.5, 1.0, 3.0]
    c = cascade_constants(q, y, 0.0)["c"]
    c3 = 1.0
    c2 = (c3 / 3.0) ** (1 / 3) * gamma(1 - 1 / 3)
    c1 = (c2 / 1.0) ** 0.5 * gamma(0.5)
    np.testing.assert_allclose(c, [c1, c2, c3], rtol=1e-13)


def test_tree_contains_both_ground_states():
    t = sample_cascade_tree([0.0, 0.5], [0.5, 1.5], 0.5, seed=4)
    states = np.nonzero(t.level == 3)[0]
    assert t.old_gs in states and t.new_gs in states
    assert t.U[t.old_gs] == pytest.approx(t.U[states].min())
    v = t.U - 0.5 * t.Sigma
    assert v[t.new_gs] == pytest.approx(v[states].min())


@pytest.mark.parametrize(
    "q,y,dg", [([0.0, 0.5], [0.5, 1.5], 1.0), ([0.0, 0.3, 0.6], [0.4, 1.0, 2.5], -0.6)]
)
def test_tree_holds_the_plain_samplers_ground_states(q, y, dg):
    """The tree recorded for a seed holds the ground states and jump that the plain sampler
    returns for that seed, recomputed here from the tree's nodes; with ``window=0`` it is exactly
    the set of nodes the plain sampler drew, and a wider window only extends it."""
    k = len(q)
    qext = np.append(q, 1.0)
    jumps = 0
    for seed in range(40):
        j = sample_cascade_jumps(q, y, dg, 1, seed=seed)
        t0 = sample_cascade_tree(q, y, dg, seed=seed, window=0.0)
        t = sample_cascade_tree(q, y, dg, seed=seed, window=1.0)
        assert t0.parent.size == j.n_nodes[0]
        assert np.count_nonzero(t0.level == k + 1) == j.n_states[0]
        for name in ("parent", "level", "U", "Sigma"):
            np.testing.assert_array_equal(getattr(t, name)[: t0.parent.size], getattr(t0, name))
        states = np.nonzero(t.level == k + 1)[0]
        old = states[np.argmin(t.U[states])]
        new = states[np.argmin((t.U - dg * t.Sigma)[states])]
        assert (old, new) == (t.old_gs, t.new_gs) == (t0.old_gs, t0.new_gs)
        a, b = old, new
        while a != b:
            a, b = t.parent[a], t.parent[b]
        assert qext[t.level[a] - 1] == j.q_jump[0]
        if old == new:
            assert j.dE[0] == 0.0 and j.dU[0] == 0.0 and j.dSigma[0] == 0.0
        else:
            jumps += 1
            assert j.dU[0] == pytest.approx(t.U[new] - t.U[old], abs=1e-12)
            assert j.dSigma[0] == pytest.approx(t.Sigma[new] - t.Sigma[old], abs=1e-12)
            dE = (t.U[new] - dg * t.Sigma[new]) - (t.U[old] - dg * t.Sigma[old])
            assert j.dE[0] == pytest.approx(dE, abs=1e-12) and dE < 0
    assert jumps >= 5


def test_tree_at_the_node_limit_says_so_or_refuses():
    """sample_cascade_tree draws at most TREE_MAX_NODES nodes; it used to stop there silently,
    marking as ground states whatever it had found. Now (two levels, δγ = 3): seed 2 settles both
    ground states but stops inside the 1.5 window: ``truncated``, and the window it holds is
    complete (a tree asked for a slightly narrower one is a prefix of it, untruncated, with the
    same ground states); seed 34 stops before its ground states are settled: ValueError."""
    from jamlab.theory.cascade import TREE_MAX_NODES

    q, y = [0.0, 0.5], [0.5, 1.5]
    t = sample_cascade_tree(q, y, 3.0, seed=2)
    assert t.parent.size == TREE_MAX_NODES and t.truncated
    assert t.window == 1.5 and 0.0 < t.complete_window < 1.5
    inner = sample_cascade_tree(q, y, 3.0, seed=2, window=0.99 * t.complete_window)
    assert not inner.truncated and inner.complete_window == inner.window
    m = inner.parent.size
    assert m < TREE_MAX_NODES
    for name in ("parent", "level", "U", "Sigma"):
        np.testing.assert_array_equal(getattr(t, name)[:m], getattr(inner, name))
    assert (inner.old_gs, inner.new_gs) == (t.old_gs, t.new_gs)
    whole = sample_cascade_tree(q, y, 3.0, seed=0)
    assert not whole.truncated and whole.complete_window == 1.5
    with pytest.raises(ValueError, match="more than 65534 nodes to settle its two ground states"):
        sample_cascade_tree(q, y, 3.0, seed=34)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(q=[0.0, 0.5], y=[1.0, 0.5]), "increasing"),
        (dict(q=[0.5, 0.2], y=[1.0, 2.0]), "increasing"),
        (dict(q=[0.0, 1.0], y=[1.0, 2.0]), r"\[0, 1\)"),
        (dict(q=[0.0], y=[-1.0]), "positive"),
        (dict(q=[0.0], y=[1.0, 2.0]), "same length"),
        (dict(q=[0.0], y=[1.0], n=0), "positive integer"),
        (dict(q=[0.0], y=[1.0], dgamma=float("nan")), "finite"),
        (dict(q=[0.0], y=[1.0], seed=None), "seed"),
    ],
)
def test_validation(kwargs, match):
    args = dict(dgamma=0.1, n=10, seed=1) | kwargs
    with pytest.raises(ValueError, match=match):
        sample_cascade_jumps(**args)


def test_poisson_cluster_ablation_is_the_unmixed_one_level_formula():
    """``poisson_clusters=True`` at k = 1 is ``E_σ0[exp(-A(σ0))]`` (diagnostic option)."""
    from jamlab.theory.exact import one_level_A

    val, _ = integrate.quad(
        lambda s0: stats.norm.pdf(s0) * np.exp(-one_level_A(0.0, s0, 1.0, 0.5)), -12, 12,
        epsabs=1e-12)
    got = exact_jump_R([0.0], [1.0], 0.5, 0.0, poisson_clusters=True)[0]
    assert got == pytest.approx(val, abs=1e-6)


def test_seed_and_levels_are_checked():
    """A negative seed gave numpy's 'expected non-negative integer'; levels=8.5 was truncated to 8
    without a word. Both are now refused, naming the argument."""
    from jamlab.theory import ParisiFunction, exact_jump_law

    q, y = np.array([0.0, 0.5]), np.array([0.3, 0.7])
    with pytest.raises(ValueError, match=r"^seed must be an integer in \[0, "):
        sample_cascade_jumps(q, y, 0.1, 10, seed=-1)
    with pytest.raises(ValueError, match="^levels must be an integer >= 8, got 8.5$"):
        exact_jump_law(ParisiFunction.linear(1.0, 0.1, 0.9), 0.1, levels=8.5)
    # an integral float and a numpy integer are integers
    a = sample_cascade_jumps(q, y, 0.1, 50, seed=np.int64(3))
    b = sample_cascade_jumps(q, y, 0.1, 50, seed=3)
    np.testing.assert_array_equal(a.dE, b.dE)
