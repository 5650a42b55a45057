"""``jamlab inspect`` / ``minimize`` / ``random-packing`` / ``import-xyz``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import jamlab.spheres as sp
from cli_helpers import jamlab, one_line_error
from jamlab.spheres.io import read_packing, write_packing
from reference_data import REFERENCE

KEYS = {"energy", "shear_stress", "pressure", "z", "z_nr", "n_rattlers", "n_contacts_nr"}
KEYS |= {"max_force", "n", "dim", "phi", "strain"}


def test_inspect_json_keys_and_values(tmp_path):
    p = sp.random_packing(120, 3, 0.75, seed=5)
    p = sp.Packing(p.positions, p.box.with_strain(0.3), seed=5)
    path = write_packing(tmp_path / "c.h5", p)
    r = jamlab("inspect", str(path), "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert set(info) == KEYS
    assert info["n"] == 120 and info["dim"] == 3 and info["strain"] == 0.3
    assert info["energy"] == pytest.approx(sp.energy(p), rel=1e-13)
    assert info["shear_stress"] == pytest.approx(sp.shear_stress(p), rel=1e-12)
    rat = sp.remove_rattlers(p)
    assert info["z_nr"] == rat.z_nr and info["n_rattlers"] == rat.n_rattlers
    r = jamlab("inspect", str(path))
    assert r.returncode == 0 and "shear_stress" in r.stdout and "N=120" in r.stdout


def test_random_then_minimize(tmp_path):
    start = tmp_path / "start.h5"
    r = jamlab(
        "random-packing",
        "--out",
        str(start),
        "--n",
        "200",
        "--phi",
        "0.8",
        "--dim",
        "2",
        "--seed",
        "9",
    )
    assert r.returncode == 0, r.stderr
    out = tmp_path / "min.h5"
    r = jamlab("minimize", str(start), "--out", str(out), "--ftol", "1e-11")
    assert r.returncode == 0, r.stderr
    assert "converged" in r.stdout and "iterations" in r.stdout
    p = read_packing(out)
    assert p.seed == 9 and p.dim == 2
    assert sp.max_force(p) < 1e-11


def test_import_reference_positions(tmp_path):
    src = REFERENCE / "lammps-aqs-n500-phi0.80-1000steps" / "positions.txt"
    out = tmp_path / "ref.h5"
    r = jamlab("import-xyz", str(src), "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert read_packing(out).n == 500


@pytest.mark.parametrize(
    "make_args",
    [
        lambda d: ["inspect", str(d / "garbage.h5")],
        lambda d: ["inspect", str(d / "missing.h5")],
        lambda d: ["inspect", str(d / "empty.h5")],
        lambda d: ["minimize", str(d / "garbage.h5"), "--out", str(d / "o.h5")],
        lambda d: ["random-packing", "--out", str(d / "x.h5"), "--n", "1", "--phi", "0.5"],
        lambda d: ["random-packing", "--out", str(d / "x.h5"), "--n", "10", "--phi", "-0.5"],
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, make_args):
    (tmp_path / "garbage.h5").write_text("not hdf5\n")
    import h5py

    with h5py.File(tmp_path / "empty.h5", "w") as h5:
        h5["x"] = np.zeros(3)
    one_line_error(jamlab(*make_args(tmp_path)))


def test_coincident_particles_are_one_line(tmp_path):
    """Two particles at the same point (ZeroDivisionError tracebacks before): every reader and
    command refuses them with one line naming the two particles."""
    import h5py

    (tmp_path / "dup.txt").write_text("0 0 0\n0 0 0\n1.5 1.5 1.5\n")
    for command in ("import-xyz", "import"):
        line = one_line_error(
            jamlab(command, tmp_path / "dup.txt", "--out", tmp_path / "d.h5", "--box-length", 3)
        )
        assert "particles 0 and 1 coincide" in line
        assert not (tmp_path / "d.h5").exists()
    good = tmp_path / "r.h5"
    write_packing(good, sp.random_packing(8, 3, 0.3, seed=0))
    with h5py.File(good, "r+") as h5:
        pos = h5["positions"][()]
        pos[5] = pos[2]
        h5["positions"][...] = pos
    for args in (
        ["inspect", good],
        ["minimize", good, "--out", tmp_path / "m.h5"],
        ["shear", good, "--out", tmp_path / "s", "--gamma-max", 0.01, "--dgamma", 0.001],
    ):
        assert "particles 2 and 5 coincide" in one_line_error(jamlab(*args))


def test_inspect_order_against_bond_order_and_a_crystal(tmp_path):
    from jamlab.analysis.order import bond_order

    p = sp.random_packing(120, 3, 0.75, seed=5)
    path = write_packing(tmp_path / "c.h5", p)
    r = jamlab("inspect", str(path), "--json", "--order")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert set(info) == KEYS | {"q6", "crystalline_fraction"}
    o = bond_order(p.positions, p.box.length, 0.0, cutoff=1.3)
    assert info["q6"] == o.global_q and info["crystalline_fraction"] == o.crystalline_fraction
    # an fcc crystal, nearest neighbours at 0.98: every particle crystalline, Q_6 = 0.57452
    cell = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    grid = np.array([[i, j, k] for i in range(4) for j in range(4) for k in range(4)], float)
    a = 0.98 * np.sqrt(2)
    fcc = sp.Packing(((grid[:, None] + cell[None]).reshape(-1, 3)) * a, sp.Box(4 * a, 3))
    r = jamlab("inspect", str(write_packing(tmp_path / "fcc.h5", fcc)), "--order")
    assert r.returncode == 0, r.stderr
    assert "crystalline_fraction  1.0" in r.stdout and "q6" in r.stdout
    line = next(x for x in r.stdout.splitlines() if x.strip().startswith("q6"))
    assert float(line.split()[1]) == pytest.approx(0.57452, abs=1e-5)


def test_inspect_order_refuses_2d(tmp_path):
    p = sp.random_packing(64, 2, 0.8, seed=1)
    r = jamlab("inspect", str(write_packing(tmp_path / "d2.h5", p)), "--order")
    assert r.returncode == 2 and one_line_error(r)
