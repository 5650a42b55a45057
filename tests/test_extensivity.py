"""``scripts/extensivity.py``: rate, mean size and release per particle and unit strain of a small
fixed-pressure run recomputed from the sample files (h5py), the bootstrap against the Poisson
error, the permutation test at its two limits, and the refusals."""

from __future__ import annotations

import math
import sys

import h5py
import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module


@pytest.fixture(scope="module")
def ex():
    return script_module("extensivity")


def direct(run, floor):
    """Per sample, from the sample files: the number and the sum of the sizes S = −ΔE ≥ floor of
    plastic steps with ΔE < 0 between two jammed minima, and the strain sheared."""
    counts, sums, strains = [], [], []
    for f in sorted(run.glob("samples/*/*/sample-*.h5")):
        with h5py.File(f) as h:
            t = {k: h[f"trace/{k}"][:] for k in ("gamma", "energy_jump", "plastic", "jammed")}
        s = -t["energy_jump"][1:]
        hit = t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:] & (s > 0) & (s >= floor)
        counts.append(int(hit.sum()))
        sums.append(float(s[hit].sum()))
        strains.append(float(t["gamma"][-1] - t["gamma"][0]))
    return np.array(counts, float), np.array(sums), np.array(strains)


def test_sums_and_pooled_by_hand(ex):
    per_sample = (np.array([1.0, 3.0, 0.5]), np.array([]), np.array([2.0]))
    counts, sums = ex.per_sample_sums(per_sample, 1.0)
    assert counts.tolist() == [2, 0, 1] and sums.tolist() == [4.0, 0.0, 2.0]
    # exposure 10·0.1 + 10·0.1 + 20·0.05 = 3: rate 3/3, mean 6/3, release 6/3
    val = ex.pooled(counts, sums, np.array([10.0, 10.0, 20.0]), np.array([0.1, 0.1, 0.05]))
    np.testing.assert_allclose(val, [1.0, 2.0, 2.0])
    assert math.isnan(ex.pooled(np.zeros(2), np.zeros(2), np.ones(2), np.ones(2))[1])


def test_run_values_equal_the_sample_files(ex, small_pressure_run):
    from jamlab.reproduce.ensembles import avalanche_set, sample_strains
    from jamlab.runs import open_run

    ds = open_run(small_pressure_run)
    per_sample = avalanche_set(ds, "jamming", 16).per_sample
    strains = sample_strains(ds, "jamming", 16)
    for floor in (1e-300, 1e-6):
        counts, sums, want_strains = direct(small_pressure_run, floor)
        got_counts, got_sums = ex.per_sample_sums(per_sample, floor)
        assert got_counts.tolist() == counts.tolist()
        np.testing.assert_allclose(got_sums, sums, rtol=1e-12)
        np.testing.assert_allclose(strains, want_strains, rtol=1e-12)
    counts, sums, _ = direct(small_pressure_run, 1e-300)
    assert counts.sum() > 0  # the run has avalanches to count
    exposure = 16 * strains.sum()
    val = ex.pooled(counts, sums, np.full(counts.size, 16.0), strains)
    np.testing.assert_allclose(val, [counts.sum() / exposure, sums.sum() / counts.sum(),
                                     sums.sum() / exposure], rtol=1e-12)


def test_energy_balance_closes_on_the_sample_files(ex, small_pressure_run):
    """work + given up − released = −Σ energy_jump of the uncounted steps, sample by sample,
    with work, given up and the uncounted steps read off the files."""
    from jamlab.reproduce.ensembles import avalanche_set
    from jamlab.runs import open_run

    ds = open_run(small_pressure_run)
    work, given_up, volume, avalanche_volume, dphi = ex.sample_energies(ds, 16)
    released = np.array([x.sum() for x in avalanche_set(ds, "jamming", 16).per_sample])
    want_work, want_given, want_volume, want_dphi, uncounted = [], [], [], [], []
    want_avalanche = []
    for f in sorted(small_pressure_run.glob("samples/*/*/sample-*.h5")):
        with h5py.File(f) as h:
            assert "packing/diameters" not in h  # monodisperse, diameter 1 (SPEC.md §5)
            t = {k: h[f"trace/{k}"][:] for k in ("gamma", "shear_stress", "energy",
                                                  "energy_jump", "plastic", "jammed", "phi")}
        # the volume from the particles' own volume, 16 π/6, and the trace's φ
        want_volume.append(1e-3 * 16 * math.pi / 6 * (1 / t["phi"][0] - 1 / t["phi"][-1]))
        want_dphi.append(t["phi"][-1] - t["phi"][0])
        counted = (t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:]
                   & (t["energy_jump"][1:] < 0))
        vol = 16 * math.pi / 6 / t["phi"]
        want_avalanche.append(1e-3 * (vol[:-1] - vol[1:])[counted].sum())
        want_work.append(sum((t["gamma"][k] - t["gamma"][k - 1]) * t["shear_stress"][k - 1]
                             for k in range(1, t["gamma"].size)))
        want_given.append(t["energy"][0] - t["energy"][-1])
        ej = t["energy_jump"][1:]
        counted = t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:] & (ej < 0)
        uncounted.append(ej[~counted].sum())
    np.testing.assert_allclose(work, want_work, rtol=1e-10)
    np.testing.assert_allclose(given_up, want_given, rtol=1e-10)
    np.testing.assert_allclose(volume, want_volume, rtol=1e-9)
    np.testing.assert_allclose(dphi, want_dphi, rtol=0, atol=1e-15)
    assert np.any(dphi != 0)  # the box did change: the volume part is not trivially 0
    np.testing.assert_allclose(avalanche_volume, want_avalanche, rtol=1e-9, atol=1e-15)
    assert np.any(avalanche_volume != 0)
    scale = np.abs(work).max()
    np.testing.assert_allclose(work + given_up - released, -np.array(uncounted), rtol=0,
                               atol=1e-9 * scale)
    exposure = np.full(work.size, 16.0) * 0.03
    val, err = ex.balance(work, given_up, volume, avalanche_volume, released, exposure, 50,
                          np.random.default_rng(1))
    np.testing.assert_allclose(val, np.array([work.sum(), given_up.sum(), volume.sum(),
                                              avalanche_volume.sum(), released.sum(),
                                              (work + given_up - released).sum()])
                               / exposure.sum(), rtol=1e-12)
    assert err.shape == (6,) and np.all(err >= 0)


