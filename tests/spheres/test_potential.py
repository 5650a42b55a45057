"""Energy, forces, stress, pressure, Hessian against brute force and numerical derivatives.

Box sizes: the engine needs ``L > 2`` (a unique image within the cut-off), so N is chosen per
dimension to keep ``L > 2`` at φ = 0.9 (d=4, N=300 gives L ≈ 3.1). Both the cell-list and the
all-pairs search paths are hit (the latter when fewer than 3 cells fit along an axis).
"""

from __future__ import annotations

import numpy as np
import pytest
from spheres_brute import brute_force

import jamlab.spheres as sp
from jamlab.spheres.box import box_length_for

N_FOR_DIM = {2: 80, 3: 150, 4: 300}
STRAINS = [0.0, 0.3, 0.5, 0.7, 1.3]
PHIS = [0.5, 0.7, 0.9]
RTOL = 1e-12


def make(dim: int, phi: float, strain: float, seed: int, n: int | None = None):
    """Random positions in [0, L)^d (for the brute force) and the same configuration moved by
    random Lees–Edwards lattice vectors (for the engine, to exercise its image handling)."""
    n = N_FOR_DIM[dim] if n is None else n
    L = box_length_for(n, dim, phi)
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, L, size=(n, dim))
    k = rng.integers(-2, 3, size=(n, dim)).astype(float)
    moved = pos + k * L
    moved[:, 0] += k[:, 1] * strain * L
    return pos, sp.Packing(moved, sp.Box(L, dim, strain)), L


CASES = [(d, s, phi) for d in (2, 3, 4) for s in STRAINS for phi in PHIS]


@pytest.mark.parametrize(("dim", "strain", "phi"), CASES)
def test_matches_brute_force(dim, strain, phi):
    seed = 1000 * dim + int(100 * strain) + int(10 * phi)
    pos, p, L = make(dim, phi, strain, seed)
    ref = brute_force(pos, L, strain)
    assert ref["n_contacts"] > 0
    for nl in (None, sp.NeighborList(p, skin=0.3)):
        e, f = sp.energy_and_forces(p, nl)
        assert abs(e - ref["energy"]) <= RTOL * ref["energy_scale"]
        assert abs(sp.energy(p, nl) - e) <= RTOL * ref["energy_scale"]
        assert np.abs(f - ref["forces"]).max() <= RTOL * ref["force_scale"]
        S = sp.stress_tensor(p, nl) * L**dim
        assert np.all(np.abs(S - ref["virial"]) <= RTOL * ref["virial_scale"])
        assert abs(sp.shear_stress(p, nl) - ref["shear_stress"]) <= RTOL * ref["virial_scale"][0, 1]
        p_scale = np.trace(ref["virial_scale"]) / (dim * L**dim)
        assert abs(sp.pressure(p, nl) - ref["pressure"]) <= RTOL * p_scale
        assert sp.coordination(p, nl) == pytest.approx(2 * ref["n_contacts"] / p.n, rel=0, abs=0)
        ev = sp.evaluate(p, nl)
        assert abs(ev.energy - ref["energy"]) <= RTOL * ref["energy_scale"]
        assert np.abs(ev.forces - ref["forces"]).max() <= RTOL * ref["force_scale"]
        assert np.all(
            np.abs(ev.stress_tensor * L**dim - ref["virial"]) <= RTOL * ref["virial_scale"]
        )
        assert abs(ev.shear_stress - ref["shear_stress"]) <= RTOL * ref["virial_scale"][0, 1]
        assert abs(ev.pressure - ref["pressure"]) <= RTOL * p_scale
        assert ev.n_contacts == ref["n_contacts"]
        assert ev.max_force == pytest.approx(np.linalg.norm(ref["forces"], axis=1).max(), rel=1e-10)
    H = sp.hessian(p).toarray()
    scale = np.abs(ref["hessian"]).max()
    assert np.abs(H - ref["hessian"]).max() <= RTOL * scale


