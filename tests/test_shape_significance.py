"""``scripts/shape_significance.py``: its rows are the library's test, the run directories are read
as the report counts avalanches, too few avalanches give a row that says so, and bad arguments
exit with code 2."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module

from jamlab.analysis import clustered_shape_test, sample_cutoff_power_law


@pytest.fixture(scope="module")
def ss():
    return script_module("shape_significance")


def test_row_is_the_library_test(ss):
    rng = np.random.default_rng(0)
    samples = [sample_cutoff_power_law(40, 1.4, 300.0, 1.0, rng) for _ in range(10)]
    want = clustered_shape_test(samples, 2.0)
    cells = [c.strip() for c in ss.row("x", samples, 2.0).strip("|").split("|")]
    assert len(cells) == 11 and cells[0] == "x"
    assert int(cells[1]) == want.samples and int(cells[2]) == want.n_tail
    assert float(cells[6]) == pytest.approx(want.lr, abs=0.006)
    assert float(cells[7]) == pytest.approx(want.scale, abs=0.006)


def test_too_few_avalanches_say_so(ss):
    assert "need >= 3 samples" in ss.row("x", [np.full(30, 2.0)], 1.0)


def test_reads_the_counted_avalanches(ss, small_pressure_run, monkeypatch, capsys):
    from jamlab.reproduce.ensembles import counted_steps
    from jamlab.runs import open_run

    ej, counted = counted_steps(open_run(small_pressure_run), "jamming", 16)
    monkeypatch.setattr("sys.argv", ["shape_significance.py", str(small_pressure_run),
                                     str(small_pressure_run), "--n", "16",
                                     "--floor", "1e-300"])
    ss.main()
    out = capsys.readouterr().out
    rows = [r for r in out.splitlines() if r.startswith("| p (N = 16)") or "pooled" in r]
    assert len(rows) == 3  # each run, then the two pooled
    # 5 counted avalanches in 3 packings: too few for the test, and the refusal counts them
    sizes = int(counted.sum())
    assert sizes < 20
    assert f"got 3 and {sizes}" in rows[0] and f"got 3 and {sizes}" in rows[1]
    assert f"got 6 and {2 * sizes}" in rows[2]


@pytest.mark.parametrize("argv", [
    ["a", "b", "--n", "250", "500", "1000", "--floor", "1e-9"],
    ["a", "--n", "250", "--floor", "0"],
    ["no-such-run", "--n", "250", "--floor", "1e-9"],
    ["a", "b", "--n", "250", "--floor", "1e-9", "--profile", "0.5"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--profile", "0"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--replicate", "1000=2"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--replicate", "500=0"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--replicate", "500"],
    ["a", "--n", "250", "--floor", "1e-9", "--replicate", "250=2"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--resample", "500=0"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--resample", "1000=2"],
    ["a", "b", "--n", "250", "500", "--floor", "1e-9", "--resample", "500=2", "--draws", "0"],
    ["a", "--n", "250", "--floor", "1e-9", "--resample", "250=2"],
    ["a", "--n", "250", "--floor", "1e-9", "--subsets", "500=5"],
    ["a", "b", "--n", "250", "--floor", "1e-9", "--take", "3"],
    ["a", "--n", "250", "--floor", "1e-9", "--take", "-1"],
    ["a", "--n", "250", "--floor", "1e-9", "--subsets", "250=5", "--draws", "0"],
])
def test_bad_arguments_exit_2(ss, monkeypatch, argv):
    assert exit_code(ss, argv, monkeypatch) == 2


def test_widening_the_set_of_shapes_only_widens_the_interval(ss, capsys):
    rng = np.random.default_rng(3)
    by_n = {n: [sample_cutoff_power_law(30, 1.4, 30.0 * n / 250, 1.0, rng, stretch=0.6)
                for _ in range(8)] for n in (250, 500)}
    same = ss.widened(by_n, 1.0, [0.5, 2.0], 4, 0.7)  # λ̂ < 1 is not let to narrow it
    assert same[0] == same[1]
    (lo, hi), (wlo, whi) = ss.widened(by_n, 1.0, [0.3, 0.5, 0.7, 2.0], 4, 3.0)
    assert wlo <= lo < hi <= whi
    assert "2Δlog L / 3.00 ≤ 3.84" in capsys.readouterr().out


def test_replicating_every_size_alike_scales_the_errors_by_root_k(ss):
    """Counting every packing K times leaves the estimates and divides both standard errors by
    √K (the information and the packings' score covariance both grow K-fold), up to the
    small-sample factors k/(k − 1) of the covariances over the k packings and the n avalanches;
    the design effect changes by those factors alone. Replicating one size moves the estimate
    (the sizes are re-weighted)."""
    rng = np.random.default_rng(5)
    by_n = {n: [sample_cutoff_power_law(60, 1.4, 30.0 * n / 250, 1.0, rng, stretch=0.6)
                for _ in range(8)] for n in (250, 500)}
    one = clustered_shape_test(by_n, 1.0)
    three = clustered_shape_test(ss.replicated(by_n, {250: 3, 500: 3}), 1.0)
    # to the optimiser's tolerance (≈ 1e-5 relative)
    assert three.tau == pytest.approx(one.tau, rel=1e-4)
    assert three.stretch == pytest.approx(one.stretch, rel=1e-3)
    k, n = one.samples, one.n_tail

    def small(m):  # the factor m/(m − 1) of the covariance over m units, 3m against m
        return (3 * m / (3 * m - 1)) / (m / (m - 1))

    assert three.samples == 3 * k and three.n_tail == 3 * n
    assert three.scale == pytest.approx(one.scale * small(k) / small(n), rel=1e-3)
    # the errors at â rest on a numerical Hessian there: 5e-3 relative (the k-factor is 2 %)
    assert three.tau_se_robust == pytest.approx(one.tau_se_robust * np.sqrt(small(k) / 3),
                                                rel=5e-3)
    assert three.tau_se == pytest.approx(one.tau_se / np.sqrt(3), rel=5e-3)
    assert ss.replicated(by_n, {500: 1}) == by_n
    moved = ss.replicated(by_n, {250: 4})
    assert len(moved[250]) == 32 and len(moved[500]) == 8
    assert ss.parse_factors(["250=4", "500=1"]) == {250: 4, 500: 1}
    with pytest.raises(ValueError, match="--subsets names N = 500 twice"):
        ss.parse_factors(["500=20", "500=40"], "--subsets")
    with pytest.raises(ValueError, match="without runs"):
        ss.replicated(by_n, {1000: 2})


def test_projected_rows_follow_the_measured_ones(ss, tmp_path, monkeypatch, capsys):
    """End to end through ``main``: ``--replicate`` adds the projected joint row (the library's
    test on the replicated packings) and, with ``--profile``, the projected shape-free intervals
    after the measured ones."""
    from types import SimpleNamespace

    rng = np.random.default_rng(9)
    by_n = {n: [sample_cutoff_power_law(40, 1.4, 30.0 * n / 250, 1.0, rng, stretch=0.7)
                for _ in range(6)] for n in (250, 500)}
    runs = {}
    for n in by_n:
        (tmp_path / str(n)).mkdir()
        runs[str(tmp_path / str(n))] = n
    monkeypatch.setattr(ss, "open_run", lambda run: runs[str(run)])
    monkeypatch.setattr(ss, "avalanche_set",
                        lambda n, label, size: SimpleNamespace(per_sample=by_n[n]))
    monkeypatch.setattr("sys.argv", ["shape_significance.py", *runs, "--n", "250", "500",
                                     "--floor", "1", "--replicate", "500=3",
                                     "--profile", "0.5", "--boot", "3"])
    ss.main()
    out = capsys.readouterr().out
    projected = [r for r in out.splitlines() if r.startswith("| joint, projected: N = 500 ×3")]
    want = clustered_shape_test({250: by_n[250], 500: by_n[500] * 3}, 1.0)
    assert len(projected) == 1 and f"| {want.samples} | {want.n_tail} |" in projected[0]
    assert out.count("Shape-free τ of the joint fits") == 2
    assert out.index("Projected (N = 500 ×3") > out.index("Shape-free τ of the joint fits")


def test_resampling_draws_from_the_measured_packings(ss):
    """``--resample``: the added packings are measured ones of the same size (so when every
    packing of that size is the same, a draw is the replication exactly), none added leaves
    the set as is, and the draws are the seed's."""
    rng = np.random.default_rng(2)
    by_n = {n: [sample_cutoff_power_law(30, 1.4, 30.0 * n / 250, 1.0, rng) for _ in range(5)]
            for n in (250, 500)}
    out = ss.resampled(by_n, {500: 7}, np.random.default_rng(0))
    assert out[250] == by_n[250] and len(out[500]) == 12 and out[500][:5] == by_n[500]
    assert all(any(x is y for y in by_n[500]) for x in out[500][5:])
    again = ss.resampled(by_n, {500: 7}, np.random.default_rng(0))
    assert [id(x) for x in again[500]] == [id(x) for x in out[500]]
    assert ss.resampled(by_n, {}, np.random.default_rng(0)) == by_n
    same = {250: by_n[250], 500: [by_n[500][0]] * 5}
    drawn = ss.resampled(same, {500: 10}, np.random.default_rng(1))
    assert drawn == ss.replicated(same, {500: 3})
    with pytest.raises(ValueError, match="without runs"):
        ss.resampled(by_n, {1000: 2}, np.random.default_rng(0))


def test_resampled_rows_summarise_the_draws(ss, capsys):
    """The printed medians and ranges are those of the library's test on the drawn sets."""
    rng = np.random.default_rng(4)
    by_n = {n: [sample_cutoff_power_law(40, 1.4, 30.0 * n / 250, 1.0, rng, stretch=0.7)
                for _ in range(6)] for n in (250, 500)}
    results = ss.resampled_rows(by_n, {500: 4}, 1.0, 5, 3, 1e9)
    draw = np.random.default_rng(3)
    want = [clustered_shape_test(ss.resampled(by_n, {500: 4}, draw), 1.0) for _ in range(5)]
    assert [r.tau for r in results] == [w.tau for w in want]
    out = capsys.readouterr().out
    assert "5 of 5 draws fitted, 16 packings each" in out
    assert f"σ_τ sandwich {np.median([w.tau_se_robust for w in want]):.3f}" in out
    assert "σ_τ ≤ 1e+09 in 100% of them" in out


def test_resampled_rows_leave_out_undefined_errors(ss, monkeypatch, capsys):
    """A draw whose ``H`` is not positive definite has no sandwich σ (NaN): the spread is that
    of the other draws, the count of such draws is printed, and they count as not ≤ target."""
    good = [0.04, 0.06, 0.08]
    fake = [type("R", (), {"stretch": 0.5, "tau": 1.4, "samples": 7, "tau_se_robust": s})()
            for s in good + [float("nan")]]
    monkeypatch.setattr(ss, "fitted", lambda sets, floor: fake)
    ss.resampled_rows({250: []}, {}, 1.0, 4, 0, 0.05)
    out = capsys.readouterr().out
    assert f"σ_τ sandwich {ss.spread(good, 3)} (1 draws with H not positive definite" in out
    assert "nan" not in out
    assert "σ_τ ≤ 0.05 in 25% of them" in out
    monkeypatch.setattr(ss, "fitted", lambda sets, floor: fake[3:])
    ss.resampled_rows({250: []}, {}, 1.0, 1, 0, 0.05)
    assert "σ_τ sandwich undefined (1 draws" in capsys.readouterr().out


def test_subsets_are_fitted_alone_and_place_each_run(ss, capsys):
    """``--subsets``: each draw is the library's test on ``K`` distinct packings chosen by the
    seed, and a run is placed by how far its ``â`` is from the subsets' median."""
    rng = np.random.default_rng(6)
    samples = [sample_cutoff_power_law(40, 1.4, 30.0, 1.0, rng, stretch=0.7) for _ in range(9)]
    got = ss.subset_rows(samples, 5, 1.0, 4, 2, [("far", 1e6)])
    draw = np.random.default_rng(2)
    picks = [draw.choice(9, 5, replace=False) for _ in range(4)]
    assert all(len(set(p)) == 5 for p in picks)
    want = [clustered_shape_test([samples[i] for i in p], 1.0).stretch for p in picks]
    assert got == want
    out = capsys.readouterr().out
    assert "4 of 4 fitted" in out and "far: â 1000000.00; subsets as far from the median: 0%" in out
    with pytest.raises(ValueError, match="3 <= K <= 9"):
        ss.subset_rows(samples, 10, 1.0, 4, 2, [])


def test_take_reads_each_runs_first_packings(ss, tmp_path, monkeypatch, capsys):
    """``--take``: a run's row (and the pooled one) is the library's test on its first ``K``
    packings; more than a run has is refused with exit 2, before any row is printed."""
    from types import SimpleNamespace

    rng = np.random.default_rng(8)
    packings = [sample_cutoff_power_law(40, 1.4, 30.0, 1.0, rng, stretch=0.7) for _ in range(7)]
    (tmp_path / "r").mkdir()
    monkeypatch.setattr(ss, "open_run", lambda run: run)
    monkeypatch.setattr(ss, "avalanche_set",
                        lambda run, label, size: SimpleNamespace(per_sample=packings))
    monkeypatch.setattr("sys.argv", ["shape_significance.py", str(tmp_path / "r"),
                                     str(tmp_path / "r"), "--n", "250", "--floor", "1",
                                     "--take", "5", "0"])
    ss.main()
    rows = [r for r in capsys.readouterr().out.splitlines()
            if r.startswith(("| r (N", "| N = 250 pooled"))]
    assert len(rows) == 3
    assert rows[0] == ss.row("r (N = 250)", packings[:5], 1.0)
    assert rows[1] == ss.row("r (N = 250)", packings, 1.0)
    assert rows[2] == ss.row("N = 250 pooled", packings[:5] + packings, 1.0)
    argv = [str(tmp_path / "r"), str(tmp_path / "r"), "--n", "250", "--floor", "1",
            "--take", "5", "8"]
    assert exit_code(ss, argv, monkeypatch) == 2
    out = capsys.readouterr()
    assert "Cut-off" not in out.out and "--take 8" in out.err  # refused before any row