def test_balance_difference_of_constant_samples_is_exact(ex):
    """Every sample of a run the same: the differences are exact and so are their intervals."""
    ones = np.ones(4)
    first = (1.0 * ones, 2.0 * ones, 1.5 * ones, 1.0 * ones, 3.0 * ones, -1e-4 * ones,
             10.0 * ones)
    second = (1.0 * ones[:3], 5.0 * ones[:3], 4.0 * ones[:3], 4.0 * ones[:3], 6.0 * ones[:3],
              2e-4 * ones[:3], 20.0 * ones[:3])
    val, lo, hi = ex.balance_difference(first, second, 30, np.random.default_rng(0))
    want = [0.05 - 0.1, 0.25 - 0.2, 0.2 - 0.15, 0.2 - 0.1, 0.3 - 0.3, 3e-4]
    for x in (val, lo, hi):
        np.testing.assert_allclose(x, want, rtol=0, atol=1e-15)


def test_bootstrap_error_of_the_rate_is_the_poisson_error(ex):
    rng = np.random.default_rng(3)
    m, lam = 400, 30.0
    counts = rng.poisson(lam, m).astype(float)
    sums = counts * 2.0
    parts, strains = np.full(m, 100.0), np.full(m, 0.01)
    draws = ex.bootstrap(counts, sums, parts, strains, 2000, rng)
    poisson = math.sqrt(counts.sum()) / (parts * strains).sum()
    assert np.std(draws[:, 0], ddof=1) == pytest.approx(poisson, rel=0.1)
    np.testing.assert_allclose(draws[:, 1], 2.0)  # every size is 2: the mean never moves


def test_permutation_p_at_its_limits(ex):
    rng = np.random.default_rng(5)
    one = (np.array([4.0, 6.0]), np.array([4.0, 6.0]), np.array([10.0, 10.0]),
           np.array([1.0, 1.0]))
    # the same samples in both runs: every deal gives the observed |ln ratio| = 0
    p = ex.permutation_p(one, one, np.ones(3), 99, rng)
    np.testing.assert_allclose(p, 1.0)
    # rates 1 against 2 per particle, 30 samples each of Poisson counts: no deal reaches it
    a = rng.poisson(100, 30).astype(float)
    b = rng.poisson(200, 30).astype(float)
    first = (a, a, np.full(30, 100.0), np.ones(30))
    second = (b, b, np.full(30, 100.0), np.ones(30))
    ratio = ex.pooled(*second) / ex.pooled(*first)
    p = ex.permutation_p(first, second, ratio, 199, rng)
    assert p[0] == pytest.approx(1 / 200) and p[2] == pytest.approx(1 / 200)
    assert p[1] > 0.05  # every size is 1 in both: the mean size does not differ


def test_slope_over_three_sizes_of_exact_power_laws(ex):
    """rate ∝ N^−0.5 and mean size ∝ N^0.25 exactly (identical samples): every slope, its
    interval and both two-size slopes are those powers."""
    runs = []
    for n in (100, 200, 400):
        counts = np.full(5, 10.0 * math.sqrt(n / 100))
        sums = counts * (n / 100) ** 0.25
        runs.append((n, (counts, sums, np.full(5, float(n)), np.full(5, 1.0 / 100))))
    v = ex.slope_values(runs, 30, np.random.default_rng(2))
    for key in ("slope", "lo", "hi", "first", "last"):
        np.testing.assert_allclose(v[key], [-0.5, 0.25, -0.25], atol=1e-12)
    np.testing.assert_allclose([v["change_lo"], v["change_hi"]], 0.0, atol=1e-12)


