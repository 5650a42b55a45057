"""GSD / extended XYZ / LAMMPS data exchange: exact round trips, and the files read by the
maintained libraries themselves (``gsd`` with HOOMD's box convention, ``ase.io.read`` with ASE's
own minimum-image distances) — the LAMMPS side is in ``test_exchange_lammps.py``."""

from __future__ import annotations

import dataclasses
import itertools

import ase.io
import gsd.hoomd
import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.spheres import exchange as ex
from jamlab.spheres.aqs import shear

FORMATS = {"gsd": ".gsd", "extxyz": ".extxyz", "lammps-data": ".data"}


def _packing(dim: int, strain: float, seed: int = 7) -> sp.Packing:
    # positions spread over several periodic images, so that nothing relies on wrapping
    p = sp.random_packing(40, dim, 0.85, seed=seed)
    shift = np.random.default_rng(seed).integers(-2, 3, size=p.positions.shape) * p.box.length
    p = p.with_positions(p.positions + shift)
    return dataclasses.replace(p, box=p.box.with_strain(strain))


def _assert_identical(q: sp.Packing, p: sp.Packing) -> None:
    assert q.box == p.box  # length, dim and strain, exactly
    assert q.positions.shape == p.positions.shape
    assert np.array_equal(q.positions, p.positions)  # bit for bit (stronger than 1e-15)
    assert np.array_equal(q.diameters, p.diameters)
    assert q.seed == p.seed


def _distances_jamlab(p: sp.Packing) -> np.ndarray:
    i, j = np.triu_indices(p.n, 1)
    return np.linalg.norm(p.box.minimum_image(p.positions[i] - p.positions[j]), axis=1)


def _distances_brute(x: np.ndarray, lattice: np.ndarray) -> np.ndarray:
    """Minimum over the 27 (3-d) or 9 (2-d) nearest images ``x_i − x_j + n·lattice`` (rows of
    ``lattice`` are the periodic vectors); valid when the lattice is not too skewed."""
    i, j = np.triu_indices(x.shape[0], 1)
    dr = x[i] - x[j]
    best = np.full(dr.shape[0], np.inf)
    for n in itertools.product((-2, -1, 0, 1, 2), repeat=lattice.shape[0]):
        best = np.minimum(best, np.linalg.norm(dr + np.asarray(n) @ lattice, axis=1))
    return best


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strain", [0.0, 0.3, -0.49, 1.37, 7.1e-5])
def test_round_trip_is_exact(tmp_path, fmt, dim, strain):
    p = _packing(dim, strain)
    out = ex.export_frames([ex.Frame(p)], fmt, tmp_path / f"c{FORMATS[fmt]}")
    (q,) = ex.read_frames(out)
    _assert_identical(q, p)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("alpha", [2.0, 2.5])
def test_round_trip_keeps_diameters(tmp_path, fmt, alpha):
    p = _packing(3, 0.2)
    diam = np.linspace(0.8, 1.25, p.n)
    p = dataclasses.replace(p, diameters=diam, alpha=alpha)
    out = ex.export_frames([ex.Frame(p)], fmt, tmp_path / f"c{FORMATS[fmt]}")
    (q,) = ex.read_frames(out)
    _assert_identical(q, p)
    assert np.array_equal(q.diameters, diam)
    if fmt != "lammps-data":  # a LAMMPS data file has no place for the pair exponent
        assert q.alpha == alpha


SEEDS = [0, 2**63 - 1, 2**63, 2**64 - 1, None]


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("seed", SEEDS)
def test_every_valid_seed_round_trips(tmp_path, fmt, seed):
    """Seeds >= 2^63 overflowed GSD's int64 seed chunk (OverflowError)."""
    p = dataclasses.replace(_packing(3, 0.1), seed=seed)
    out = ex.export_frames([ex.Frame(p)], fmt, tmp_path / f"c{FORMATS[fmt]}")
    (q,) = ex.read_frames(out)
    assert q.seed == seed and (seed is None or type(q.seed) is int)
    _assert_identical(q, p)


