"""``scripts/shear_order.py``: a tiny run's rows recomputed from the sheared packing itself, the
results file's round trip, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import assert_out_kept, exit_code, script_module


@pytest.fixture(scope="module")
def so():
    return script_module("shear_order")


def test_rows_recomputed_by_hand(so):
    from jamlab.analysis.order import bond_order
    from jamlab.spheres import aqs, prepare
    from jamlab.spheres.potential import energy, virial

    rows = so.one_sample((40, 0.8, 3, "mono", 2e-3, 0.02, 0.01, 1.0))
    assert rows.shape == (3, len(so.COLUMNS))
    np.testing.assert_allclose(rows[:, 0], [0.0, 0.01, 0.02])
    packing = prepare(40, 3, 0.8, 3).packing
    for k, row in enumerate(rows):
        if k:
            packing = aqs.shear(packing, 2e-3, n_steps=5, classify=False).packing
        assert packing.box.strain == pytest.approx(row[0])
        o = bond_order(packing.positions, packing.box.length, packing.box.strain)
        assert row[1] == o.crystalline_fraction and row[2] == o.global_q
        assert row[3] == pytest.approx(energy(packing) / 40, rel=1e-12)
        assert row[4] == pytest.approx(virial(packing)[0, 1] / packing.box.length ** 3,
                                       rel=1e-9, abs=1e-15)


def test_run_and_round_trip(so, tmp_path, capsys):
    out = tmp_path / "o.npz"
    so.main(["--n", "40", "--samples", "2", "--sizes", "mono", "bidisperse", "--gamma-max",
             "0.01", "--every", "0.01", "--dgamma", "5e-3", "--out", str(out)])
    text = capsys.readouterr().out
    assert "| mono | 40 (2) | 0.01 |" in text and "| bidisperse | 40 (2) | 0 |" in text
    so.main(["--load", str(out)])
    assert capsys.readouterr().out == text


def test_the_quench_alone(so):
    rows = so.one_sample((40, 0.8, 3, "bidisperse", 1e-3, 0.0, 0.1, 1.3))
    assert rows.shape == (1, len(so.COLUMNS)) and rows[0, 0] == 0.0
    from jamlab.analysis.order import bond_order
    from jamlab.spheres import prepare

    p = prepare(40, 3, 0.8, 3, sizes="bidisperse").packing
    assert rows[0, 2] == bond_order(p.positions, p.box.length, 0.0, p.diameters, 1.3).global_q


@pytest.mark.parametrize("argv", [["--phi", "0.3"], ["--n", "8"], ["--gamma-max", "-1"],
                                  ["--dgamma", "0.2", "--every", "0.1"],
                                  ["--samples", "0"], ["--load", "/nonexistent.npz"],
                                  ["--cutoff", "0"],
                                  ["--sizes", "poly"]])
def test_bad_arguments_exit_2(so, monkeypatch, argv):
    assert exit_code(so, argv, monkeypatch) == 2


def test_existing_out_is_not_overwritten(so, tmp_path, monkeypatch):
    assert_out_kept(so, tmp_path / "o.npz", monkeypatch)