@pytest.mark.parametrize(("dim", "strain"), [(2, 0.7), (3, 0.3), (3, 1.3), (4, 0.5)])
def test_forces_are_minus_gradient(dim, strain):
    _, p, _ = make(dim, 0.8, strain, seed=7 + dim, n=N_FOR_DIM[dim] // 2 + 30)
    f = sp.forces(p)
    rng = np.random.default_rng(3)
    h = 1e-6
    pos = np.array(p.positions)
    for i in rng.choice(p.n, size=10, replace=False):
        for a in range(dim):
            plus, minus = pos.copy(), pos.copy()
            plus[i, a] += h
            minus[i, a] -= h
            num = (sp.energy(p.with_positions(plus)) - sp.energy(p.with_positions(minus))) / (2 * h)
            assert abs(-num - f[i, a]) < 1e-7 * (1 + abs(f[i, a]))


@pytest.mark.parametrize(("dim", "strain"), [(2, 0.0), (3, 0.5), (3, 1.3), (4, 0.7)])
def test_shear_stress_is_energy_derivative(dim, strain):
    _, p, _ = make(dim, 0.85, strain, seed=11 + dim)
    h = 1e-6
    num = (sp.energy(sp.affine_shear(p, h)) - sp.energy(sp.affine_shear(p, -h))) / (2 * h)
    sigma = sp.shear_stress(p)
    assert abs(num - sigma) < 1e-7 * (1 + abs(sigma))


@pytest.mark.parametrize(("dim", "strain"), [(2, 0.3), (3, 0.7), (4, 1.3)])
def test_hessian_is_jacobian_of_forces(dim, strain):
    _, p, _ = make(dim, 0.8, strain, seed=5 + dim, n={2: 40, 3: 60, 4: 120}[dim])
    H = sp.hessian(p).toarray()
    pos = np.array(p.positions)
    h = 1e-6
    num = np.empty_like(H)
    for i in range(p.n):
        for a in range(dim):
            plus, minus = pos.copy(), pos.copy()
            plus[i, a] += h
            minus[i, a] -= h
            df = sp.forces(p.with_positions(plus)) - sp.forces(p.with_positions(minus))
            num[:, dim * i + a] = -df.ravel() / (2 * h)
    assert np.abs(H - H.T).max() <= 1e-14 * np.abs(H).max()
    assert np.abs(num - H).max() < 1e-6 * np.abs(H).max()


@pytest.mark.parametrize(("dim", "strain"), [(2, 0.0), (3, 0.3), (4, 1.3)])
def test_dforce_dstrain_is_numerical(dim, strain):
    _, p, _ = make(dim, 0.8, strain, seed=21 + dim)
    h = 1e-6
    num = (sp.forces(sp.affine_shear(p, h)) - sp.forces(sp.affine_shear(p, -h))) / (2 * h)
    xi = sp.dforce_dstrain(p)
    assert np.abs(xi - num).max() < 1e-6 * (1 + np.abs(xi).max())


@pytest.mark.parametrize("n", [400, 60])  # cell search, and all-pairs search (2 cells per axis)
def test_neighbor_list_follows_strain_and_motion(n):
    pos, p, L = make(3, 0.8, 0.2, seed=99, n=n)
    nl = sp.NeighborList(p, skin=0.3)
    builds = nl.n_builds
    q = sp.affine_shear(p, 0.01)
    assert sp.energy(q, nl) == pytest.approx(sp.energy(q), rel=1e-13)
    assert nl.n_builds == builds  # a small strain step keeps the list
    rng = np.random.default_rng(1)
    q2 = q.with_positions(q.positions + rng.normal(0, 0.02, q.positions.shape))
    assert sp.energy(q2, nl) == pytest.approx(sp.energy(q2), rel=1e-13)
    q3 = sp.affine_shear(q2, 0.5)
    sp.energy(q3, nl)
    assert nl.n_builds > builds  # a large strain step rebuilds
    ref = brute_force(q3.box.wrap(q3.positions), L, q3.strain)
    assert sp.energy(q3, nl) == pytest.approx(ref["energy"], rel=1e-12)


def test_neighbor_list_shifts_depend_on_the_strain_alone():
    """A list moved through 2000 strains inside one step (as a chattering continuation's
    trials did) holds the same image shifts, bit for bit, as one moved to the step's end at
    once; and they are the images of the box at that strain (to rounding). Moved by increments,
    the shifts drifted by ~1e-13 here (6e-14 and 1.4e-13 for two steps tried)."""
    _, p, _ = make(3, 0.8, 0.2, seed=7, n=400)
    once, often = sp.NeighborList(p, skin=0.3), sp.NeighborList(p, skin=0.3)
    g0, g1 = p.strain, p.strain + 1e-5
    for g in np.random.default_rng(0).uniform(g0, g1, 2000):
        often.update(p.positions, g)
    often.update(p.positions, g1)
    once.update(p.positions, g1)
    assert often.n_builds == once.n_builds == 1
    assert np.array_equal(often.shift, once.shift)
    q = sp.Packing(p.positions, p.box.with_strain(g1))
    pos = once.sorted(q.positions)
    i = np.repeat(np.arange(q.n), np.diff(once.start))
    exact = q.box.minimum_image(pos[i] - pos[once.nbr])
    np.testing.assert_allclose(pos[i] - pos[once.nbr] + once.shift, exact, rtol=0, atol=1e-13)


def test_large_accumulated_strain():
    """γ = 7.3 and γ = 0.3 are the same lattice: same energy and stress."""
    _, p, _ = make(3, 0.8, 0.3, seed=4)
    q = sp.Packing(p.positions, p.box.with_strain(7.3))
    assert sp.energy(q) == pytest.approx(sp.energy(p), rel=1e-13)
    assert sp.shear_stress(q) == pytest.approx(sp.shear_stress(p), rel=1e-12)


def test_rattlers_match_independent_peeling():
    pos, p, L = make(3, 0.65, 0.0, seed=8, n=200)
    ref = brute_force(pos, L, 0.0)
    i, j = ref["pairs"]
    keep = np.ones(p.n, bool)
    pairs = list(zip(i.tolist(), j.tolist(), strict=True))
    changed = True
    while changed:
        changed = False
        for k in range(p.n):
            n_k = sum(1 for a, b in pairs if (a == k and keep[b]) or (b == k and keep[a]))
            if keep[k] and n_k < 4:
                keep[k] = False
                changed = True
    nc = sum(1 for a, b in pairs if keep[a] and keep[b])
    r = sp.remove_rattlers(p)
    assert np.array_equal(r.mask, keep)
    assert r.n_rattlers == p.n - keep.sum()
    assert r.n_contacts_nr == nc
    assert r.z_nr == (2 * nc / keep.sum() if keep.sum() else 0.0)


@pytest.mark.parametrize("dim", [6, 12, 24, 64])
def test_high_dimension_few_spheres_matches_minimum_image(dim):
    """A box of a few diameters in high d: the cell list would have 3^d cells for a handful of
    spheres (d = 12: 49 s and 4 GB for two spheres; d = 32 crashed the process), so all pairs
    are searched. Energy and forces against plain numpy minimum-image sums (L = 5 > 2 cut-offs:
    one image per pair at most)."""
    rng = np.random.default_rng(dim)
    L, n = 5.0, 6
    offsets = rng.normal(size=(n, dim))
    offsets *= rng.uniform(0.2, 0.6, size=(n, 1)) / np.linalg.norm(offsets, axis=1, keepdims=True)
    pos = 2.5 + offsets  # a cluster: most pairs overlap
    e_ref, f_ref = 0.0, np.zeros((n, dim))
    for i in range(n):
        for j in range(i + 1, n):
            dr = pos[i] - pos[j]
            dr -= L * np.round(dr / L)
            r = np.linalg.norm(dr)
            if r < 1.0:
                e_ref += (1.0 - r) ** 2
                f = 2.0 * (1.0 - r) * dr / r  # −∂E/∂r_i
                f_ref[i] += f
                f_ref[j] -= f
    assert e_ref > 0
    p = sp.Packing(pos, sp.Box(L, dim))
    for nl in (None, sp.NeighborList(p, skin=0.3)):
        e, f = sp.energy_and_forces(p, nl)
        assert e == pytest.approx(e_ref, rel=1e-13)
        np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-13 * np.abs(f_ref).max())


