"""scripts/cutoff_shape.py: the profile with one packing left out, and the jackknife error."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module

from jamlab.analysis import cutoff_shape_profile

cs = script_module("cutoff_shape")


def power_law_cutoff(rng: np.random.Generator, n: int, tau: float, x_c: float) -> np.ndarray:
    """``n`` draws of ``x^(−τ) e^(−x/x_c)`` on ``[1, ∞)``: Pareto by inversion, thinned by the
    exponential factor (rejection)."""
    out = np.empty(0)
    while out.size < n:
        x = (1.0 - rng.random(4 * n)) ** (-1.0 / (tau - 1.0))
        out = np.concatenate([out, x[rng.random(x.size) < np.exp(-x / x_c)]])
    return out[:n]


GRID = (0.5, 1.0, 2.0)  # a short grid of shapes: the bookkeeping, not the physics, is tested


def test_each_left_out_profile_is_the_profile_of_the_rest():
    rng = np.random.default_rng(3)
    s = power_law_cutoff(rng, 240, 1.5, 100.0)
    groups = rng.integers(0, 3, s.size) * 7 + 5  # labels 5, 12, 19 in random order
    rows = cs.leave_one_out(s, groups, 2.0, GRID)
    assert [r["group"] for r in rows] == [5, 12, 19]
    for r in rows:
        rest = s[groups != r["group"]]
        direct = cutoff_shape_profile(rest, 2.0, GRID)
        assert r["profile"].n_tail == direct.n_tail == np.count_nonzero(rest >= 2.0)
        assert r["removed"] == np.count_nonzero((groups == r["group"]) & (s >= 2.0))
        assert r["removed"] + r["profile"].n_tail == np.count_nonzero(s >= 2.0)
        assert r["profile"].taus == direct.taus
        assert r["profile"].best == direct.best


def test_jackknife_of_the_mean_is_its_standard_error():
    """For the mean, the jackknife standard error equals s/√n exactly."""
    x = np.random.default_rng(5).normal(size=37)
    loo = (x.sum() - x) / (x.size - 1)
    assert cs.jackknife_se(loo) == pytest.approx(x.std(ddof=1) / np.sqrt(x.size), rel=1e-12)


def test_bad_groups_are_refused():
    s = np.arange(1.0, 31.0)
    with pytest.raises(ValueError, match="group labels"):
        cs.leave_one_out(s, np.zeros(29), 1.0)
    with pytest.raises(ValueError, match="two groups"):
        cs.leave_one_out(s, np.zeros(30), 1.0)


def test_plan_pools_only_what_each_run_holds():
    held = [("a", [500]), ("b", [1000]), ("c", [500, 1000])]
    assert cs.plan(held, [500, 1000], pool=False) == [[(0, 500)], [(1, 1000)],
                                                      [(2, 500), (2, 1000)]]
    assert cs.plan(held[:2], [500, 1000], pool=True) == [[(0, 500), (1, 1000)]]
    assert cs.plan(held[1:], [1000], pool=False) == [[(0, 1000)], [(1, 1000)]]
    with pytest.raises(ValueError, match=r"a: holds N = \[500\], none of --n \[1000\]"):
        cs.plan(held, [1000], pool=True)


def test_packing_labels_tell_sources_apart():
    ids = [np.array([0, 3, 3]), np.array([3, 7])]
    np.testing.assert_array_equal(cs.packing_labels([500], ids[:1]), [0, 3, 3])
    both = cs.packing_labels([500, 1000], ids)
    np.testing.assert_array_equal(both, [500_000_000, 500_000_003, 500_000_003,
                                         1_000_000_003, 1_000_000_007])
    same_n = cs.packing_labels([500, 500], ids)  # two runs of one N: by source index
    assert np.unique(same_n).size == 4
    np.testing.assert_array_equal(same_n, [0, 3, 3, 1_000_003, 1_000_007])


def test_leave_out_report_jackknifes_the_fixed_shape(capsys):
    """The printed jackknife 'held fixed' is that of τ at the full data's best a, each packing
    left out (profiles recomputed here directly), not of τ at each leave-one-out's own best a."""
    rng = np.random.default_rng(11)
    s = power_law_cutoff(rng, 300, 1.5, 50.0)
    groups = rng.integers(0, 4, s.size)
    full = cutoff_shape_profile(s, 2.0, GRID)
    cs.leave_out_report(s, groups, full)
    out = capsys.readouterr().out
    k = full.stretches.index(full.best)
    fixed = [cutoff_shape_profile(s[groups != g], 2.0, GRID).taus[k] for g in range(4)]
    rechosen = [cutoff_shape_profile(s[groups != g], 2.0, GRID).tau_best for g in range(4)]
    assert f"at a = {full.best:g} held fixed ± {cs.jackknife_se(np.array(fixed)):.3f}" in out
    assert f"τ at the best a {full.tau_best:.3f} ± {cs.jackknife_se(np.array(rechosen)):.3f}" in out
