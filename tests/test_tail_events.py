"""``scripts/tail_events.py``: per-sample counts, dispersion, halves and the event list of a small
fixed-pressure run recomputed from the sample files (h5py), the statistics by hand and exact
enumeration, and the refusals."""

from __future__ import annotations

import sys

import h5py
import numpy as np
import pytest
from scipy import stats
from tests.script_helpers import script_module


@pytest.fixture(scope="module")
def te():
    return script_module("tail_events")


@pytest.fixture(scope="module")
def small_run(small_pressure_run):
    return small_pressure_run


def test_dispersion_by_hand_and_by_enumeration(te):
    d = te.dispersion(np.array([2, 0]), trials=99999, seed=1)
    assert (d["total"], d["mean"], d["variance"], d["index"], d["chi2"]) == (2, 1.0, 2.0, 2.0, 2.0)
    assert d["p_chi2"] == pytest.approx(stats.chi2.sf(2.0, 1))
    # two events in two equal cells: (2,0), (1,1), (0,2) with 1/4, 1/2, 1/4; Σc² ≥ 4 has 1/2
    assert d["p_exact"] == pytest.approx(0.5, abs=0.01)
    # three events in three cells, all in one: 3 · (1/3)³ = 1/9
    assert te.dispersion(np.array([3, 0, 0]), 99999)["p_exact"] == pytest.approx(1 / 9, abs=0.005)
    # evenly spread: every deal has Σc² ≥ 3
    assert te.dispersion(np.array([1, 1, 1]), 999)["p_exact"] == 1.0
    assert np.isnan(te.dispersion(np.array([0, 0, 0]), 10)["index"])
    assert np.isnan(te.dispersion(np.array([4, 1]), 0)["p_exact"])


def test_top_share_and_halves_by_hand(te):
    assert te.top_share(np.array([0, 3, 0, 3, 1, 1, 1]), 2) == pytest.approx(6 / 9)
    assert np.isnan(te.top_share(np.zeros(3), 2))
    sizes = np.array([[1.0, 0.0, 5.0, 5.0, 5.0], [5.0, 0.0, 0.0, 5.0, 0.0]])
    counted = sizes > 0
    # first half: columns 0–1 (5 // 2 = 2): 1 event ≥ 2; second half: 4
    first, second, p = te.halves(sizes, counted, 2.0)
    assert (first, second) == (1, 4)
    assert p == pytest.approx(2 * (1 + 5) / 32)  # two-sided binomial, n = 5
    assert np.isnan(te.halves(sizes, counted, 10.0)[2])


def test_lag_pairs_by_hand_and_by_placement(te):
    sizes = np.array([[5.0, 5.0, 0.0, 5.0, 0.0, 0.0], [0.0, 5.0, 0.0, 0.0, 0.0, 0.0]])
    counted = sizes > 0
    # row 0 has events at 0, 1, 3: one pair at lag 1 (0–1), one at lag 2 (1–3), one at lag 3
    # (0–3); expected: 3 · 2 · (6 − ℓ)/(6 · 5) (row 1 has one event: no pair)
    for lag, observed in ((1, 1), (2, 1), (3, 1), (4, 0)):
        assert te.lag_pairs(sizes, counted, 1.0, lag) == (observed, pytest.approx(
            6 * (6 - lag) / 30))
    # the expectation is that of uniform placement: 3 events among 6 steps, all 20 placements
    from itertools import combinations

    for lag in (1, 2):
        mean = np.mean([sum(1 for a in pl for b in pl if b - a == lag)
                        for pl in combinations(range(6), 3)])
        assert te.lag_pairs(sizes[:1], counted[:1], 1.0, lag)[1] == pytest.approx(mean)


