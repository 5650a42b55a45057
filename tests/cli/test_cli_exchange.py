"""``jamlab export`` / ``jamlab import``: round trips through the command line, and its errors."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

import jamlab.spheres as sp
from cli_helpers import jamlab, one_line_error
from jamlab.spheres.io import read_packing, write_packing
from reference_data import N500


def _config(tmp_path, strain=0.4):
    p = sp.random_packing(30, 3, 0.8, seed=21)
    p = dataclasses.replace(p, box=p.box.with_strain(strain))
    return write_packing(tmp_path / "c.h5", p), p


@pytest.mark.parametrize("suffix", [".gsd", ".extxyz", ".data"])
def test_export_import_round_trip(tmp_path, suffix):
    path, p = _config(tmp_path)
    r = jamlab("export", path, "--out", tmp_path / f"c{suffix}")
    assert r.returncode == 0, r.stderr
    assert "1 frame(s)" in r.stdout
    r = jamlab("import", tmp_path / f"c{suffix}", "--out", tmp_path / "back.h5")
    assert r.returncode == 0, r.stderr
    q = read_packing(tmp_path / "back.h5")
    assert q.box == p.box and np.array_equal(q.positions, p.positions) and q.seed == p.seed


def test_import_text_positions_like_import_xyz(tmp_path):
    r = jamlab("import", N500 / "positions.txt", "--out", tmp_path / "a.h5")
    assert r.returncode == 0, r.stderr
    r = jamlab("import-xyz", N500 / "positions.txt", "--out", tmp_path / "b.h5")
    assert r.returncode == 0, r.stderr
    a, b = read_packing(tmp_path / "a.h5"), read_packing(tmp_path / "b.h5")
    assert a.n == 500 and a.box == b.box and np.array_equal(a.positions, b.positions)


def test_never_overwrites_without_force_and_never_the_input(tmp_path):
    path, _ = _config(tmp_path)
    (tmp_path / "c.gsd").write_text("precious")
    msg = one_line_error(jamlab("export", path, "--out", tmp_path / "c.gsd"))
    assert "exists" in msg and "--force" in msg
    assert (tmp_path / "c.gsd").read_text() == "precious"
    assert jamlab("export", path, "--out", tmp_path / "c.gsd", "--force").returncode == 0
    before = path.read_bytes()
    msg = one_line_error(jamlab("export", path, "--out", path, "--format", "gsd", "--force"))
    assert "input" in msg and path.read_bytes() == before
    msg = one_line_error(jamlab("import", tmp_path / "c.gsd", "--out", tmp_path / "c.gsd"))
    assert "input" in msg or "exists" in msg


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["export", "{c}", "--out", "{d}/x.h5"], "--format"),
        # the formats listed are those export writes (positions is import's only)
        (["export", "{c}", "--out", "{d}/x.foo"], "give --format (gsd, extxyz, lammps-data)"),
        (["export", "{c}", "--out", "{d}/x.gsd", "--format", "pdb"], "cannot export"),
        # a suffix naming another format than --format's (a third audit: GSD in an .xyz file)
        (["export", "{c}", "--out", "{d}/x.gsd", "--format", "extxyz"],
         "--out {d}/x.gsd names gsd, and --format extxyz writes extxyz"),
        (["export", "{d}/missing.h5", "--out", "{d}/x.gsd"], "no such file"),
        (["export", "{c}", "--out", "{d}/x.gsd", "--frame", "3"], "out of range"),
        (["import", "{d}/missing.gsd", "--out", "{d}/x.h5"], "no such file"),
        (["import", "{c}", "--out", "{d}/x.h5", "--format", "gsd"], "GSD"),
        (["import", "{c}", "--out", "{d}/x.h5", "--format", "lammps-data"], "LAMMPS"),
        (["import", "{d}/garbage.extxyz", "--out", "{d}/x.h5"], "extended XYZ"),
        (["import", "{d}/garbage.extxyz", "--out", "{d}/x.h5", "--strain", "0.1"], "positions"),
    ],
)
def test_bad_input_is_one_line_error(tmp_path, args, match):
    path, _ = _config(tmp_path)
    (tmp_path / "garbage.extxyz").write_text("3\nnot extxyz\n1 2\n")
    r = jamlab(*[a.format(c=path, d=tmp_path) for a in args])
    assert match.format(d=tmp_path) in one_line_error(r)
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "x.gsd").exists()


def test_missing_extra_is_named(tmp_path):
    path, _ = _config(tmp_path)
    fake = tmp_path / "fake"
    for name in ("gsd", "ase"):
        (fake / name).mkdir(parents=True)
        (fake / name / "__init__.py").write_text(f"raise ImportError('no {name} here')\n")
    path_var = os.pathsep.join([str(fake), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path_var}
    msg = one_line_error(jamlab("export", path, "--out", tmp_path / "x.gsd", env=env))
    assert "gsd" in msg and "jamlab[formats]" in msg
    (tmp_path / "y.extxyz").write_text("")
    r = jamlab("import", tmp_path / "y.extxyz", "--out", tmp_path / "y.h5", env=env)
    msg = one_line_error(r)
    assert "ASE" in msg and "jamlab[formats]" in msg
    # extxyz and LAMMPS data are written without either package
    assert jamlab("export", path, "--out", tmp_path / "x.extxyz", env=env).returncode == 0
    assert jamlab("export", path, "--out", tmp_path / "x.data", env=env).returncode == 0
