"""HDF5 configuration files and text import."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import jamlab
import jamlab.spheres as sp
from jamlab.spheres.io import read_lammps_positions, read_packing, write_packing


def test_roundtrip_exact(tmp_path):
    p = sp.random_packing(50, 4, 0.6, seed=12)
    p = sp.Packing(p.positions, p.box.with_strain(1.25), seed=12)
    path = write_packing(tmp_path / "c.h5", p)
    q = read_packing(path)
    assert np.array_equal(q.positions, p.positions)
    assert q.box == p.box and q.seed == 12
    with h5py.File(path) as h5:
        assert h5["positions"].shape == (50, 4) and h5["positions"].dtype == np.float64
        for key in ("box_length", "strain", "dim", "phi", "seed", "jamlab_version"):
            assert key in h5.attrs
        assert h5.attrs["jamlab_version"] == jamlab.__version__
        assert h5.attrs["phi"] == pytest.approx(0.6, rel=1e-14)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["c.h5"]  # no temp file left


def test_unknown_seed_and_inconsistent_phi(tmp_path):
    p = sp.Packing(np.random.default_rng(0).uniform(0, 3, (10, 3)), sp.Box(3.0, 3))
    path = write_packing(tmp_path / "c.h5", p)
    assert read_packing(path).seed is None
    with h5py.File(path, "a") as h5:
        h5.attrs["phi"] = 0.5
    with pytest.raises(ValueError, match="phi"):
        read_packing(path)


def test_bad_files(tmp_path):
    (tmp_path / "t.h5").write_text("hello")
    with pytest.raises(ValueError, match="HDF5"):
        read_packing(tmp_path / "t.h5")
    with h5py.File(tmp_path / "e.h5", "w") as h5:
        h5["positions"] = np.zeros((3, 3))
    with pytest.raises(ValueError, match="box_length"):
        read_packing(tmp_path / "e.h5")
    with pytest.raises(FileNotFoundError):
        read_packing(tmp_path / "none.h5")


def test_text_positions(tmp_path):
    pos = np.random.default_rng(1).uniform(0, 4, (20, 3))
    np.savetxt(tmp_path / "p.txt", pos, header="x y z")
    p = read_lammps_positions(tmp_path / "p.txt", box_length=4.0, strain=0.1)
    assert np.array_equal(p.positions, pos) and p.strain == 0.1
    with pytest.raises(ValueError, match="meta.json"):
        read_lammps_positions(tmp_path / "p.txt")
