"""``scripts/medium_fraction.py --dirs ... --pool``: run directories of one study at different N
pooled into one estimate (counts recounted here with h5py), refusals with exit code 2."""

from __future__ import annotations

import json

import numpy as np
import pytest

from script_helpers import SCRIPTS, script_module
from trace_recount import finished_samples, recount, step_count


@pytest.fixture(scope="module")
def mf():
    return script_module("medium_fraction")


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    from jamlab.runs import Execution, Study, run_study

    root = tmp_path_factory.mktemp("runs")
    out = []
    for n in (16, 24):
        study = Study(phi=["jamming"], n=[n], samples=2, dgamma=1e-3, gamma_max=0.1, seed=3,
                      pressure=1e-3)
        run_study(study, root / f"n{n}", Execution(workers=0))
        out.append(root / f"n{n}")
    return out


def test_pooled_directories_hold_the_avalanches_of_both(mf, two_runs, capsys):
    from jamlab.reproduce.scales import SCALES
    from jamlab.runs import Study, open_run

    runs = [(ds, Study.from_dict(json.loads(ds.attrs["study"])))
            for ds in map(open_run, two_runs)]
    est = mf.analyse(runs, SCALES["medium"], "pooled")
    want = np.concatenate([recount(p) for p in two_runs])
    assert want.size > 0
    # (a preparation may fail: N = 24, seed 3)
    done = sum(len(finished_samples(p)) for p in two_runs)
    assert est.n_avalanches == want.size and est.samples == done >= 2
    out = capsys.readouterr().out
    assert f"N = [16, 24], {done} of 4 samples finished" in out
    # the projection is from CPU time (worker wall time counts a shared machine's waits)
    cpu = np.concatenate([np.asarray(ds.cpu_seconds.values).ravel()[
        np.asarray(ds.status.values).ravel() == "done"] for ds, _ in runs])
    assert (f"projected for all 4 samples of this study: {4 * cpu.mean() / 3600:.2f} h of one "
            "core (from the mean CPU time)") in out
    # one N twice is refused (the directories may share seeds)
    with pytest.raises(ValueError, match="one size in two run directories of one master seed"):
        mf.analyse([runs[0], runs[0]], SCALES["medium"], "twice")
    with pytest.raises(SystemExit) as err:  # and from the command line, with exit code 2
        mf.main(["--dirs", str(two_runs[0]), str(two_runs[0]), "--pool"])
    assert err.value.code == 2


def test_the_figure_needs_one_estimate_per_pressure(mf, two_runs, tmp_path):
    with pytest.raises(SystemExit) as err:
        mf.main(["--dirs", *map(str, two_runs), "--figure-dir", str(tmp_path)])
    assert err.value.code == 2
    assert mf.main(["--dirs", *map(str, two_runs), "--pool", "--figure-dir",
                    str(tmp_path)]) == 0
    with pytest.raises(SystemExit) as err:
        mf.main(["--dirs", str(tmp_path / "missing")])
    assert err.value.code == 2


def test_the_script_runs_as_a_program():
    import subprocess
    import sys

    out = subprocess.run([sys.executable, str(SCRIPTS / "medium_fraction.py"), "--help"],
                         capture_output=True, text=True, check=True).stdout
    assert "--pool" in out and "--figure-dir" in out


def test_two_realisations_of_one_size_are_pooled(mf, two_runs, tmp_path):
    """One N from two directories with different master seeds (two realisations: other
    packings) is pooled; the avalanches are those of both, recounted with h5py, in the pooled
    fits and in the N's own histogram and cut-off fit."""
    from jamlab.reproduce.scales import SCALES
    from jamlab.runs import Execution, Study, open_run, run_study

    other = tmp_path / "n16-s4"
    run_study(Study(phi=["jamming"], n=[16], samples=2, dgamma=1e-3, gamma_max=0.1, seed=4,
                    pressure=1e-3), other, Execution(workers=0))
    dirs = [two_runs[0], other]
    runs = [(ds, Study.from_dict(json.loads(ds.attrs["study"]))) for ds in map(open_run, dirs)]
    assert runs[0][1].seed != runs[1][1].seed
    est = mf.analyse(runs, SCALES["medium"], "two realisations")
    want = np.concatenate([recount(p) for p in dirs])
    assert want.size > 0 and est.n_avalanches == want.size
    assert est.samples == sum(len(finished_samples(p)) for p in dirs)
    assert mf.main(["--dirs", *map(str, dirs), "--pool", "--n-boot", "0"]) == 0
    # one N's histogram holds both realisations (sizes and steps), not the last one's
    steps = sum(step_count(p) for p in dirs)
    assert list(est.per_n) == [16] and est.per_n[16].counts.sum() == want.size
    assert est.per_n[16].n_total == est.steps == steps
    # with a second N, each N's cut-off fit in the pooled window holds all its sizes: N = 16
    # both realisations, N = 24 its one; and the figure (the per-N panel) is drawn
    three = dirs + [two_runs[1]]
    runs3 = [(ds, Study.from_dict(json.loads(ds.attrs["study"]))) for ds in map(open_run, three)]
    est3 = mf.analyse(runs3, SCALES["medium"], "two N, one twice")
    assert list(est3.per_n) == [16, 24]
    assert est3.per_n[16].counts.sum() == want.size
    assert est3.per_n[24].counts.sum() == recount(two_runs[1]).size
    cut = est3.cutoff
    if cut is not None:
        from jamlab.analysis import fit_cutoff_power_law

        for n, sizes in ((16, want), (24, recount(two_runs[1]))):
            got = est3.cutoff_per_n[n]
            if np.count_nonzero(sizes >= cut.x_min) < 10:
                assert got is None
            else:
                ref = fit_cutoff_power_law(sizes, cut.x_min)
                assert got.tau == pytest.approx(ref.tau, rel=1e-12) and got.n_tail == ref.n_tail
    assert mf.main(["--dirs", *map(str, three), "--pool", "--n-boot", "0", "--figure-dir",
                    str(tmp_path / "fig")]) == 0
    assert (tmp_path / "fig" / "tau_pressure.png").stat().st_size > 0
    assert (tmp_path / "fig" / "fig5_pressure.png").stat().st_size > 0
