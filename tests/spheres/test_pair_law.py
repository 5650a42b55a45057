"""The pair law ``V = (1 − r/σ_ij)^α`` for any size distribution and exponent (``SPEC.md`` §5),
against the independent brute force of ``spheres_brute`` (every pair, every image, the law
written out by hand), finite differences, and the exact harmonic special case."""

from __future__ import annotations

import numpy as np
import pytest
from spheres_brute import brute_force

import jamlab.spheres as sp
from jamlab.spheres.state import parse_sizes, size_distribution, solid_volume

CASES = [
    # (label, n, dim, phi, sizes, alpha, strain)
    ("bidisperse 2D harmonic", 40, 2, 0.9, "bidisperse", 2.0, 0.0),
    ("bidisperse 2D harmonic sheared", 40, 2, 0.9, "bidisperse", 2.0, 0.37),
    ("polydisperse 3D harmonic", 60, 3, 0.75, "polydisperse:0.15", 2.0, 0.0),
    ("monodisperse 3D Hertzian", 50, 3, 0.72, "mono", 2.5, 0.0),
    ("polydisperse 3D Hertzian sheared", 60, 3, 0.75, "polydisperse", 2.5, -1.3),
    ("bidisperse 2D alpha 3.3", 40, 2, 0.92, "bidisperse", 3.3, 0.2),
]


def _case(n, dim, phi, sizes, alpha, strain, seed=3):
    pk = sp.random_packing(n, dim, phi, seed, sizes=sizes, alpha=alpha)
    pk = sp.affine_shear(pk, strain) if strain else pk
    return pk


def _rel(a, b, scale):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / scale)


@pytest.mark.parametrize("label,n,dim,phi,sizes,alpha,strain", CASES, ids=[c[0] for c in CASES])
def test_observables_equal_brute_force(label, n, dim, phi, sizes, alpha, strain):
    pk = _case(n, dim, phi, sizes, alpha, strain)
    ref = brute_force(
        pk.wrapped().positions, pk.box.length, pk.strain, pk.diameters, alpha
    )
    ev = sp.evaluate(pk)
    assert ev.n_contacts == ref["n_contacts"] > n  # a dense, overlapping configuration
    assert abs(ev.energy - ref["energy"]) <= 1e-12 * ref["energy_scale"]
    assert _rel(ev.forces, ref["forces"], ref["force_scale"]) <= 1e-12
    vol = pk.box.volume
    np.testing.assert_allclose(ev.stress_tensor * vol, ref["virial"], rtol=0,
                               atol=1e-12 * ref["virial_scale"].max())
    assert abs(ev.shear_stress - ref["shear_stress"]) <= 1e-12 * ref["virial_scale"].max()
    p_scale = ref["virial_scale"].max() / (dim * vol)
    assert abs(ev.pressure - ref["pressure"]) <= 1e-12 * p_scale
    assert abs(sp.pressure(pk) - ref["pressure"]) <= 1e-12 * p_scale
    h = sp.hessian(pk).toarray()
    hs = np.abs(ref["hessian"]).max()
    assert _rel(h, ref["hessian"], hs) <= 1e-12
    assert _rel(sp.dforce_dstrain(pk), ref["dforce_dstrain"], hs) <= 1e-12
    i, j, _ = sp.contacts(pk)
    bi, bj = ref["pairs"]
    assert set(zip(i.tolist(), j.tolist(), strict=True)) == {
        (min(a, b), max(a, b)) for a, b in zip(bi.tolist(), bj.tolist(), strict=True)
    }


@pytest.mark.parametrize("alpha", [2.0, 2.5, 3.3])
def test_derivatives_by_finite_differences(alpha):
    """F = −∂E/∂r, Σ = ∂E/∂γ (affine) and H = −∂F/∂r by central differences (relative 1e-6)."""
    pk = _case(30, 3, 0.75, "polydisperse:0.2", alpha, 0.1, seed=7)
    e0, f0 = sp.energy_and_forces(pk)
    eps = 1e-6
    k, a = 4, 2
    plus = np.array(pk.positions)
    plus[k, a] += eps
    minus = np.array(pk.positions)
    minus[k, a] -= eps
    fd = -(sp.energy(pk.with_positions(plus)) - sp.energy(pk.with_positions(minus))) / (2 * eps)
    assert abs(fd - f0[k, a]) <= 1e-6 * np.abs(f0).max()
    sig_fd = (sp.energy(sp.affine_shear(pk, eps)) - sp.energy(sp.affine_shear(pk, -eps))) / (
        2 * eps
    )
    assert abs(sig_fd - sp.shear_stress(pk)) <= 1e-6 * abs(sp.shear_stress(pk))
    h = sp.hessian(pk).toarray()
    col = -(sp.forces(pk.with_positions(plus)) - sp.forces(pk.with_positions(minus))) / (2 * eps)
    np.testing.assert_allclose(h[:, 3 * k + a], col.ravel(), rtol=0, atol=1e-6 * np.abs(h).max())