def test_far_lag_baseline_by_hand_and_against_a_drifting_rate(te):
    # one row of 200 steps, events at 0, 1, 50, 120: of the six pairs, those at lags 20–100 are
    # 0–50, 1–50 and 50–120: 3 pairs over Σ(200 − L) positions
    sizes = np.zeros((1, 200))
    sizes[0, [0, 1, 50, 120]] = 1.0
    counted = sizes > 0
    positions = sum(200 - g for g in range(20, 101))
    expected, p, fewer = te.far_lag_baseline(sizes, counted, 0.5, 1)
    assert expected == pytest.approx(3 / positions * 199)
    assert p == pytest.approx(stats.poisson.sf(0, expected))  # one observed pair at lag 1
    assert fewer == pytest.approx(np.exp(-expected) * (1 + expected))  # P(X ≤ 1), by hand
    # at lag 2 no pair: P(X ≥ 0) = 1, P(X ≤ 0) = e^(−μ), μ scaled to the 198 positions
    expected2, p2, fewer2 = te.far_lag_baseline(sizes, counted, 0.5, 2)
    assert expected2 == pytest.approx(3 / positions * 198)
    assert p2 == pytest.approx(1.0) and fewer2 == pytest.approx(np.exp(-expected2))
    assert te.far_text(0, expected2, p2, fewer2).endswith(f"(fewer, p {fewer2:.2g})")
    assert te.far_text(1, expected, p, fewer).endswith(f"(p {p:.2g})")
    # independent events at a rate that grows along the window (and differs by sample): the
    # far-lag baseline follows the pairs at lag 1 (simulated), the uniform placement does not
    rng = np.random.default_rng(3)
    ramp = np.linspace(0.002, 0.06, 1000) * rng.uniform(0.5, 1.5, size=(400, 1))
    hit = rng.random((400, 1000)) < ramp
    observed = int((hit[:, 1:] & hit[:, :-1]).sum())
    far = te.far_lag_baseline(hit.astype(float), hit, 0.5, 1)[0]
    uniform = te.lag_pairs(hit.astype(float), hit, 0.5, 1)[1]
    assert 0.8 * observed < far < 1.1 * observed
    assert uniform < 0.8 * observed  # what the drift adds, which uniform placement misses


def test_follow_on_by_hand(te):
    # two samples of 6 steps; events (S ≥ 1) at steps 0, 1, 3 of row 0 and 2 of row 1: 4 events
    # in 12 steps (base 1/3); those with a next step: 0 (followed), 1, 3, 2 (not)
    sizes = np.array([[5.0, 50.0, 0.0, 500.0, 0.0, 0.0], [0.0, 0.0, 5.0, 0.0, 0.0, 0.0]])
    counted = sizes > 0
    z_nr = np.array([[6.0, 6.1, 6.0, 6.0, 5.9, 5.9, 5.9], [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 6.0]])
    out = te.follow_on(sizes, counted, z_nr, 1.0)
    assert out["base"] == pytest.approx(4 / 12)
    g = out["groups"]
    assert g["all"][:2] == (4, 1)
    assert g["all"][2] == pytest.approx(stats.binomtest(1, 4, 1 / 3, alternative="greater").pvalue)
    assert g["S in [1e+00, 1e+01)"][:2] == (2, 1)  # steps 0 (followed) and row 1's step 2
    assert g["S in [1e+01, 1e+02)"][:2] == (1, 0)
    assert g["S in [1e+02, inf)"][:2] == (1, 0)
    # Δz_nr of step k is z_nr[k + 1] − z_nr[k]: step 0 +0.1, step 1 −0.1, step 3 −0.1, row 1 0
    assert g["Δz_nr > 0"][:2] == (1, 1) and g["Δz_nr < 0"][:2] == (2, 0)
    assert g["Δz_nr = 0"][:2] == (1, 0)


def direct(run, floor):
    """Per-sample counts and the events ≥ floor from the sample files: S = −ΔE of plastic steps
    with ΔE < 0 between two jammed minima; μ = σ_xy/p at the step's start, σ_xy = Σ/V with the
    row's volume V = N (π/6)/φ (monodisperse spheres of unit diameter)."""
    counts, events = [], []
    for f in sorted(run.glob("samples/*/*/sample-*.h5")):
        with h5py.File(f) as h:
            t = {k: h[f"trace/{k}"][:] for k in ("shear_stress", "pressure", "gamma", "phi",
                                                  "energy_jump", "plastic", "jammed")}
            n, index = int(h.attrs["n"]), int(h.attrs["index"])
        s = -t["energy_jump"][1:]
        hit = t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:] & (s > 0) & (s >= floor)
        counts.append(int(hit.sum()))
        mu = t["shear_stress"] * t["phi"] / (n * np.pi / 6) / t["pressure"]
        events += [(index, k + 1, t["gamma"][k + 1], s[k], mu[k], t["pressure"][k])
                   for k in np.flatnonzero(hit)]
    return counts, sorted(events, key=lambda e: -e[3])