def test_one_skin_free_list_per_packing_and_the_same_bits(monkeypatch):
    """Evaluations of one packing object without a list share one skin-free build
    (``neighbors.list_positions``), with the bits of a fresh list every time; another packing
    gets a new build (a moved one checked against the brute force)."""
    import jamlab.spheres.neighbors as nb

    pos, pk, _ = make(3, 0.8, 0.3, seed=11)
    builds = []
    init = nb.NeighborList.__init__

    def counted(self, packing, skin=nb.DEFAULT_SKIN):
        builds.append(skin)
        init(self, packing, skin)

    monkeypatch.setattr(nb.NeighborList, "__init__", counted)
    from jamlab.spheres.potential import virial

    ev, vir, con = sp.evaluate(pk), virial(pk), sp.contacts(pk)
    assert builds == [0.0]  # one build for the three
    fresh = sp.NeighborList(pk, skin=0.0)
    ev2 = sp.evaluate(pk, fresh)
    assert ev.energy == ev2.energy and np.array_equal(ev.forces, ev2.forces)
    assert np.array_equal(vir, virial(pk, fresh))
    assert all(np.array_equal(a, b) for a, b in zip(con, sp.contacts(pk, fresh), strict=True))
    builds.clear()
    other = sp.Packing(pk.positions.copy(), pk.box)  # equal, but another object
    assert sp.evaluate(other).energy == ev.energy and builds == [0.0]
    # a packing's positions cannot change under it (read-only): a moved configuration is
    # another packing, and gets its own build
    assert not other.positions.flags.writeable
    builds.clear()
    step = np.zeros_like(pos)
    step[0, 0] = 0.05
    moved = sp.evaluate(other.with_positions(other.positions + step))
    assert builds == [0.0] and moved.energy != ev.energy
    ref = brute_force(pos + step, other.box.length, other.box.strain)
    assert abs(moved.energy - ref["energy"]) <= RTOL * ref["energy_scale"]
