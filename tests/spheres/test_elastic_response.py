"""The linear elastic non-affine response ``u^el = δγ K⁺ Ξ`` of a minimum
(:func:`jamlab.spheres.aqs.anatomy.elastic_nonaffine_response`, used to take the elastic part out
of an avalanche's displacement field) against (1) a full FIRE minimisation after a small affine
shear, where it must predict the non-affine displacement to second order in ``δγ``, and (2) a
finite-difference Hessian and ``∂F/∂γ`` of a hand-written pair sum, solved by dense least
squares."""

from __future__ import annotations

import numpy as np
import pytest
from spheres_brute import brute_elastic_response, brute_force, brute_jammed_state, wrap

import jamlab.spheres as sp
from jamlab.analysis.anatomy import event_field, nonaffine_displacements
from jamlab.spheres.aqs.anatomy import elastic_nonaffine_response
from jamlab.spheres.contacts import backbone_mask, contacts
from jamlab.spheres.fire import minimize
from jamlab.spheres.state import affine_shear


@pytest.fixture(scope="module")
def jammed64():
    return sp.jam(64, 3, 1, p_target=1e-3).packing


def residual_ratio(packing, dgamma: float) -> float:
    """``|u − u^el − t| / |u|`` over the backbone after affine shear ``δγ`` and FIRE."""
    ci, cj, _ = contacts(packing)
    keep = backbone_mask(ci, cj, packing.n, packing.dim + 1)
    res = minimize(affine_shear(packing, dgamma), ftol=1e-15)
    assert res.converged
    after = res.packing
    ai, aj, _ = contacts(after)
    assert set(zip(ci, cj, strict=True)) == set(zip(ai, aj, strict=True)), "a contact changed"
    u = nonaffine_displacements(
        packing.positions, after.positions, packing.box.length, packing.strain, after.strain
    )
    ev, fraction = event_field(u, elastic_nonaffine_response(packing, dgamma, keep), keep)
    assert np.isfinite(fraction)
    return float(np.linalg.norm(ev[keep]) / np.linalg.norm(u[keep]))


def test_linear_response_predicts_an_elastic_step_to_second_order(jammed64):
    assert residual_ratio(jammed64, 1e-6) < 1e-4  # measured 4.4e-5 (the FIRE floor)
    r1 = residual_ratio(jammed64, 1e-5)
    r2 = residual_ratio(jammed64, 2e-5)
    # measured: 2.5e-4 and 5.0e-4 (N = 64, p = 1e-3, seed 1); the FIRE floor (ftol 1e-15) is
    # ~4e-5 of |u| at δγ = 1e-6, so the doubling is checked where it is well above the floor
    assert r1 < 1e-3 and r2 < 2e-3
    assert 1.7 < r2 / r1 < 2.3  # the remainder is O(δγ²): its ratio to |u| = O(δγ) doubles


def test_linear_response_is_not_the_raw_field_with_a_wrong_sign(jammed64):
    # the subtraction removes the elastic field, it does not double it
    p = jammed64
    ci, cj, _ = contacts(p)
    keep = backbone_mask(ci, cj, p.n, p.dim + 1)
    el = elastic_nonaffine_response(p, 1e-5, keep)
    after = minimize(affine_shear(p, 1e-5), ftol=1e-15).packing
    u = nonaffine_displacements(p.positions, after.positions, p.box.length, 0.0, after.strain)
    assert np.linalg.norm((u + el)[keep]) > 1.9 * np.linalg.norm(u[keep])


def fd_response(pos, L, gamma, keep, dgamma, diam, alpha, h=1e-6):
    """``u^el`` from central finite differences of the hand-written forces (rattlers deleted):
    ``H = −∂F/∂x`` column by column, ``Ξ = ∂F/∂γ`` with the reduced coordinates fixed."""
    pb, db = pos[keep], diam[keep]
    nb, dim = pb.shape

    def force(p, g):
        return brute_force(wrap(p, L, g), L, g, db, alpha)["forces"].ravel()

    H = np.zeros((nb * dim, nb * dim))
    for c in range(nb * dim):
        e = np.zeros(nb * dim)
        e[c] = h
        H[:, c] = -(force(pb + e.reshape(nb, dim), gamma) - force(pb - e.reshape(nb, dim), gamma))
    H /= 2 * h
    H = 0.5 * (H + H.T)
    sh = np.zeros_like(pb)
    sh[:, 0] = h * pb[:, 1]
    xi = (force(pb + sh, gamma + h) - force(pb - sh, gamma - h)) / (2 * h)
    sol = np.linalg.lstsq(H, dgamma * xi, rcond=1e-9)[0]
    u = np.zeros_like(pos)
    u[keep] = sol.reshape(nb, dim)
    return u


@pytest.mark.parametrize(("n", "dim", "phi", "sizes", "alpha", "seed", "strain"), [
    (16, 3, None, "mono", 2.0, 2, 0.37),  # near jamming (p = 1e-2)
    (24, 3, None, "mono", 2.0, 4, 0.0),  # with 2 rattlers
    (16, 2, 0.9, "bidisperse", 2.0, 1, -1.3),
    (16, 3, 0.75, "mono", 2.5, 3, 0.2),  # Hertzian
])  # fmt: skip
def test_against_finite_difference_brute_force(n, dim, phi, sizes, alpha, seed, strain):
    if phi is None:
        start = sp.jam(n, dim, seed, p_target=1e-3 if n == 24 else 1e-2).packing
    else:
        start = sp.prepare(n, dim, phi, seed, sizes=sizes, alpha=alpha).packing
    # a minimum at a strain with Lees–Edwards images in play
    packing = minimize(affine_shear(start, strain), ftol=1e-14).packing
    L, g = packing.box.length, packing.strain
    pos = wrap(packing.positions, L, g)
    diam = np.asarray(packing.diameters, dtype=float)
    state = brute_jammed_state(packing, 1e-14)
    assert state["jammed"], "the test wants a rigid minimum"
    keep = state["backbone"]
    dgamma = 1e-3
    got = elastic_nonaffine_response(packing, dgamma)
    fd = fd_response(pos, L, g, keep, dgamma, diam, packing.alpha)
    exact = brute_elastic_response(pos, L, g, keep, dgamma, diam, packing.alpha)
    scale = np.linalg.norm(fd)
    assert scale > 0
    # measured |got − fd| / |fd| ≈ 2e-10 – 4e-10 (central differences, h = 1e-6)
    np.testing.assert_allclose(got, fd, atol=1e-8 * scale, rtol=0)
    np.testing.assert_allclose(got, exact, atol=1e-9 * scale, rtol=0)
    assert np.all(got[~keep] == 0)
    if n == 24:
        assert (~keep).sum() == 2
    np.testing.assert_allclose(got[keep].mean(axis=0), 0, atol=1e-14 * scale)


def test_floppy_minimum_has_no_linear_response():
    # a dilute minimum (no contacts left): every backbone particle would be free, so no K⁺ Ξ;
    # with the whole system as "backbone" the pinned Hessian is singular → NaN, never a number
    packing = sp.prepare(16, 3, 0.3, seed=1).packing
    keep = np.ones(packing.n, dtype=bool)
    assert np.all(np.isnan(elastic_nonaffine_response(packing, 1e-3, keep)))