def test_run_tail_equals_the_sample_files(te, small_run):
    from jamlab.runs import open_run

    t = te.run_tail(open_run(small_run), 16, [1e-300, 1e-6])
    for floor in (1e-300, 1e-6):
        counts, _ = direct(small_run, floor)
        assert t["counts"][floor].tolist() == counts
    counts, events = direct(small_run, 1e-6)
    assert sum(counts) > 0  # the run has events to list
    assert len(t["events"]) == len(events)
    for got, want in zip(t["events"], events, strict=True):
        assert got[:2] == want[:2]
        np.testing.assert_allclose(got[2:], want[2:], rtol=1e-12)
    assert len(t["mu"]) + len(t["mu_rest"]) == sum(direct(small_run, 1e-300)[0])
    # the consecutive pairs, from the events read off the sample files
    every = {(e[0], e[1]): e[3] for e in direct(small_run, 1e-300)[1]}
    want = sorted((i, k, every[i, k - 1], s) for (i, k), s in every.items() if (i, k - 1) in every)
    assert [q[:2] for q in t["pairs"][1e-300]] == [q[:2] for q in want]
    np.testing.assert_allclose([q[2:] for q in t["pairs"][1e-300]], [q[2:] for q in want],
                               rtol=1e-12)


@pytest.mark.parametrize("argv", [
    ["a", "b", "--n", "250", "500", "1000"],
    ["a", "--above", "0"],
    ["a", "--trials", "-1"],
    ["a", "--top", "0"],
    ["a", "--bursts", "1e-8", "0", "1e-9"],
    ["a", "--bursts", "1e-8", "2.5", "1e-9"],
    ["a", "--bursts", "0", "3", "1e-9"],
])
def test_bad_arguments_exit_2(te, monkeypatch, argv):
    monkeypatch.setattr(sys, "argv", ["tail_events.py", *argv])
    with pytest.raises(SystemExit) as e:
        te.main()
    assert e.value.code == 2


def test_pair_order_counts_which_of_two_consecutive_is_larger(te):
    sizes = np.array([[1.0, 5.0, 0.0, 3.0, 2.0, 9.0],
                      [4.0, 1.0, 0.5, 0.0, 7.0, 8.0]])
    counted = sizes > 0
    # consecutive counted pairs: (1,5) (3,2) (2,9) | (4,1) (1,0.5) (7,8): 6 pairs, 3 larger second
    assert te.pair_order(sizes, counted, 0.1) == (6, 3, 1.0)
    # above 0.9 the 0.5 drops out: (1,5) (3,2) (2,9) (4,1) (7,8) -> 3 of 5
    k, larger, p = te.pair_order(sizes, counted, 0.9)
    assert (k, larger) == (5, 3)
    assert p == pytest.approx(stats.binomtest(3, 5, 0.5).pvalue)
    assert te.pair_order(sizes, counted, 100.0) == (0, 0, 1.0)


def test_pair_order_of_iid_sizes_is_even(te):
    rng = np.random.default_rng(4)
    sizes = rng.pareto(0.5, size=(50, 400))
    k, larger, p = te.pair_order(sizes, np.ones_like(sizes, dtype=bool), 0.0)
    assert k == 50 * 399 and abs(larger / k - 0.5) < 0.02 and p > 1e-3


