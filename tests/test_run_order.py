"""``scripts/run_order.py``: each sample's order recomputed from the positions in its file, the
split of the counted avalanches between amorphous and ordered samples, the fit of all against
the report's rule, and the refusals."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module


@pytest.fixture(scope="module")
def ro():
    return script_module("run_order")


@pytest.fixture(scope="module")
def unsat_run(tmp_path_factory):
    from jamlab.runs import Execution, Study, run_study

    out = tmp_path_factory.mktemp("unsat-run") / "u"
    study = Study(phi=[0.75], n=[40], samples=8, dgamma=1e-3, gamma_max=0.06, seed=11)
    run_study(study, out, Execution(workers=0))
    return out


def test_order_of_each_sample_from_its_file(ro, unsat_run):
    from jamlab.analysis.order import bond_order

    (cell,) = ro.read([unsat_run], None)
    assert cell["label"] == "0.75" and cell["n"] == 40 and cell["order"].shape == (8, 2)
    files = sorted((unsat_run / "samples").rglob("sample-*.h5"))
    assert len(files) == 8
    for row, f in zip(cell["order"], files, strict=True):
        with h5py.File(f, "r") as h5:
            pos = h5["packing/positions"][()]
            length = float(h5.attrs["box_length"])
        o = bond_order(pos, length, 0.0)
        assert tuple(row) == pytest.approx((o.crystalline_fraction, o.global_q), abs=1e-12)


def test_tables_split_the_avalanches(ro, unsat_run, capsys):
    from jamlab.analysis import fit_power_law

    cells = ro.read([unsat_run], None)
    (cell,) = cells
    # a threshold that puts the most ordered sample alone in the ordered group
    frac = cell["order"][:, 0]
    assert 0 < np.sum(frac > 0.05) < 8  # this run has both (5 of 8 ordered at N = 40)
    top = int(np.argmax(frac))
    threshold = float(np.sort(frac)[-2]) if frac.size > 1 else 0.0
    if frac[top] <= threshold:  # ties: nothing is alone above; the split is still by the rule
        threshold = float(frac[top])
    ro.tables(cells, threshold, boot=5, min_tail=5)
    text = capsys.readouterr().out
    n_ord = int(np.sum(frac > threshold))
    assert f"| 0.75 | 40 | u | 8 | {n_ord} (" in text
    every = np.concatenate(cell["sizes"])
    row_all = next(r for r in text.splitlines() if r.startswith("| 0.75 | all | 8 |"))
    assert f"| {every.size} |" in row_all
    if every.size >= 5:
        f = fit_power_law(every, x_max=float(every.max()), min_tail=5, n_boot=5, seed=0)
        assert f"{f.tau:.3f} [{f.ci_low:.3f}, {f.ci_high:.3f}], {f.n_tail}" in row_all
    amorphous = sum(s.size for s, x in zip(cell["sizes"], frac, strict=True) if x <= threshold)
    row_am = next(r for r in text.splitlines()
                  if r.startswith(f"| 0.75 | amorphous | {8 - n_ord} | {amorphous} |"))
    if every.size >= 5:  # the window of all: τ, its interval and the tail counted here
        kept = np.concatenate([s for s, x in zip(cell["sizes"], frac, strict=True)
                               if x <= threshold] or [np.empty(0)])
        tail = int(np.count_nonzero(kept >= f.x_min))
        window = row_am.rstrip(" |").rsplit(" | ", 1)[1]
        if tail >= 5:
            g = fit_power_law(kept, x_min=f.x_min, x_max=float(kept.max()), n_boot=5, seed=0)
            assert window == f"{g.tau:.3f} [{g.ci_low:.3f}, {g.ci_high:.3f}], {tail}"
        else:
            assert window == "fewer than 5 sizes"


def test_refusals(ro, unsat_run, tmp_path, monkeypatch):
    assert exit_code(ro, [str(tmp_path)], monkeypatch) == 2  # not a run
    assert exit_code(ro, [str(unsat_run), "--phi", "0.9"], monkeypatch) == 2  # no such label
    assert exit_code(ro, [str(unsat_run), "--ordered", "1.5"], monkeypatch) == 2
    assert exit_code(ro, [str(unsat_run), "--cutoff", "0"], monkeypatch) == 2


def test_cutoff_reaches_the_first_shell(ro, unsat_run):
    from jamlab.analysis.order import bond_order
    from jamlab.runs.load import prepared_packing

    (cell,) = ro.read([unsat_run], None, cutoff=1.3)
    first = sorted((unsat_run / "samples").rglob("sample-*.h5"))[0]
    p = prepared_packing(first)
    o = bond_order(p.positions, p.box.length, p.box.strain, cutoff=1.3)
    assert tuple(cell["order"][0]) == pytest.approx((o.crystalline_fraction, o.global_q))
