"""``scripts/paired_rates.py``: two small fixed-pressure runs of the same packings at two strain
steps; the per-packing rates recomputed from the sample files (h5py), the premise (the same
prepared packing at either step) and the refusals."""

from __future__ import annotations

import sys

import h5py
import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    from jamlab.runs import Execution, Study, run_study

    root = tmp_path_factory.mktemp("pr")
    for name, dg in (("a", 1e-3), ("b", 5e-4)):
        study = Study(phi=["jamming"], n=[16], samples=3, dgamma=dg, gamma_max=2e-2, seed=4,
                      pressure=1e-3)
        run_study(study, root / name, Execution(workers=0))
    other = Study(phi=["jamming"], n=[16], samples=2, dgamma=1e-3, gamma_max=2e-3, seed=4,
                  pressure=1e-2)
    run_study(other, root / "c", Execution(workers=0))
    return root


def test_per_packing_equals_the_sample_files(two_runs):
    from jamlab.runs import open_run

    pr = script_module("paired_rates")
    floors = [0.0, 1e-8]
    for name in ("a", "b"):
        got = pr.per_packing(open_run(two_runs / name), 16, floors)
        assert sorted(got) == [0, 1, 2]
        for i in got:
            with h5py.File(two_runs / name / f"samples/phi=jamming/N=16/sample-{i:05d}.h5") as h:
                t = {k: h[f"trace/{k}"][:] for k in ("gamma", "energy_jump", "plastic",
                                                      "jammed")}
            s = -t["energy_jump"][1:]
            keep = t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:] & (s > 0)
            strain = t["gamma"][-1] - t["gamma"][0]
            assert strain == pytest.approx(2e-2, rel=1e-9)
            for k, f in enumerate(floors):
                assert got[i][0][k] == pytest.approx(np.count_nonzero(keep & (s >= f)) / strain)
                assert got[i][1][k] == pytest.approx(s[keep & (s >= f)].sum() / strain)
    assert sum(v[0][0] for v in pr.per_packing(open_run(two_runs / "a"), 16, [0.0]).values()) > 0


def test_the_same_packing_at_either_step(two_runs):
    for i in range(3):
        start = []
        for name in ("a", "b"):
            with h5py.File(two_runs / name / f"samples/phi=jamming/N=16/sample-{i:05d}.h5") as h:
                start.append(h["trace/phi"][0])
        assert start[0] == start[1]


def test_wilcoxon_p():
    pr = script_module("paired_rates")
    x = np.arange(10.0)
    assert pr.wilcoxon_p(x, x) == 1.0
    assert pr.wilcoxon_p(x, x + 1.0) < 0.01


@pytest.mark.parametrize("which", ["c", "missing"])
def test_refuses_runs_that_differ_in_more_than_the_step(two_runs, monkeypatch, which):
    pr = script_module("paired_rates")
    argv = [str(two_runs / "a"), str(two_runs / which), "--n", "16"]
    assert exit_code(pr, argv, monkeypatch) == 2


def test_prints_a_row_per_floor(two_runs, monkeypatch, capsys):
    pr = script_module("paired_rates")
    monkeypatch.setattr(sys, "argv", ["paired_rates.py", str(two_runs / "a"),
                                      str(two_runs / "b"), "--n", "16", "--above", "1e-9",
                                      "1e-8"])
    pr.main()
    out = capsys.readouterr().out
    assert "3 packings in both" in out and "| 1e-09 |" in out and "| 1e-08 |" in out
    assert "volume_guess elastic), b" in out
