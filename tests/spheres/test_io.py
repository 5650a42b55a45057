"""HDF5 configuration files and text import."""

from __future__ import annotations

import os
import stat

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


def test_a_file_of_another_kind_is_named(tmp_path):
    """A trace given where a configuration is read (and the reverse) says what it is, not that
    its format_version is unknown; a directory says it is one (a third audit)."""
    from jamlab.spheres.trace import read_trace

    config = write_packing(tmp_path / "c.h5", sp.random_packing(8, 3, 0.3, seed=1))
    with pytest.raises(ValueError, match=r"c\.h5 is a jamlab-configuration file, not a trace "):
        read_trace(config)
    with h5py.File(tmp_path / "t.h5", "w") as h5:  # the root attributes a trace carries
        h5.attrs["format"] = "jamlab-aqs-trace"
        h5.attrs["format_version"] = 2
    with pytest.raises(ValueError, match=r"t\.h5 is a jamlab-aqs-trace file, not a configuration"):
        read_packing(tmp_path / "t.h5")
    with pytest.raises(ValueError, match="is a directory, not a configuration file"):
        read_packing(tmp_path)


def test_text_positions(tmp_path):
    pos = np.random.default_rng(1).uniform(0, 4, (20, 3))
    np.savetxt(tmp_path / "p.txt", pos, header="x y z")
    p = read_lammps_positions(tmp_path / "p.txt", box_length=4.0, strain=0.1)
    assert np.array_equal(p.positions, pos) and p.strain == 0.1
    with pytest.raises(ValueError, match="meta.json"):
        read_lammps_positions(tmp_path / "p.txt")


def _good_file(tmp_path):
    p = sp.Packing(np.random.default_rng(0).uniform(0, 3, (10, 3)), sp.Box(3.0, 3), seed=4)
    return write_packing(tmp_path / "c.h5", p)


@pytest.mark.parametrize(
    "damage, needle",
    [
        (lambda h5: (h5.__delitem__("positions"), h5.create_group("positions")), "positions"),
        (lambda h5: (h5.__delitem__("positions"), h5.create_dataset("positions", data=[1.0, 2])),
         "positions"),
        (lambda h5: (h5.__delitem__("positions"), h5.create_dataset("positions", data=["a"] * 3)),
         "positions"),
        (lambda h5: h5["positions"].__setitem__((0, 0), np.nan), "finite"),
        (lambda h5: h5.attrs.__setitem__("strain", 1e17), "strain"),
        (lambda h5: h5.attrs.__setitem__("dim", 2), "dim"),
        (lambda h5: h5.attrs.__setitem__("seed", 2.5), "seed"),
        (lambda h5: h5.attrs.__setitem__("box_length", -3.0), "box length"),
    ],
)
def test_damaged_configuration_is_a_value_error(tmp_path, damage, needle):
    """Every damage is a one-line ``ValueError`` (on 09aa8ce: TypeError, AttributeError or a
    configuration silently accepted)."""
    path = _good_file(tmp_path)
    with h5py.File(path, "a") as h5:
        damage(h5)
    with pytest.raises(ValueError, match=needle):
        read_packing(path)


def test_malformed_meta_json_is_a_value_error(tmp_path):
    np.savetxt(tmp_path / "p.txt", np.random.default_rng(1).uniform(0, 4, (20, 3)))
    for text in ("{", '{"box_length": null}', '{"box_length": 4, "seed_of_random_start": "x"}'):
        (tmp_path / "meta.json").write_text(text)
        with pytest.raises(ValueError, match="meta.json"):
            read_lammps_positions(tmp_path / "p.txt")


def test_files_are_created_with_the_umask_mode(tmp_path):
    old = os.umask(0o027)
    try:
        path = _good_file(tmp_path)
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
