"""Lees–Edwards box: minimum image, wrapping, packing fraction, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from spheres_brute import image_shifts

import jamlab.spheres as sp
from jamlab.spheres.box import box_length_for, packing_fraction, sphere_volume


@pytest.mark.parametrize("dim", [2, 3, 4])
@pytest.mark.parametrize("strain", [0.0, 0.3, 0.5, 0.7, 1.3, -2.6, 41.7])
def test_minimum_image_is_the_shortest_image(dim, strain):
    L = 5.0
    box = sp.Box(L, dim, strain)
    rng = np.random.default_rng(dim)
    a = rng.uniform(0, L, size=(200, dim))
    b = rng.uniform(0, L, size=(200, dim))
    mi = box.minimum_image(a - b)
    g = box.reduced_strain
    for k in range(len(a)):
        cands = a[k] - (b[k] + image_shifts(L, dim, g))
        r = np.sqrt((cands**2).sum(axis=1))
        if r.min() < L / 2:  # then the shortest image is unique and must be found
            assert np.linalg.norm(mi[k]) == pytest.approx(r.min(), rel=1e-12)
        # it is always some lattice image: the difference is a lattice vector
        diff = mi[k] - (a[k] - b[k])
        ny = round(diff[1] / L)
        diff[0] -= ny * strain * L
        assert np.allclose(diff / L, np.round(diff / L), atol=1e-9)


@pytest.mark.parametrize("strain", [0.0, 0.45, 1.3, -3.2])
def test_wrap_keeps_lattice_images_and_lands_in_box(strain):
    dim, L = 3, 4.0
    box = sp.Box(L, dim, strain)
    rng = np.random.default_rng(0)
    pos = rng.uniform(-30, 30, size=(500, dim))
    w = box.wrap(pos)
    assert np.all((w >= 0) & (w < L))
    diff = w - pos
    ny = np.round(diff[:, 1] / L)
    diff[:, 0] -= ny * strain * L
    assert np.allclose(diff / L, np.round(diff / L), atol=1e-9)


def test_packing_fraction_helpers():
    assert sphere_volume(2) == pytest.approx(math.pi / 4)
    assert sphere_volume(3) == pytest.approx(math.pi / 6)
    assert sphere_volume(4) == pytest.approx(math.pi**2 / 32)
    for dim in (2, 3, 4, 5):
        L = box_length_for(1000, dim, 0.8)
        assert packing_fraction(1000, dim, L) == pytest.approx(0.8, rel=1e-14)
    meta_L = 8.682328464463406  # reference/lammps-aqs-n1000-phi0.80/meta.json
    assert box_length_for(1000, 3, 0.8) == pytest.approx(meta_L, rel=1e-14)


def test_sphere_volume_of_radii_array():
    r = np.array([0.0, 0.5, 0.7])
    np.testing.assert_allclose(sphere_volume(3, r), 4 * math.pi / 3 * r**3, rtol=1e-15)


def test_volume_helpers_compute_a_float32_argument_in_float64():
    # the value of np.float32(0.3), widened exactly, against the same value as a Python float
    r32 = np.float32(0.3)
    assert sphere_volume(3, r32) == sphere_volume(3, float(r32))
    assert type(sphere_volume(3, r32)) is float
    v = sphere_volume(3, np.array([r32, r32]))
    assert v.dtype == np.float64 and v[0] == sphere_volume(3, float(r32))
    assert packing_fraction(10, 3, np.float32(5.5)) == packing_fraction(10, 3, 5.5)


@pytest.mark.parametrize(
    ("call", "word"),
    [
        (lambda: sphere_volume(3, -1.0), "radius"),  # was a negative volume
        (lambda: sphere_volume(3, np.array([0.5, -0.5])), "radius"),
        (lambda: sphere_volume(3, float("nan")), "radius"),
        (lambda: sphere_volume(1), "dimension"),
        (lambda: packing_fraction(100, 3, -5.0), "box side"),  # was a negative φ
        (lambda: packing_fraction(100, 3, float("inf")), "box side"),  # was φ = 0
        (lambda: packing_fraction(0, 3, 5.0), "particles"),
        (lambda: packing_fraction(True, 3, 5.0), "particles"),
        (lambda: packing_fraction(100, 3, True), "box side"),  # was read as L = 1
        (lambda: box_length_for(True, 3, 0.5), "particles"),
        (lambda: box_length_for(100, 3, True), "packing fraction"),  # was read as φ = 1
        (lambda: box_length_for(100, 3, "0.5"), "packing fraction"),  # was a TypeError
    ],
)
def test_volume_helpers_refuse_bad_input(call, word):
    with pytest.raises(ValueError, match=word):
        call()


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"length": -1.0, "dim": 3}, "length"),
        ({"length": float("nan"), "dim": 3}, "length"),
        ({"length": 5.0, "dim": 1}, "dim"),
        ({"length": 5.0, "dim": 3, "strain": float("inf")}, "strain"),
    ],
)
def test_bad_box(kwargs, word):
    with pytest.raises(ValueError, match=word):
        sp.Box(**kwargs)


def test_bad_packings():
    box = sp.Box(5.0, 3)
    with pytest.raises(ValueError, match="N=1"):
        sp.Packing(np.zeros((1, 3)), box)
    with pytest.raises(ValueError, match="shape"):
        sp.Packing(np.zeros((10, 2)), box)
    with pytest.raises(ValueError, match="shape"):
        sp.Packing(np.zeros(30), box)
    bad = np.zeros((10, 3))
    bad[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"positions\[4, 1\]=nan"):
        sp.Packing(bad, box)
    with pytest.raises(ValueError, match="exceed 2"):
        sp.Packing(np.zeros((10, 3)), sp.Box(1.9, 3))
    with pytest.raises(ValueError, match="phi"):
        sp.random_packing(100, 3, 0.0, seed=1)
    with pytest.raises(ValueError, match="phi"):
        sp.random_packing(100, 3, -0.5, seed=1)
    with pytest.raises(ValueError, match="n="):
        sp.random_packing(1, 3, 0.5, seed=1)
    with pytest.raises(ValueError, match="dim"):
        sp.random_packing(100, 1, 0.5, seed=1)


def test_packing_is_immutable_copy():
    pos = np.random.default_rng(0).uniform(0, 5, size=(20, 3))
    p = sp.Packing(pos, sp.Box(5.0, 3))
    pos[0, 0] = 99.0
    assert p.positions[0, 0] != 99.0
    with pytest.raises(ValueError):
        p.positions[0, 0] = 1.0


def _brute_closest(pos: np.ndarray, L: float, gamma: float) -> float:
    """Smallest distance over all pairs and all 3^d lattice images (independent of Box)."""
    shifts = image_shifts(L, pos.shape[1], gamma - math.floor(gamma + 0.5))
    best = math.inf
    for i in range(len(pos)):
        for j in range(i + 1, len(pos)):
            d = pos[i] - (pos[j] + shifts)
            best = min(best, float(np.sqrt((d**2).sum(axis=1)).min()))
    return best


@pytest.mark.parametrize(
    ("strain", "at_origin", "offset"),
    [
        (0.0, False, (0.0, 0.0, 0.0)),  # the same point
        (0.0, False, (1.0, 0.0, 0.0)),  # one box side along x: a periodic image
        (0.3, False, (0.3, 1.0, 0.0)),  # across y under strain 0.3: x shifted by γL
        (1.3, False, (-1.3, -1.0, 1.0)),  # across -y and z at γ = 1.3 (γ' = 0.3)
        (0.0, True, (1e-201, 0.0, 0.0)),  # r ≈ 6e-201: r² underflows to 0 in the kernels
        (0.0, False, (0.0, 1e-13, 0.0)),  # r = 6e-13 < 2^-40 L
    ],
)
def test_coincident_particles_are_refused(strain, at_origin, offset):
    L = 6.0
    box = sp.Box(L, 3, strain)
    pos = np.random.default_rng(3).uniform(0, L, size=(20, 3))
    if at_origin:
        pos[7] = 0.0
    pos[13] = pos[7] + np.array(offset) * L
    assert _brute_closest(pos, L, strain) < sp.state.COINCIDENCE * L  # the planted pair
    with pytest.raises(ValueError, match=r"particles 7 and 13 coincide"):
        sp.Packing(pos, box)


def test_near_but_distinct_particles_are_kept():
    # 1e-9 L apart (above the 2^-40 L tolerance): a valid, if absurd, configuration
    L = 6.0
    pos = np.random.default_rng(4).uniform(0, L, size=(20, 3))
    pos[5] = pos[2] + [0.0, 1e-9 * L, 0.0]
    p = sp.Packing(pos, sp.Box(L, 3, 0.2))
    assert np.array_equal(p.positions, pos)


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_coincidence_on_a_lattice_and_at_cell_boundaries(dim):
    """A square lattice (equal coordinates everywhere: the quick pass cannot decide) with pairs
    planted astride the cell boundaries of the first grid, against brute force."""
    from jamlab.spheres.state import coincident_pair

    k = 3 if dim == 4 else 5
    L = 6.0
    axes = [np.arange(k) * (L / k)] * dim
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    box = sp.Box(L, dim, 0.0)
    assert coincident_pair(lattice, box) is None
    assert _brute_closest(lattice, L, 0.0) == pytest.approx(L / k)
    m = 1 << min(20, 62 // dim)
    tiny = 1e-14 * L
    for axis in range(dim):
        pos = lattice.copy()
        i, j = 3, len(pos) - 2
        # particle j sits just across a cell boundary of grid 0 from particle i, along `axis`
        pos[i] = L * (np.arange(dim) * 0.1 + 0.2)
        pos[i, axis] = L * (round(0.5 * m) / m) - 0.5 * tiny
        pos[j] = pos[i]
        pos[j, axis] += tiny
        found = coincident_pair(pos, box)
        assert found is not None and found[:2] == (i, j)
        assert found[2] == pytest.approx(tiny, rel=1e-2)
        assert _brute_closest(pos, L, 0.0) == pytest.approx(found[2], rel=1e-2)


def test_packing_seed_is_a_valid_seed():
    # every seed jamlab writes and reads is in [0, 2^64 - 1]: a negative one was kept and only
    # failed later (GSD export)
    pos = np.random.default_rng(0).random((8, 3)) * 3.0
    assert sp.Packing(pos, sp.Box(3.0, 3, 0.0), seed=2**64 - 1).seed == 2**64 - 1
    assert sp.Packing(pos, sp.Box(3.0, 3, 0.0), seed=np.uint64(7)).seed == 7
    for bad in (-5, 2**64):
        with pytest.raises(ValueError, match=r"seed must be an integer in \[0, "):
            sp.Packing(pos, sp.Box(3.0, 3, 0.0), seed=bad)
