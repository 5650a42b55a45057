"""``scripts/cutoff_groups.py``: τ shared by groups with one cut-off each, against the library's
single fit, against data drawn with known group cut-offs, the grouping by hand, the run reader
on a small fixed-pressure run, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module

from jamlab.analysis import fit_cutoff_power_law, sample_cutoff_power_law


@pytest.fixture(scope="module")
def cg():
    return script_module("cutoff_groups")


def test_one_group_is_the_library_fit(cg):
    x = sample_cutoff_power_law(1500, 1.45, 3e-7, 1e-9, np.random.default_rng(0))
    want = fit_cutoff_power_law(x, 1e-9)
    got = cg.fit_groups([x], 1e-9)
    assert got["tau"] == pytest.approx(want.tau, abs=1e-6)
    assert got["tau_stderr"] == pytest.approx(want.tau_stderr, rel=1e-3)
    assert got["loglik"] == pytest.approx(want.loglik, abs=1e-6)
    assert got["cutoffs"][0] == pytest.approx(want.x_c, rel=1e-4)


def test_groups_with_their_own_cutoffs_recover_tau_and_the_cutoffs(cg):
    rng = np.random.default_rng(1)
    tau, cuts = 1.4, (1e-7, 1e-6, 1e-5)
    groups = [sample_cutoff_power_law(1500, tau, c, 1e-9, rng) for c in cuts]
    fit = cg.fit_groups(groups + [np.array([1e-12])], 1e-9)  # a group below the floor
    assert fit["groups_used"] == 3 and fit["groups_empty"] == 1
    assert abs(fit["tau"] - tau) < 4 * fit["tau_stderr"]
    for got, want in zip(fit["cutoffs"], cuts, strict=True):
        assert 0.5 < got / want < 2.0
    # one cut-off for the mixture is worse by far, and looks stretched
    rows = {r["model"]: r for r in cg.compare({"one": [np.concatenate(groups)],
                                                "parts": groups}, 1e-9)}
    assert rows["parts, a = 1"]["lr"] > 30
    assert rows["shape"]["a"] < 1.0
    assert rows["parts, a = 1"]["daic"] < 0


def test_group_sizes_by_hand(cg):
    sizes = np.arange(1.0, 13.0).reshape(2, 6)
    counted = np.ones((2, 6), dtype=bool)
    counted[0, 1] = False
    parts = cg.group_sizes(sizes, counted, "parts", 3)
    assert [p.tolist() for p in parts] == [[1.0, 7.0, 8.0], [3.0, 4.0, 9.0, 10.0],
                                           [5.0, 6.0, 11.0, 12.0]]
    rows = cg.group_sizes(sizes, counted, "samples", 3)
    assert [r.tolist() for r in rows] == [[1.0, 3.0, 4.0, 5.0, 6.0], [7.0, 8.0, 9.0, 10.0,
                                                                     11.0, 12.0]]
    with pytest.raises(ValueError):
        cg.group_sizes(sizes, counted, "parts", 7)


def test_null_daic_draws_every_model(cg):
    rng = np.random.default_rng(2)
    x = sample_cutoff_power_law(400, 1.4, 1e-7, 1e-9, rng, stretch=0.6)
    groups = {"one": [x], "parts": np.split(x, 2), "samples": np.split(x, 4)}
    null = cg.null_daic(groups, 1e-9, 2, seed=1)
    assert set(null) == {"one", "shape", "parts, a = 1", "parts, a free", "samples, a = 1",
                         "samples, a free"}
    assert all(v.shape == (2,) and np.all(np.isfinite(v)) for v in null.values())
    assert np.all(null["shape"] == 0.0)


def test_run_groups_reads_the_counted_avalanches(cg, small_pressure_run):
    from jamlab.reproduce.ensembles import counted_steps
    from jamlab.runs import open_run

    run, n = small_pressure_run, 16
    ej, counted = counted_steps(open_run(run), "jamming", n)
    g = cg.run_groups([run], [n], 2)
    assert np.array_equal(np.sort(g["one"][0]), np.sort(-ej[counted]))
    assert sum(a.size for a in g["parts"]) == sum(a.size for a in g["samples"]) == counted.sum()
    late = cg.run_groups([run], [n], 3, skip=10)
    assert np.array_equal(np.sort(late["one"][0]), np.sort(-ej[:, 10:][counted[:, 10:]]))
    assert len(late["parts"]) == 3 and sum(a.size for a in late["parts"]) == counted[:, 10:].sum()
    with pytest.raises(ValueError):
        cg.run_groups([run], [n], 2, skip=ej.shape[1])


@pytest.mark.parametrize("argv", [
    ["a", "b", "--n", "250", "500", "1000", "--x-min", "1e-9"],
    ["a", "--n", "250", "--x-min", "0"],
    ["a", "--n", "250", "--x-min", "1e-9", "--parts", "0"],
    ["a", "--n", "250", "--x-min", "1e-9", "--null", "-1"],
    ["a", "--n", "250", "--x-min", "1e-9", "--skip", "-1"],
])
def test_bad_arguments_exit_2(cg, monkeypatch, argv):
    assert exit_code(cg, argv, monkeypatch) == 2


def test_best_shape_of_one_group_is_the_library_profile(cg):
    from jamlab.analysis import cutoff_shape_profile

    x = sample_cutoff_power_law(800, 1.4, 1e-7, 1e-9, np.random.default_rng(3), stretch=0.6)
    grid = (0.4, 0.6, 1.0, 1.5)
    want = cutoff_shape_profile(x, 1e-9, grid)
    got = cg.best_shape([x], 1e-9, grid)
    assert got["a"] == want.best
    assert got["fit"]["tau"] == pytest.approx(want.tau_best, abs=1e-5)
    assert got["lr_exponential"] == pytest.approx(want.lr_exponential, abs=1e-4)
    assert got["tau_low"] == pytest.approx(want.tau_low, abs=2e-3)
    assert got["tau_high"] == pytest.approx(want.tau_high, abs=2e-3)