def test_gsd_seeds_of_a_movie_and_of_older_files(tmp_path):
    """One file whose frames carry different seeds, an unknown one after known ones (GSD takes a
    chunk missing from a frame from frame 0); and the int64 chunk of files written before."""
    base = _packing(3, 0.1)
    seeds = [2**64 - 1, None, 2**63, 0, None]
    frames = [ex.Frame(dataclasses.replace(base, seed=s)) for s in seeds]
    out = ex.export_frames(frames, "gsd", tmp_path / "movie.gsd")
    assert [q.seed for q in ex.read_frames(out)] == seeds
    with gsd.hoomd.open(str(out), "r") as traj:
        assert traj[0].log["jamlab/seed"].dtype == np.uint64
        assert traj[1].log["jamlab/seed"].dtype == np.int64
    for old, expected in (([-1], None), ([7], 7), ([2**63 - 1], 2**63 - 1)):
        with gsd.hoomd.open(str(out), "r") as traj:
            frame = traj[0]
        frame.log["jamlab/seed"] = np.array(old, np.int64)  # what jamlab wrote before
        with gsd.hoomd.open(str(tmp_path / "old.gsd"), "w") as traj:
            traj.append(frame)
        (q,) = ex.read_frames(tmp_path / "old.gsd")
        assert q.seed == expected
    for bad in (np.array([-2], np.int64), np.array([1.5]), np.array([1, 2], np.uint64)):
        frame.log["jamlab/seed"] = bad
        with gsd.hoomd.open(str(tmp_path / "bad.gsd"), "w") as traj:
            traj.append(frame)
        with pytest.raises(ValueError, match="seed"):
            ex.read_frames(tmp_path / "bad.gsd")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strain", [0.0, 0.3, 1.37])
def test_gsd_read_by_gsd_with_hoomd_box_convention(tmp_path, dim, strain):
    p = _packing(dim, strain)
    ex.write_gsd(tmp_path / "c.gsd", [ex.Frame(p)])
    with gsd.hoomd.open(str(tmp_path / "c.gsd"), "r") as traj:
        assert len(traj) == 1
        f = traj[0]
    L = p.box.length
    assert f.configuration.dimensions == dim
    assert np.array_equal(
        f.configuration.box, np.float32([L, L, L if dim == 3 else 0, strain, 0, 0])
    )
    assert f.particles.N == p.n and np.array_equal(f.particles.diameter, np.ones(p.n, np.float32))
    # HOOMD: lattice vectors a1 = (Lx, 0, 0), a2 = (xy Ly, Ly, 0), a3 = (xz Lz, yz Lz, Lz); the
    # box is centred on the origin: every fractional coordinate of a position in [-1/2, 1/2)
    Lx, Ly, Lz, xy, xz, yz = (float(v) for v in f.configuration.box)
    lattice = np.array([[Lx, 0, 0], [xy * Ly, Ly, 0], [xz * Lz, yz * Lz, Lz]])[:dim, :dim]
    x = np.asarray(f.particles.position, dtype=np.float64)[:, :dim]
    frac = np.linalg.solve(lattice.T, x.T).T
    assert np.all(frac >= -0.5 - 1e-6) and np.all(frac < 0.5 + 1e-6)
    if dim == 2:
        assert np.all(f.particles.position[:, 2] == 0)
    # the same pair distances as jamlab's Lees–Edwards box (single precision)
    d_gsd = _distances_brute(x, lattice)
    d_jam = _distances_jamlab(p)
    close = d_jam < 1.5
    assert np.allclose(d_gsd[close], d_jam[close], rtol=0, atol=2e-5 * L)
    # unwrapped positions (position + image · lattice) are jamlab's minus the box centre
    unwrapped = x + f.particles.image[:, :dim] @ lattice
    assert np.allclose(unwrapped + 0.5 * lattice.sum(axis=0), p.positions, atol=2e-5 * L * 5)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strain", [0.0, 0.3, 1.37])
