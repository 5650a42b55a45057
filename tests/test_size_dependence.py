"""``scripts/size_dependence.py`` on real run directories: its size counts against an h5py
recount, and its refusals (exit code 2). The statistics: tests/analysis/test_size_difference.py."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from script_helpers import script_module


@pytest.fixture(scope="module")
def sd():
    return script_module("size_dependence")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    from jamlab.runs import Execution, Study, run_study

    root = tmp_path_factory.mktemp("sd_runs")
    out = {}
    for n in (16, 24):
        study = Study(phi=["jamming"], n=[n], samples=4, dgamma=1e-3, gamma_max=0.2, seed=5,
                      pressure=1e-3)
        run_study(study, root / f"n{n}", Execution(workers=0))
        out[n] = root / f"n{n}"
    return out


def _recount(path) -> np.ndarray:
    """Avalanche sizes −ΔH (plastic steps with ΔH < 0 between jammed minima) of a run, read
    with h5py."""
    sizes = [np.empty(0)]
    for f in sorted(path.glob("samples/*/*/*.h5")):
        with h5py.File(f, "r") as h5:
            de, pl = h5["trace/energy_jump"][1:], h5["trace/plastic"][1:].astype(bool)
            jm = h5["trace/jammed"][()]
        sizes.append(-de[pl & (de < 0) & jm[:-1] & jm[1:]])
    return np.concatenate(sizes)


def test_real_runs_and_refusals(sd, runs, tmp_path, capsys):
    # exit code 2, one line: not a run directory; one size only
    for argv in ([str(tmp_path)], [str(runs[16])], [str(runs[16]), str(runs[24]), "--boot", "1"]):
        with pytest.raises(SystemExit) as err:
            sd.main(argv)
        assert err.value.code == 2
    # two sizes: a row for p = 0.001 whose size counts are the h5py recount's in the window
    # (checked only where each size has the 10 sizes a fit needs)
    from jamlab.reproduce.measurements import avalanche_set
    from jamlab.runs import open_run

    counts = [sum(a.size for a in avalanche_set(open_run(runs[n]), "jamming", n).per_sample)
              for n in (16, 24)]
    assert counts == [_recount(runs[16]).size, _recount(runs[24]).size]
    try:
        code = sd.main([str(runs[16]), str(runs[24]), "--boot", "20"])
    except SystemExit as err:  # too few avalanches in the window at this tiny size
        assert err.value.code == 2
        assert "fewer than 10" in capsys.readouterr().err
        return
    assert code == 0
    out = capsys.readouterr().out
    assert "over 1 pressure(s)" in out
    row = next(line for line in out.splitlines() if line.startswith("| 0.001 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    x_min = float(cells[1])  # (printed to 3 digits: the counts are compared away from it)
    for cell, n in zip(cells[2:4], (16, 24), strict=True):
        k, tail = (int(v) for v in cell.split(":")[1].split(",")[:2])
        s = _recount(runs[n])
        assert k == len(list(runs[n].glob("samples/*/*/*.h5")))
        assert np.count_nonzero(s >= x_min * 1.001) <= tail <= np.count_nonzero(s >= x_min * 0.999)