def test_rate_curves_count_by_hand(ex):
    rng = np.random.default_rng(0)
    per_sample = (np.array([1.0, 10.0, 100.0]), np.array([5.0]))
    grid = np.array([0.5, 5.0, 50.0, 500.0])
    rate, draws = ex.rate_curves({"r": (per_sample, 2.0, np.array([0.5, 0.5]))}, grid, 50, 1,
                                 rng)["r"]
    # exposure 2·0.5 + 2·0.5 = 2; counts ≥ S: 4, 3, 1, 0 (the last below least = 1)
    np.testing.assert_allclose(rate[:3], [2.0, 1.5, 0.5])
    assert math.isnan(rate[3]) and np.all(np.isnan(draws[:, 3]))
    assert draws.shape == (50, 4)


def test_main_prints_the_tables_and_the_figure(ex, small_pressure_run, tmp_path, monkeypatch,
                                               capsys):
    fig = tmp_path / "f.png"
    monkeypatch.setattr(sys, "argv", ["extensivity.py", str(small_pressure_run),
                                      str(small_pressure_run), "--n", "16", "--above", "1e-300",
                                      "--boot", "20", "--permutations", "9", "--figure",
                                      str(fig)])
    ex.main()
    out = capsys.readouterr().out
    counts, sums, strains = direct(small_pressure_run, 1e-300)
    rate = counts.sum() / (16 * strains.sum())
    assert f"| {int(counts.sum())} | {rate:.3g} ±" in out
    steps = 3 * 30  # the fixture: 3 samples of 30 steps
    assert f"| {steps} | {int(counts.sum())} | {counts.sum() / steps:.4f} (" in out
    # a run against itself: ratio 1 and p = 1 for each quantity
    assert out.count("| 1.000 (") == 3 and out.count("| 1 |") == 3
    # and its balance against itself: every difference 0
    assert "| 16 − 16 | +0 (" in out
    assert out.split("| 16 − 16 |")[1].split("\n")[0].count("+0 (") == 6
    assert fig.stat().st_size > 0


@pytest.mark.parametrize("argv", [
    ["a", "b", "--n", "250", "500", "1000", "--above", "1e-9"],
    ["a", "--n", "16", "--above", "0"],
    ["a", "--n", "16", "--above", "1e-9", "--boot", "1"],
    ["a", "--n", "16", "--above", "1e-9", "--permutations", "-1"],
    ["a", "b", "--n", "16", "--above", "1e-9", "--labels", "x"],
])
def test_bad_arguments_exit_2(ex, monkeypatch, argv):
    assert exit_code(ex, argv, monkeypatch) == 2


def test_a_size_the_run_lacks_exits_2(ex, small_pressure_run, monkeypatch, capsys):
    argv = [str(small_pressure_run), "--n", "999", "--above", "1e-9"]
    assert exit_code(ex, argv, monkeypatch) == 2
    assert "no φ label jamming at N = 999" in capsys.readouterr().err


def test_phi_label_and_one_run_at_two_sizes(ex, tmp_path_factory, monkeypatch, capsys):
    """``--phi``: a constant-volume run above jamming (φ = 0.8, N = 16 and 24 in one study),
    named twice with ``--n 16 24``, is read at each size; its energy balance per particle and
    unit strain equals the sums over the sample files (h5py) of each size."""
    from jamlab.runs import Execution, Study, run_study

    run = tmp_path_factory.mktemp("cv-two-sizes") / "cv"
    run_study(Study(phi=[0.8], n=[16, 24], samples=3, dgamma=1e-3, gamma_max=0.1, seed=6),
              run, Execution(workers=0))
    monkeypatch.setattr(sys, "argv", ["extensivity.py", str(run), str(run), "--n", "16", "24",
                                      "--phi", "0.8", "--above", "1e-300", "--boot", "20",
                                      "--permutations", "9"])
    ex.main()
    out = capsys.readouterr().out
    balance = out.split("## Energy balance")[1].split("## Where")[0]
    for n in (16, 24):
        work, given, strain = 0.0, 0.0, 0.0
        for f in sorted(run.glob(f"samples/phi=0.8*/N={n}/sample-*.h5")):
            with h5py.File(f) as h:
                g, sig, e = (h[f"trace/{k}"][:] for k in ("gamma", "shear_stress", "energy"))
            work += float(np.sum(np.diff(g) * sig[:-1]))
            given += float(e[0] - e[-1])
            strain += float(g[-1] - g[0])
        row = [r for r in balance.splitlines() if r.startswith(f"| cv N={n} | {n} (3) |")]
        assert len(row) == 1, balance
        cells = row[0].split("|")
        assert cells[3].strip().startswith(f"{work / (n * strain):.3g} ±")
        assert cells[4].strip().startswith(f"{given / (n * strain):.3g} ±")


def test_a_phi_label_the_run_lacks_exits_2(ex, small_pressure_run, monkeypatch):
    argv = [str(small_pressure_run), "--n", "16", "--phi", "0.75", "--above", "1e-9"]
    assert exit_code(ex, argv, monkeypatch) == 2