def test_extxyz_read_by_ase(tmp_path, dim, strain):
    p = _packing(dim, strain)
    ex.write_extxyz(tmp_path / "c.extxyz", [ex.Frame(p)])
    atoms = ase.io.read(tmp_path / "c.extxyz")
    L = p.box.length
    assert len(atoms) == p.n and list(atoms.pbc) == [True, True, dim == 3]
    assert np.array_equal(atoms.cell[0], [L, 0, 0])
    assert np.array_equal(atoms.cell[1], [strain * L, L, 0])
    assert np.array_equal(atoms.positions[:, :dim], p.positions)
    assert np.array_equal(atoms.arrays["radius"], np.full(p.n, 0.5))
    assert atoms.info["strain"] == strain and atoms.info["box_length"] == L
    # ASE's own minimum-image distances equal jamlab's Lees–Edwards ones (pairs in contact range)
    d_ase = atoms.get_all_distances(mic=True)[np.triu_indices(p.n, 1)]
    d_jam = _distances_jamlab(p)
    close = d_jam < 1.5
    assert np.allclose(d_ase[close], d_jam[close], rtol=1e-12, atol=0)


def test_gsd_from_another_program_is_read_from_the_hoomd_chunks(tmp_path):
    """A HOOMD-style file without jamlab's log chunks: box, diameters and the centred positions
    in single precision."""
    p = _packing(3, 0.25)
    L = p.box.length
    lattice = np.array([[L, 0, 0], [0.25 * L, L, 0], [0, 0, L]])
    frac = np.linalg.solve(lattice.T, p.positions.T).T
    frac -= np.floor(frac)
    f = gsd.hoomd.Frame()
    f.configuration.box = [L, L, L, 0.25, 0, 0]
    f.particles.N = p.n
    f.particles.types = ["A"]
    f.particles.position = ((frac - 0.5) @ lattice).astype(np.float32)
    f.particles.diameter = np.ones(p.n, np.float32)
    with gsd.hoomd.open(str(tmp_path / "h.gsd"), "w") as traj:
        traj.append(f)
    (q,) = ex.read_frames(tmp_path / "h.gsd")
    assert q.box.length == np.float32(L) and q.box.strain == np.float32(0.25)
    assert np.allclose(_distances_jamlab(q), _distances_jamlab(p), rtol=0, atol=1e-5 * L)


def test_trace_exports_the_saved_frames_as_a_movie(tmp_path):
    p = sp.minimize(sp.random_packing(32, 3, 0.9, seed=3)).packing
    result = shear(p, 1e-3, n_steps=4, save_every=2, out=tmp_path / "t.h5")
    trace = result.trace
    frames = ex.frames_of(tmp_path / "t.h5")
    assert [f.step for f in frames] == [2, 4]  # the configurations the run saved
    for fr in frames:
        assert fr.packing.box.strain == trace.gamma[fr.step]
        assert fr.row["energy"] == trace.energy[fr.step]
        assert fr.row["shear_stress"] == trace.shear_stress[fr.step]
        assert sp.energy(fr.packing) == pytest.approx(trace.energy[fr.step], rel=1e-12)
    ex.write_gsd(tmp_path / "t.gsd", frames)
    ex.write_extxyz(tmp_path / "t.extxyz", frames)
    with gsd.hoomd.open(str(tmp_path / "t.gsd"), "r") as traj:
        assert [int(f.configuration.step) for f in traj] == [2, 4]
        assert [float(f.configuration.box[3]) for f in traj] == [
            np.float32(trace.gamma[2]),
            np.float32(trace.gamma[4]),
        ]
        assert float(traj[1].log["jamlab/energy"][0]) == trace.energy[4]
    images = ase.io.read(tmp_path / "t.extxyz", index=":")
    assert [a.info["aqs_step"] for a in images] == [2, 4]
    assert [a.info["aqs_shear_stress"] for a in images] == list(trace.shear_stress[[2, 4]])
    for fmt in ("t.gsd", "t.extxyz"):
        back = ex.read_frames(tmp_path / fmt)
        for q, fr in zip(back, frames, strict=True):
            _assert_identical(q, fr.packing)
    with pytest.raises(ValueError, match="one configuration"):
        ex.export_frames(frames, "lammps-data", tmp_path / "t.data")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("LAMMPS\n\n1 atoms\n0 3 xlo xhi\n0 4 ylo yhi\n0 3 zlo zhi\n\nAtoms # atomic\n\n"
         "1 1 0.5 0.5 0.5\n", "not a Lees"),
        ("LAMMPS\n\n2 atoms\n0 3 xlo xhi\n0 3 ylo yhi\n0 3 zlo zhi\n\nAtoms # charge\n\n"
         "1 1 0 0.5 0.5 0.5\n2 1 0 1.5 1.5 1.5\n", "style charge"),
        ("LAMMPS\n\n3 atoms\n0 3 xlo xhi\n0 3 ylo yhi\n0 3 zlo zhi\n\nAtoms # atomic\n\n"
         "1 1 0.5 0.5 0.5\n", "1 atom lines for 3"),
        ("not a data file\n", "not a LAMMPS data file"),
    ],
)  # fmt: skip
def test_bad_lammps_data_is_a_value_error(tmp_path, text, match):
    (tmp_path / "bad.data").write_text(text)
    with pytest.raises(ValueError, match=match):
        ex.read_frames(tmp_path / "bad.data")