def test_consecutive_pairs_lists_the_pairs_by_hand(te):
    sizes = np.array([[1.0, 5.0, 0.0, 3.0, 2.0, 9.0],
                      [4.0, 1.0, 0.5, 0.0, 7.0, 8.0]])
    counted = sizes > 0
    counted[1, 5] = False  # an uncounted step (e.g. unjammed) breaks the pair (7, 8)
    ids = np.array([3, 11])
    # column b is the step b + 1 of the trace, so the second of a pair at columns (b, b + 1)
    # is the step b + 2
    assert te.consecutive_pairs(sizes, counted, 0.1, ids) == [
        (3, 2, 1.0, 5.0), (3, 5, 3.0, 2.0), (3, 6, 2.0, 9.0), (11, 2, 4.0, 1.0),
        (11, 3, 1.0, 0.5)]
    assert te.consecutive_pairs(sizes, counted, 0.9, ids) == [
        (3, 2, 1.0, 5.0), (3, 5, 3.0, 2.0), (3, 6, 2.0, 9.0), (11, 2, 4.0, 1.0)]
    k, larger, _ = te.pair_order(sizes, counted, 0.1)
    pairs = te.consecutive_pairs(sizes, counted, 0.1, ids)
    assert (k, larger) == (len(pairs), sum(q[3] > q[2] for q in pairs))


def test_followers_by_a_loop_over_events(te):
    rng = np.random.default_rng(4)
    sizes = rng.pareto(0.5, size=(6, 200)) * 1e-10
    counted = rng.random((6, 200)) < 0.3
    floor, window = float(np.quantile(sizes[counted], 0.8)), 3
    want = np.zeros_like(counted)
    for i, k in zip(*np.nonzero(counted & (sizes >= floor)), strict=True):
        for lag in range(1, window + 1):
            if k + lag < sizes.shape[1] and counted[i, k + lag]:
                want[i, k + lag] = True
    got = te.followers(sizes, counted, floor, window)
    assert got.any() and np.array_equal(got, want)
    # by hand: the large event at column 1 makes columns 2 and 3 followers (window 2), the
    # uncounted column 2 is not one; the large event at column 3 makes column 4 one
    s = np.array([[1.0, 9.0, 1.0, 8.0, 1.0, 1.0]])
    c = np.array([[True, True, False, True, True, True]])
    assert te.followers(s, c, 5.0, 2).tolist() == [[False, False, False, True, True, True]]


def test_burst_fit_drops_the_followers_and_refits(te):
    rng = np.random.default_rng(5)
    sizes = (rng.pareto(0.5, size=(10, 300)) + 1.0) * 1e-10
    counted = rng.random((10, 300)) < 0.5
    floor, window, x_min = float(np.quantile(sizes[counted], 0.9)), 2, 2e-10
    b = te.burst_fit(sizes, counted, floor, window, x_min)
    drop = te.followers(sizes, counted, floor, window)
    assert b["dropped"] == (int(drop.sum()), int((sizes[drop] >= x_min).sum()))
    assert b["all"].n_tail == int((sizes[counted] >= x_min).sum())
    assert b["without"].n_tail == b["all"].n_tail - b["dropped"][1]
    # i.i.d. sizes: dropping the followers moves τ by noise only
    assert abs(b["without"].tau - b["all"].tau) < 4 * b["sigma_diff"]


def test_follower_sizes_finds_planted_aftershocks_and_not_iid_ones(te):
    rng = np.random.default_rng(6)
    # i.i.d. sizes, each sample with its own scale: no effect
    scale = np.exp(rng.normal(0, 1, size=(8, 1)))
    sizes = (rng.pareto(0.6, size=(8, 400)) + 1.0) * scale
    counted = rng.random((8, 400)) < 0.4
    floor = float(np.quantile(sizes[counted], 0.9))
    iid = te.follower_sizes(sizes, counted, floor, 3, 1.0, 100, 200, seed=1)
    assert iid["n"] > 0 and iid["p"] > 0.01
    # the statistic by hand
    f = te.followers(sizes, counted, floor, 3)
    big = sizes >= 1.0
    want = np.mean(np.log(sizes[f & big])) - np.mean(np.log(sizes[counted & ~f & big]))
    assert iid["delta"] == pytest.approx(want, rel=1e-12)
    # aftershocks: every counted step within 3 after a large event made 20 times larger
    planted = sizes.copy()
    planted[f] *= 20.0
    shocked = te.follower_sizes(planted, counted, floor, 3, 1.0, 100, 200, seed=1)
    assert shocked["delta"] > 2.0 and shocked["p"] < 0.01