@pytest.mark.parametrize("label,n,dim,phi,sizes,alpha,strain", CASES, ids=[c[0] for c in CASES])
def test_numpy_forms_of_the_law(label, n, dim, phi, sizes, alpha, strain):
    """``pair_energy`` summed over every pair within reach is the brute-force energy, zero
    beyond contact, and ``contact_force`` is its ``−dV/dr`` by central differences."""
    from jamlab.spheres.pair import contact_force, pair_energy, pair_sigmas

    pk = _case(n, dim, phi, sizes, alpha, strain)
    ref = brute_force(pk.wrapped().positions, pk.box.length, pk.strain, pk.diameters, alpha)
    i, j = np.triu_indices(n, 1)
    dr = pk.box.minimum_image(pk.positions[i] - pk.positions[j])
    r = np.sqrt(np.einsum("kd,kd->k", dr, dr))
    sig = pair_sigmas(pk.diameters, i, j)
    v = pair_energy(r, sig, alpha)
    assert np.all(v[r >= sig] == 0.0) and np.count_nonzero(v) == ref["n_contacts"]
    assert abs(v.sum() - ref["energy"]) <= 1e-12 * ref["energy_scale"]
    c = r < sig
    eps = 1e-7
    fd = -(pair_energy(r[c] + eps, sig[c], alpha) - pair_energy(r[c] - eps, sig[c], alpha)) / (
        2 * eps
    )
    f = contact_force(r[c], sig[c], alpha)
    assert np.max(np.abs(fd - f)) <= 1e-6 * np.max(f)


def test_harmonic_monodisperse_is_the_special_case():
    """α = 2 with D = 1 through the general code path (α = 2 + 1e-12 takes the power branch)
    agrees with the harmonic branch to 1e-10 relative."""
    pk = sp.random_packing(80, 3, 0.8, 2)
    near = sp.Packing(pk.positions, pk.box, diameters=pk.diameters, alpha=2.0 + 1e-12)
    e1, f1 = sp.energy_and_forces(pk)
    e2, f2 = sp.energy_and_forces(near)
    assert abs(e1 - e2) <= 1e-10 * e1
    assert np.max(np.abs(f1 - f2)) <= 1e-10 * np.abs(f1).max()


def test_size_distributions():
    d = size_distribution(11, "bidisperse")
    assert (d == 1.0).sum() == 6 and (d == 1.4).sum() == 5
    p = size_distribution(1000, "polydisperse:0.2")
    assert abs(p.mean() - 1.0) < 1e-14 and abs(p.std() / p.mean() - 0.2) < 1e-5
    assert np.all(size_distribution(5, "mono") == 1.0)
    for bad in ("poly", "polydisperse:0.7", "bidisperse:0.1", "mono:", "polydisperse:x"):
        with pytest.raises(ValueError):
            parse_sizes(bad)
    # phi = Σ v_d(D_i/2) / L^d
    pk = sp.random_packing(64, 2, 0.84, 1, sizes="bidisperse")
    expect = (32 * np.pi * 0.25 + 32 * np.pi * 0.49) / pk.box.length**2
    assert abs(pk.phi - 0.84) < 1e-14 and abs(pk.phi - expect) < 1e-14
    assert solid_volume(np.ones(3), 3) == 3 * sp.sphere_volume(3)


def test_bad_pair_law_is_rejected():
    pk = sp.random_packing(20, 3, 0.5, 1)
    for alpha in (1.0, 0.5, float("nan"), "x"):
        with pytest.raises(ValueError, match="alpha"):
            sp.Packing(pk.positions, pk.box, alpha=alpha)
    with pytest.raises(ValueError, match="diameters"):
        sp.Packing(pk.positions, pk.box, diameters=-np.ones(20))
    with pytest.raises(ValueError, match="diameters"):
        sp.Packing(pk.positions, pk.box, diameters=np.ones(3))
    nl = sp.NeighborList(pk)
    other = sp.Packing(pk.positions, pk.box, alpha=2.5)
    with pytest.raises(ValueError, match="pair law"):
        sp.energy(other, nl)