def test_lammps_atomic_style_and_origin_shift(tmp_path):
    text = (
        "made elsewhere\n\n2 atoms\n1 atom types\n\n-1.5 1.5 xlo xhi\n-1.5 1.5 ylo yhi\n"
        "-1.5 1.5 zlo zhi\n0.75 0 0 xy xz yz\n\nMasses\n\n1 1.0\n\nAtoms # atomic\n\n"
        "2 1 0.5 0.25 -1.0 0 0 0\n1 1 -1.0 -1.5 0.0 0 0 0\n"
    )
    (tmp_path / "x.data").write_text(text)
    (q,) = ex.read_frames(tmp_path / "x.data")
    assert q.box == sp.Box(3.0, 3, 0.25)
    # sorted by atom id, shifted by (xlo, ylo, zlo)
    assert np.array_equal(q.positions, [[0.5, 0.0, 1.5], [2.0, 1.75, 0.5]])
    assert np.array_equal(q.diameters, [1.0, 1.0])


def test_format_from_suffix():
    assert ex.format_from_suffix("a.GSD") == "gsd"
    assert ex.format_from_suffix("a.xyz") == "extxyz"
    assert ex.format_from_suffix("a.lmp") == "lammps-data"
    with pytest.raises(ValueError, match="--format"):
        ex.format_from_suffix("a.h5")


@pytest.mark.parametrize("text", ["1.5", "1.8446744073709552e+19", "18446744073709551616", "-2"])
def test_extxyz_seed_that_is_no_valid_seed_is_refused(tmp_path, text):
    """ASE reads a decimal above 2^63 - 1 as a float: the exact one comes from the comment line,
    and what is not an integer seed in [0, 2^64 - 1] is refused, not rounded."""
    out = ex.export_frames([ex.Frame(dataclasses.replace(_packing(3, 0.1), seed=5))], "extxyz",
                           tmp_path / "c.extxyz")
    out.write_text(out.read_text().replace(" seed=5 ", f" seed={text} "))
    with pytest.raises(ValueError, match="seed"):
        ex.read_frames(out)


def test_lammps_data_seed_is_checked(tmp_path):
    # the seed in the title line is a user-editable string: checked as every other seed
    import jamlab.spheres as sp
    from jamlab.spheres import exchange as ex

    ex.write_lammps_data(tmp_path / "x.data", sp.random_packing(8, 3, 0.3, seed=5))
    assert ex.read_lammps_data(tmp_path / "x.data").seed == 5
    for bad in ("abc", "-7", "18446744073709551616"):
        text = (tmp_path / "x.data").read_text().replace("jamlab_seed=5", f"jamlab_seed={bad}")
        (tmp_path / "y.data").write_text(text)
        with pytest.raises(ValueError, match="jamlab_seed must be an integer"):
            ex.read_lammps_data(tmp_path / "y.data")
