"""``scripts/rate_collapse.py`` on real run directories: its exponents against the analysis run on
an h5py recount of the same samples, its counts, and its refusals (exit code 2). The statistics:
tests/analysis/test_rate_collapse.py."""

from __future__ import annotations

import re

import numpy as np
import pytest

from script_helpers import script_module
from trace_recount import finished_samples, recount_sample


@pytest.fixture(scope="module")
def rc():
    return script_module("rate_collapse")


@pytest.fixture(scope="module")
def runs(pressure_runs_by_size):
    return pressure_runs_by_size


def test_refusals(rc, runs, tmp_path):
    two = [str(runs[16]), str(runs[24])]
    for argv in ([str(tmp_path), "--s-min", "1e-6"], [str(runs[16]), "--s-min", "1e-6"],
                 [*two], [*two, "--s-min", "0"], [*two, "--s-min", "1e-6", "--boot", "1"],
                 [*two, "--s-min", "1e-6", "--least", "0"],
                 [*two, "--s-min", "1e3"],  # no avalanche that large
                 [*two, "--s-min", "1e-6", "--figure", str(tmp_path / "f.txt")],
                 [*two, "--s-min", "1e-6", "--figure", str(runs[16] / "f.png")]):
        with pytest.raises(SystemExit) as err:
            rc.main(argv)
        assert err.value.code == 2


def test_a_constant_volume_run_refused(rc, runs, tmp_path, capsys):
    # jamlab.runs.open_pressure_run, which size_dependence.py uses too
    from jamlab.runs import Execution, Study, run_study

    study = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=0.005, seed=5)
    run_study(study, tmp_path / "cv", Execution(workers=0))
    with pytest.raises(SystemExit) as err:
        rc.main([str(tmp_path / "cv"), str(runs[16]), "--s-min", "1e-6"])
    assert err.value.code == 2
    assert "not a fixed-pressure study of one N (pressure None" in capsys.readouterr().err


def test_exponents_are_the_recounts(rc, runs, capsys, tmp_path):
    # N = 32 was sheared to half the strain of the others: the exposure is each packing's own
    import h5py

    from jamlab.analysis import rate_collapse

    ns = (16, 24, 32)
    groups = {n: [recount_sample(f) for f in finished_samples(runs[n])] for n in ns}
    strains = {}
    for n in ns:
        strains[n] = []
        for f in finished_samples(runs[n]):
            with h5py.File(f, "r") as h5:
                g = h5["trace/gamma"][()]
            strains[n].append(float(g[-1] - g[0]))
    assert strains[32] == pytest.approx([0.1] * 4) and strains[16] == pytest.approx([0.2] * 4)
    s_min = float(np.quantile(np.concatenate([np.concatenate(g) for g in groups.values()]), 0.2))
    argv = [*(str(runs[n]) for n in ns), "--s-min", repr(s_min), "--least", "2", "--boot", "5",
            "--figure", str(tmp_path / "rc.png")]
    try:
        code = rc.main(argv)
    except SystemExit as err:  # too few avalanches at these tiny sizes for a window's fit
        assert err.value.code == 2
        assert "fewer than" in capsys.readouterr().err
        return
    assert code == 0
    assert (tmp_path / "rc.png").stat().st_size > 0
    out = capsys.readouterr().out
    want = rate_collapse(groups, strains, s_min, least=2, boot=5)
    m = re.search(r"a = ([-\d.]+) ± ([\d.]+), b = ([-\d.]+) ± ([\d.]+)", out)
    assert m is not None
    assert [float(v) for v in m.groups()] == pytest.approx(
        [want.a, want.a_sigma, want.b, want.b_sigma], abs=6e-4)
    assert (f"16: 4, {want.tails[0]}, 0.2; 24: 4, {want.tails[1]}, 0.2; 32: 4, {want.tails[2]}, "
            "0.1") in out
    assert want.tails == tuple(int(sum(np.count_nonzero(a >= s_min) for a in groups[n]))
                               for n in ns)
