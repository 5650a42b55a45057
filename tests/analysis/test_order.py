"""``jamlab.analysis.order``: Steinhardt's ``Q_6`` of perfect lattices and coordination shells
against their published values, the Lees–Edwards bonds against an explicit sum over images,
invariances, ten Wolde's criterion, and the refusals."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from jamlab.analysis.contact_geometry import pairs_within
from jamlab.analysis.order import bond_order


def lattice(basis, cells: int, spacing: float):
    grid = np.array(list(itertools.product(range(cells), repeat=3)), dtype=float)
    pos = (grid[:, None, :] + np.asarray(basis, dtype=float)[None]).reshape(-1, 3) * spacing
    return pos, cells * spacing


FCC = [[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]
BCC = [[0, 0, 0], [0.5, 0.5, 0.5]]


@pytest.mark.parametrize(("basis", "spacing", "q6", "z"), [
    # Steinhardt, Nelson & Ronchetti, PRB 28, 784 (1983), Table I: fcc 0.57452, bcc (first
    # shell of 8) 0.62854, simple cubic 0.35355
    (FCC, math.sqrt(2.0), 0.57452, 12),
    (BCC, 2 / math.sqrt(3.0), 0.62854, 8),
    ([[0, 0, 0]], 1.0, 0.35355, 6),
])
def test_perfect_lattices(basis, spacing, q6, z):
    pos, length = lattice(basis, 4, spacing)  # nearest neighbours at distance 1
    o = bond_order(pos, length, cutoff=1.05)
    assert np.all(o.neighbours == z)
    assert o.global_q == pytest.approx(q6, abs=5e-6)
    np.testing.assert_allclose(o.local_q, q6, atol=5e-6)
    # ten Wolde: every bond ordered, so crystalline iff z >= 7
    assert o.crystalline_fraction == (1.0 if z >= 7 else 0.0)


def test_a_rotated_lattice_keeps_its_local_order():
    """A rotation changes ``Q_lm`` but not ``q_6(i)``: an fcc shell rotated at random."""
    pos, _ = lattice(FCC, 3, math.sqrt(2.0))
    centre = pos[np.argmin(np.linalg.norm(pos - pos.mean(axis=0), axis=1))]  # interior site
    shell = pos[np.abs(np.linalg.norm(pos - centre, axis=1) - 1.0) < 1e-9] - centre
    assert len(shell) == 12
    q, _ = np.linalg.qr(np.random.default_rng(3).standard_normal((3, 3)))
    cluster = np.vstack([[0, 0, 0], shell @ q.T]) + 10.0  # alone in a large box
    o = bond_order(cluster, 20.0, cutoff=1.05)
    assert o.local_q[0] == pytest.approx(0.57452, abs=5e-6)


def test_hcp_and_icosahedral_shells():
    """The centre of a 12-neighbour shell: hcp 0.48476, icosahedron 0.66332 (Steinhardt et al.,
    Table I)."""
    a = np.array([[math.cos(k * math.pi / 3), math.sin(k * math.pi / 3), 0] for k in range(6)])
    up = [[0.5, math.sqrt(3) / 6, math.sqrt(2 / 3)], [-0.5, math.sqrt(3) / 6, math.sqrt(2 / 3)],
          [0.0, -math.sqrt(3) / 3, math.sqrt(2 / 3)]]
    hcp = np.vstack([a, up, np.array(up) * [1, 1, -1]])  # B layer above and below: hcp
    g = (1 + math.sqrt(5)) / 2
    ico = np.array([p for s1 in (1, -1) for s2 in (1, -1)
                    for p in ([0, s1, s2 * g], [s1, s2 * g, 0], [s2 * g, 0, s1])], dtype=float)
    ico /= np.linalg.norm(ico[0])
    for shell, q6 in ((hcp, 0.48476), (ico, 0.66332)):
        assert np.allclose(np.linalg.norm(shell, axis=1), 1.0)
        o = bond_order(np.vstack([[0, 0, 0], shell]) + 10.0, 20.0, cutoff=1.01)
        assert o.neighbours[0] == 12
        assert o.local_q[0] == pytest.approx(q6, abs=5e-6)


def image(length, strain, n):
    """The lattice vector ``n_x L e_x + n_y (γL e_x + L e_y) + n_z L e_z``."""
    return np.array([n[0] * length + n[1] * strain * length, n[1] * length, n[2] * length])


def image_bonds(pos, length, strain, diameters, cutoff, reach=4):
    """Brute force: every pair against every image with ``|n_a| ≤ reach``; the pairs and their
    separations within the cut-off."""
    found = {}
    i, j = np.triu_indices(len(pos), 1)
    within = cutoff * 0.5 * (diameters[i] + diameters[j])
    for n in itertools.product(range(-reach, reach + 1), repeat=3):
        dr = pos[j] + image(length, strain, n) - pos[i]
        for k in np.nonzero(np.linalg.norm(dr, axis=1) < within)[0]:
            assert (i[k], j[k]) not in found  # one image only within the cut-off
            found[(i[k], j[k])] = dr[k]
    return found


@pytest.mark.parametrize("strain", [0.0, 0.37, -0.8, 1.6])
def test_lees_edwards_bonds_against_every_image(strain):
    rng = np.random.default_rng(7)
    length, n = 4.0, 60
    # any representative: each particle moved by a random lattice vector
    pos = rng.random((n, 3)) * length + np.array(
        [image(length, strain, k) for k in rng.integers(-1, 2, (n, 3))])
    diam = rng.choice([1.0, 1.4], n)
    # bond_order's bonds are pairs_within's pairs with h_max = cutoff − 1 (r_i − r_j)
    pairs = pairs_within(pos, length, strain, diam, h_max=0.2)
    want = image_bonds(pos, length, strain, diam, 1.2)
    assert set(zip(pairs.i.tolist(), pairs.j.tolist(), strict=True)) == set(want)
    for a, b, dr in zip(pairs.i, pairs.j, pairs.rij, strict=True):
        np.testing.assert_allclose(-dr, want[(a, b)], atol=1e-12)
    o = bond_order(pos, length, strain, diam, cutoff=1.2)
    np.testing.assert_array_equal(o.neighbours, np.bincount(
        [k for pair in want for k in pair], minlength=n))


def test_a_whole_strain_is_the_same_lattice():
    rng = np.random.default_rng(1)
    pos = rng.random((200, 3)) * 6.0
    a = bond_order(pos, 6.0, 0.3, cutoff=1.3)
    b = bond_order(pos, 6.0, 1.3, cutoff=1.3)
    assert a.global_q == pytest.approx(b.global_q, abs=1e-12)
    np.testing.assert_allclose(a.local_q, b.local_q, atol=1e-12)
    np.testing.assert_array_equal(a.neighbours, b.neighbours)


def test_an_ideal_gas_is_not_ordered():
    rng = np.random.default_rng(0)
    o = bond_order(rng.random((2000, 3)) * 10.0, 10.0, cutoff=1.5)
    n_bonds = o.neighbours.sum() / 2
    assert o.global_q < 5 / math.sqrt(n_bonds)  # isotropic: Q_6 ~ (bonds)^(−1/2)
    assert o.crystalline_fraction < 0.01


def test_a_particle_without_bonds():
    o = bond_order(np.array([[0.0, 0, 0], [3.0, 3, 3], [3.5, 3, 3]]), 8.0)
    assert math.isnan(o.local_q[0]) and o.neighbours.tolist() == [0, 1, 1]
    empty = bond_order(np.array([[0.0, 0, 0], [3.0, 3, 3]]), 8.0)
    assert math.isnan(empty.global_q) and not empty.crystalline.any()


@pytest.mark.parametrize(("args", "kwargs"), [
    ((np.zeros((4, 2)), 5.0), {}),  # 2D
    ((np.zeros((1, 3)), 5.0), {}),  # one particle
    ((np.random.default_rng(0).random((4, 3)), 1.9), {}),  # box below twice the cut-off
    ((np.random.default_rng(0).random((4, 3)), 5.0), {"l": 5}),  # odd degree
    ((np.random.default_rng(0).random((4, 3)), 5.0), {"cutoff": 0.0}),
    ((np.random.default_rng(0).random((4, 3)), 5.0), {"cutoff": 0.9}),  # inside the contacts
    ((np.random.default_rng(0).random((4, 3)), 5.0), {"diameters": [1.0, 1.0]}),
])
def test_refusals(args, kwargs):
    with pytest.raises(ValueError):
        bond_order(*args, **kwargs)
