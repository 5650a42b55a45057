"""``jamlab prepare`` and ``jamlab coordination``: files, attributes, exit codes."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from cli_helpers import run_in_process as run
from jamlab.spheres.io import read_packing
from jamlab.spheres.packing import describe


def test_prepare_jamming_and_coordination(tmp_path, capsys) -> None:
    out = tmp_path / "jammed.h5"
    args = ["prepare", "--n", "128", "--dim", "3", "--phi", "jamming", "--seed", "1"]
    assert run([*args, "--out", str(out), "--quiet"]) == 0
    packing = read_packing(out)
    state = describe(packing)  # recomputed from positions, independent of the stored attrs
    with h5py.File(out, "r") as h5:
        a = dict(h5.attrs)
    assert bool(a["ok"]) and a["protocol"] == "jamming" and a["seed"] == 1
    assert a["phi_j"] == pytest.approx(packing.phi, rel=1e-14)
    assert a["n_contacts_nr"] == state.n_contacts_nr == state.n_contacts_iso
    assert a["pressure"] == pytest.approx(state.pressure, rel=1e-12)
    assert a["param_p_target"] == 1e-7 and a["param_search"] == "window"
    assert 0.5e-7 <= a["pressure"] <= 2e-7
    fig, csv = tmp_path / "fig1.png", tmp_path / "fig1.csv"
    code = run(
        ["coordination", str(out), "--out", str(fig), "--csv", str(csv), "--steps", "8", "--quiet"]
    )
    assert code == 0 and fig.stat().st_size > 0
    table = np.genfromtxt(csv, delimiter=",", names=True)
    assert len(table) == 8 and np.all(np.diff(table["pressure"]) > 0)
    assert "p ~ (phi - phi_J)^" in capsys.readouterr().out


def test_prepare_unsat_and_errors(tmp_path, capsys) -> None:
    out = tmp_path / "unsat.h5"
    assert (
        run(["prepare", "--n", "128", "--phi", "0.8", "--seed", "2", "--out", str(out), "--quiet"])
        == 0
    )
    with h5py.File(out, "r") as h5:
        assert h5.attrs["protocol"] == "direct" and bool(h5.attrs["ok"])
    assert read_packing(out).phi == pytest.approx(0.8)
    capsys.readouterr()
    assert run(["prepare", "--n", "128", "--phi", "0.5", "--out", str(out)]) == 2
    assert "below jamming" in capsys.readouterr().err
    assert run(["prepare", "--n", "128", "--phi", "dense", "--out", str(out)]) == 2
    capsys.readouterr()
    assert run(["prepare", "--n", "128", "--sizes", "tri", "--out", str(out)]) == 2
    assert "sizes must be mono, bidisperse or polydisperse" in capsys.readouterr().err
    assert run(["prepare", "--n", "128", "--alpha", "1", "--out", str(out)]) == 2
    assert "alpha must be finite and > 1" in capsys.readouterr().err


def test_prepare_bidisperse_2d_hertzian(tmp_path) -> None:
    out = tmp_path / "bi.h5"
    args = ["prepare", "--n", "64", "--dim", "2", "--seed", "3", "--sizes", "bidisperse"]
    assert run([*args, "--alpha", "2.5", "--quiet", "--out", str(out)]) == 0
    pk = read_packing(out)
    assert pk.alpha == 2.5 and sorted(set(pk.diameters.tolist())) == [1.0, 1.4]
    with h5py.File(out, "r") as h5:
        assert bool(h5.attrs["isostatic"]) and h5.attrs["param_sizes"] == "bidisperse"


def test_prepare_failure_writes_flagged_file(tmp_path, capsys) -> None:
    out = tmp_path / "below.h5"
    assert (
        run(["prepare", "--n", "128", "--dim", "2", "--phi", "0.3", "--out", str(out), "--quiet"])
        == 1
    )
    with h5py.File(out, "r") as h5:
        assert not bool(h5.attrs["ok"]) and "below jamming" in h5.attrs["reason"]
    assert "failed its stopping rule" in capsys.readouterr().err


def test_prepare_at_a_pressure(tmp_path, capsys) -> None:
    out = tmp_path / "p.h5"
    args = ["prepare", "--n", "64", "--seed", "3", "--pressure", "1e-3", "--out", str(out)]
    assert run([*args, "--quiet"]) == 0
    packing = read_packing(out)
    with h5py.File(out, "r") as h5:
        a = dict(h5.attrs)
    assert bool(a["ok"]) and a["protocol"] == "jamming+enthalpy"
    assert a["param_pressure"] == 1e-3 and a["param_p_target"] == 1e-7
    # the pressure of the written configuration, recomputed by brute force: the target to 1e-6
    # (all pairs, minimum image: L > 2 σ, unsheared box; V = (1 - r)^2, p = Σ 2(1-r) r / (3 L^3))
    assert packing.strain == 0.0 and packing.box.length > 2.0
    x, length = packing.positions, packing.box.length
    dr = x[:, None, :] - x[None, :, :]
    dr -= length * np.round(dr / length)
    r = np.sqrt((dr**2).sum(-1))
    i, j = np.triu_indices(64, 1)
    r = r[i, j]
    overlap = r < 1.0
    p = np.sum(2.0 * (1.0 - r[overlap]) * r[overlap]) / (3 * length**3)
    assert p == pytest.approx(1e-3, rel=1.01e-6)
    capsys.readouterr()
    for bad, needle in (
        (["--pressure", "-1"], "--pressure"),
        (["--pressure", "inf"], "--pressure"),
        (["--pressure", "1e-3", "--ptol", "0"], "--ptol"),
        (["--pressure", "1e-3", "--phi", "0.8"], "--phi jamming"),
    ):
        assert run(["prepare", "--n", "64", *bad, "--out", str(tmp_path / "x.h5")]) == 2
        err = capsys.readouterr().err.strip()
        assert needle in err and len(err.splitlines()) == 1
        assert not (tmp_path / "x.h5").exists()
