"""``scripts/compare_runs.py`` on two hand-made run directories: its counts against ones made by
hand here, and its refusals."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from tests.script_helpers import script_module

STUDY = {"phi": ["jamming"], "n": [8], "samples": 2, "dgamma": 1e-5, "gamma_max": 5e-5,
         "pressure": 1e-6}


def make_run(root, traces, study=STUDY, cpu=None):
    root.mkdir()
    manifest = {"format": "jamlab-run", "format_version": 1, "study": study}
    (root / "manifest.json").write_text(json.dumps(manifest))
    folder = root / "samples" / "phi=jamming" / "N=8"
    folder.mkdir(parents=True)
    for i, t in enumerate(traces):
        with h5py.File(folder / f"sample-{i:05d}.h5", "w") as h5:
            for k, v in t.items():
                h5[f"trace/{k}"] = v
            if cpu is not None:
                h5.attrs["cpu_seconds"] = cpu[i]
    return root


def trace(jump, plastic, jammed):
    jump = np.array([np.nan, *jump])
    energy = np.nancumsum(np.concatenate([[1.0], jump[1:]]))
    return {"energy": energy, "energy_jump": jump, "plastic": np.array([False, *plastic]),
            "jammed": np.array(jammed)}


@pytest.fixture
def runs(tmp_path):
    a0 = trace([-1e-9, 1e-12, -3e-9, -2e-9, 1e-12], [True, False, True, True, False],
               [True, True, True, True, False, True])
    a1 = trace([-5e-10, 1e-12, 1e-12, -4e-9, 1e-12], [True, False, False, True, False],
               [True] * 6)
    # b: sample 0 differs from step 4 on (the unjammed minimum of a left: a jammed one, the
    # step flagged plastic), sample 1 is the same
    b0 = trace([-1e-9, 1e-12, -3e-9, -2e-9, -6e-9], [True, False, True, True, True], [True] * 6)
    return make_run(tmp_path / "a", [a0, a1]), make_run(tmp_path / "b", [b0, a1])


def test_counts_against_hand_counts(runs, capsys):
    mod = script_module("compare_runs")
    assert mod.main([str(runs[0]), str(runs[1])]) == 0
    out = capsys.readouterr().out
    # a: minimum 4 of sample 0 unjammed -> steps 4 and 5 excluded; avalanches: sample 0 steps 1
    # and 3 (step 4 ends unjammed), sample 1 steps 1 and 4 -> 4 of 10 steps
    assert "| 10 | 1 | 2 | 4 | 0.4000 |" in out
    # b: nothing unjammed; sample 0 steps 1, 3, 4, 5, sample 1 steps 1, 4 -> 6
    assert "| 10 | 0 | 0 | 6 | 0.6000 |" in out
    # shared events: sample 0 steps 1 and 3 (a's step 4 ends unjammed; b's 4 and 5 are b's
    # only), sample 1 steps 1 and 4 -> 4 in both, all of the same size; a only 0, b only 2
    assert ("in both runs: 4, of which 4 of the same size to 0.001 relative; in a only: 0, "
            "in b only: 2") in out
    # no iterations in these traces, no cpu_seconds: the cost is not made up
    assert out.count("| – | – |") == 2
    assert "| N=8/sample-00000 | [5] | [4] | 5 of 6 | 5 | 4 |" in out
    assert "| N=8/sample-00001 | [] | [] | 6 of 6 | None | None |" in out
    mean_a = np.mean([1e-9, 3e-9, 5e-10, 4e-9])
    assert f"{mean_a:.3e}" in out


def test_s_min_line_counts_and_tests_the_cut_sizes(runs, capsys):
    """``--s-min``: the counts and the KS statistic of the sizes at or above it, against the
    sizes listed by hand (a: 1, 3, 0.5, 4 × 1e-9; b: 1, 3, 2, 6, 0.5, 4 × 1e-9) and scipy."""
    from scipy.stats import ks_2samp

    mod = script_module("compare_runs")
    assert mod.main([str(runs[0]), str(runs[1]), "--s-min", "2.5e-9"]) == 0
    out = capsys.readouterr().out
    exact = ks_2samp([3e-9, 4e-9], [3e-9, 6e-9, 4e-9])
    assert f"S ≥ 2.5e-09: 2 / 3 avalanches, D = {exact.statistic:.4f}, " in out


def test_different_studies_are_refused(tmp_path, capsys):
    mod = script_module("compare_runs")
    t = trace([-1e-9], [True], [True, True])
    a = make_run(tmp_path / "a", [t])
    b = make_run(tmp_path / "b", [t], study={**STUDY, "pressure": 1e-5})
    with pytest.raises(SystemExit) as err:
        mod.main([str(a), str(b)])
    assert err.value.code == 2
    assert "different studies (pressure)" in capsys.readouterr().err


def test_checkpoint_interval_is_not_a_different_study(tmp_path, capsys):
    # a resumed sample equals the uninterrupted one, so checkpointing every K steps or not at
    # all is the same study
    mod = script_module("compare_runs")
    t = trace([-1e-9], [True], [True, True])
    a = make_run(tmp_path / "a", [t])
    b = make_run(tmp_path / "b", [t], study={**STUDY, "checkpoint_every": 100})
    assert mod.main([str(a), str(b)]) == 0
    assert "| N=8/sample-00000 | [] | [] | 2 of 2 | None | None |" in capsys.readouterr().out


def test_the_box_side_rule_is_compared_not_refused(tmp_path, capsys):
    # comparing the rule before (a manifest without volume_guess: "always") with the new one is
    # what the script is for: the rule of each run is printed
    mod = script_module("compare_runs")
    t = trace([-1e-9], [True], [True, True])
    a = make_run(tmp_path / "a", [t])
    b = make_run(tmp_path / "b", [t], study={**STUDY, "volume_guess": "elastic"})
    assert mod.main([str(a), str(b)]) == 0
    assert "volume_guess: 'always' (a), 'elastic' (b)" in capsys.readouterr().out


def test_cost_per_sample(tmp_path, capsys):
    mod = script_module("compare_runs")
    t0 = {**trace([-1e-9], [True], [True, True]), "iterations": np.array([0, 300])}
    t1 = {**trace([-1e-9], [True], [True, True]), "iterations": np.array([0, 100])}
    a = make_run(tmp_path / "a", [t0, t1], cpu=[2.0, 4.0])
    b = make_run(tmp_path / "b", [t0, t1])
    assert mod.main([str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert "| 200 (100–300) | 3.0 (2.0–4.0) |" in out  # a: mean (range) of the two samples
    assert "| 200 (100–300) | – |" in out  # b records no CPU time


def test_same_step_other_size_is_counted_apart(tmp_path, capsys):
    mod = script_module("compare_runs")
    a = make_run(tmp_path / "a", [trace([-1e-9, -2e-9], [True, True], [True] * 3)])
    b = make_run(tmp_path / "b", [trace([-1.0005e-9, -3e-9], [True, True], [True] * 3)])
    assert mod.main([str(a), str(b)]) == 0
    # step 1: 5e-4 relative (the same); step 2: 50 % (another minimum)
    assert ("in both runs: 2, of which 1 of the same size to 0.001 relative; in a only: 0, "
            "in b only: 0") in capsys.readouterr().out


def test_two_realisations_are_pooled_not_paired(tmp_path, capsys):
    """Runs of other seeds are refused as a pair and pooled with ``--independent``: the pooled
    counts are those of the hand-counted fixture, b's three packings included, and nothing is
    compared sample by sample."""
    mod = script_module("compare_runs")
    a0 = trace([-1e-9, 1e-12, -3e-9, -2e-9, 1e-12], [True, False, True, True, False],
               [True, True, True, True, False, True])
    a1 = trace([-5e-10, 1e-12, 1e-12, -4e-9, 1e-12], [True, False, False, True, False],
               [True] * 6)
    b0 = trace([-1e-9, 1e-12, -3e-9, -2e-9, -6e-9], [True, False, True, True, True], [True] * 6)
    a = make_run(tmp_path / "a", [a0, a1])
    b = make_run(tmp_path / "b", [b0, a1, a1], study={**STUDY, "seed": 1, "samples": 3})
    with pytest.raises(SystemExit) as err:
        mod.main([str(a), str(b)])
    assert err.value.code == 2 and "different studies (seed)" in capsys.readouterr().err
    assert mod.main([str(a), str(b), "--independent", "--permutations", "50"]) == 0
    out = capsys.readouterr().out
    assert "two realisations" in out and "2 samples, " in out and ": 3" in out
    assert "| 10 | 1 | 2 | 4 | 0.4000 |" in out  # as the paired comparison counts a
    assert "| 15 | 0 | 0 | 8 | 0.5333 |" in out  # b: 6 (as paired) + sample 1 again (2)
    assert "the same events?" not in out and "| sample |" not in out
    assert "over packings p = " in out and "50 exchanges of whole packings" in out


def test_packing_permutation_ks_of_singletons_is_the_exact_ks():
    """With one avalanche per packing, exchanging packings is exchanging avalanches: the
    permutation p is the exact two-sample KS p (``ks_2samp(method="exact")``), to the Monte
    Carlo error of 4,000 exchanges."""
    mod = script_module("compare_runs")
    rng = np.random.default_rng(2)
    a = [np.array([x]) for x in rng.exponential(1.0, 7)]
    b = [np.array([x]) for x in rng.exponential(2.5, 6)]
    from scipy.stats import ks_2samp

    d, p, perm = mod.packing_ks(a, b, 4000)
    exact = ks_2samp(np.concatenate(a), np.concatenate(b), method="exact")
    assert d == pytest.approx(exact.statistic)
    assert 0.01 < exact.pvalue < 0.9  # a case the test can tell
    assert perm == pytest.approx(exact.pvalue, abs=4 * np.sqrt(exact.pvalue / 4000) + 1e-3)
    assert np.isnan(mod.packing_ks(a, b, 0)[2])


def test_bad_permutation_count_exits_2(runs, capsys):
    mod = script_module("compare_runs")
    with pytest.raises(SystemExit) as err:
        mod.main([str(runs[0]), str(runs[1]), "--independent", "--permutations", "-1"])
    assert err.value.code == 2