def test_configuration_file_round_trip(tmp_path):
    pk = sp.random_packing(30, 2, 0.8, 4, sizes="polydisperse:0.1", alpha=2.5)
    path = sp.write_packing(tmp_path / "c.h5", pk)
    back = sp.read_packing(path)
    assert np.array_equal(back.diameters, pk.diameters) and back.alpha == 2.5
    assert np.array_equal(back.positions, pk.positions)


def test_specialised_and_general_kernels_agree_bit_for_bit():
    """The paper's system runs the compile-time specialisation (``diam=None, alpha=None``); the
    general path with an explicit ``D = 1`` array and ``α = 2.0`` computes the same numbers in
    the same operations: energies, forces, virial, contacts and Hessian bit for bit."""
    from jamlab.spheres import kernels as K

    pk = sp.random_packing(300, 3, 0.8, 9)
    nl = sp.NeighborList(pk)
    assert nl.diameters is None and nl.alpha is None  # the specialisation is what runs
    pos = nl.sorted(pk.positions)
    lst = (pos, nl.start, nl.nbr, nl.shift)
    ones = np.ones(pk.n)
    f1, f2 = np.empty_like(pos), np.empty_like(pos)
    s1, s2 = np.empty((3, 3)), np.empty((3, 3))
    assert K.energy_forces_virial(*lst, None, None, f1, s1) == K.energy_forces_virial(
        *lst, ones, 2.0, f2, s2
    )
    assert np.array_equal(f1, f2) and np.array_equal(s1, s2)
    ci, cj, cd = K.contact_pairs(*lst, None)
    ci2, cj2, cd2 = K.contact_pairs(*lst, ones)
    assert np.array_equal(ci, ci2) and np.array_equal(cd, cd2)
    h1 = K.hessian_coo(ci, cj, cd, None, None)[2]
    h2 = K.hessian_coo(ci, cj, cd, ones, 2.0)[2]
    assert np.array_equal(h1, h2)


@pytest.mark.parametrize("sizes", ["mono", "bidisperse"])
def test_branch_free_kernel_gives_the_same_bits(sizes):
    """The branch-free force kernel (3D, harmonic law, the contact test as a select) computes
    the branchy kernel's numbers bit for bit, including pairs exactly at contact distance, and
    agrees with the brute force; ``energy_forces_any`` takes it on lists longer than its
    threshold, with the same result."""
    from jamlab.spheres.kernels import pairs as P

    pk = sp.random_packing(1800, 3, 0.66, 4, sizes=sizes)
    nl = sp.NeighborList(pk, skin=0.3)
    pos = np.ascontiguousarray(nl.sorted(pk.positions))
    # put some pairs exactly at (and one ulp inside/outside) their contact distance
    rng = np.random.default_rng(0)
    sig = 1.0 if nl.diameters is None else 0.5 * (nl.diameters[:, None] + nl.diameters[None, :])
    for k in rng.choice(nl.start[-1], size=30, replace=False):
        i = int(np.searchsorted(nl.start, k, side="right") - 1)
        j = int(nl.nbr[k])
        s = sig if np.isscalar(sig) else sig[i, j]
        d = pos[i] - pos[j] + nl.shift[k]
        target = np.nextafter(s, [0.0, 2.0][int(rng.integers(2))]) if k % 3 else s
        pos[i] = pos[j] - nl.shift[k] + d * (target / np.sqrt(d @ d))
    plain, masked = P.energy_forces_3d, P.energy_forces_3d_masked
    f1, f2, f3 = (np.empty_like(pos) for _ in range(3))
    e1 = plain(pos, nl.start, nl.nbr, nl.shift, nl.diameters, None, f1)
    e2 = masked(pos, nl.start, nl.nbr, nl.shift, nl.diameters, f2)
    assert e1 == e2 and np.array_equal(f1, f2)
    lst = (pos, nl.start, nl.nbr, nl.shift, nl.diameters, None)
    for threshold in (0, nl.start[-1] - 1, nl.start[-1], 2**62):  # masked, masked, branchy ×2
        assert P.energy_forces_any(*lst, f3, threshold) == e1
        assert np.array_equal(f3, f1)
    # on the unmoved packing (the list is valid there), against the brute force
    original = np.ascontiguousarray(nl.sorted(pk.positions))
    e4 = masked(original, nl.start, nl.nbr, nl.shift, nl.diameters, f2)
    ref = brute_force(pk.wrapped().positions, pk.box.length, pk.strain, pk.diameters, 2.0)
    assert abs(e4 - ref["energy"]) <= 1e-12 * ref["energy_scale"]
    assert _rel(nl.unsorted(f2), ref["forces"], ref["force_scale"]) <= 1e-12
