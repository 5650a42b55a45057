"""The floppy-step projection (:mod:`jamlab.spheres.aqs.projection`) and ``floppy="project"``.

Checked against an independent solver: SciPy's SLSQP on the nonlinear problem itself
(minimise ``½|x − x₀|²`` subject to ``r_ij ≥ σ_ij`` for every pair, written out pair by pair
with the minimum image), on small 2D and 3D packings; and the optimality conditions directly
(``x − x₀ = Gᵀλ``, ``λ ≥ 0``, no overlap, ``λ_c > 0`` only on touching pairs). A jammed
packing has no overlap-free configuration nearby: the projection must say so. The driver
projects only from unjammed minima, records minima, and stays resumable bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize as sp_minimize

from jamlab.spheres import jam, prepare
from jamlab.spheres.aqs import AQSParameters, shear
from jamlab.spheres.aqs.projection import project
from jamlab.spheres.box import Box
from jamlab.spheres.fire import minimize
from jamlab.spheres.neighbors import NeighborList
from jamlab.spheres.potential import energy_and_forces
from jamlab.spheres.state import Packing, affine_shear, random_packing


def overlapping_start(n: int, dim: int, phi: float, seed: int) -> Packing:
    """An unjammed minimum (FIRE at φ below jamming), sheared affinely by a large step, so that
    many pairs overlap."""
    m = minimize(random_packing(n, dim, phi, seed), ftol=1e-14).packing
    return affine_shear(m, 2e-2)


def all_pairs_gaps(x: np.ndarray, box: Box, sigma: float = 1.0):
    n = x.shape[0]
    i, j = np.triu_indices(n, 1)
    dr = box.minimum_image(x[i] - x[j])
    return np.sqrt((dr * dr).sum(1)) - sigma, i, j


def slsqp_projection(start: Packing) -> np.ndarray:
    x0 = np.array(start.positions).ravel()
    shape = start.positions.shape

    def cons(v):
        return all_pairs_gaps(v.reshape(shape), start.box)[0]

    def cons_jac(v):
        x = v.reshape(shape)
        _, i, j = all_pairs_gaps(x, start.box)
        dr = start.box.minimum_image(x[i] - x[j])
        u = dr / np.sqrt((dr * dr).sum(1))[:, None]
        jac = np.zeros((i.size,) + shape)
        rows = np.arange(i.size)
        jac[rows, i] = u
        jac[rows, j] = -u
        return jac.reshape(i.size, -1)

    res = sp_minimize(lambda v: 0.5 * np.sum((v - x0) ** 2), x0, jac=lambda v: v - x0,
                      constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
                      method="SLSQP", options={"ftol": 1e-15, "maxiter": 500})
    assert res.success, res.message
    return res.x.reshape(shape)


@pytest.mark.parametrize("dim,n,phi,seed", [(2, 24, 0.6, 3), (3, 24, 0.45, 5)])
def test_projection_equals_an_independent_solver(dim, n, phi, seed):
    start = overlapping_start(n, dim, phi, seed)
    assert all_pairs_gaps(start.positions, start.box)[0].min() < -1e-3  # something to remove
    res = project(start, NeighborList(start, skin=0.3))
    assert res, res.reason
    x = res.packing.positions
    ref = slsqp_projection(start)
    assert np.abs(start.box.minimum_image(x - ref)).max() < 1e-7
    # no overlap and no force: a minimum, E = 0 to rounding
    assert all_pairs_gaps(x, start.box)[0].min() > -1e-14
    e, f = energy_and_forces(res.packing)
    assert e < 1e-26 and np.abs(f).max() < 1e-13


@pytest.mark.parametrize("dim,n,phi,seed", [(2, 24, 0.6, 3), (3, 24, 0.45, 5)])
def test_anderson_mixing_reaches_the_same_projection(dim, n, phi, seed):
    # the accelerated iteration only moves the linearisation points: the same fixed point as
    # the plain one, to the stopping tolerance, and no more linearisations
    start = overlapping_start(n, dim, phi, seed)
    nl = NeighborList(start, skin=0.3)
    plain, mixed = project(start, nl, anderson=0), project(start, nl)
    assert plain and mixed
    assert np.abs(start.box.minimum_image(
        plain.packing.positions - mixed.packing.positions)).max() < 1e-9
    assert mixed.sqp <= plain.sqp


def test_a_chain_that_opens_only_by_bending_needs_another_linearisation_point():
    # a straight periodic chain of 4 spheres, compressed along x: to first order its gaps cannot
    # all open (a state of self-stress), so the first linearisation has no solution; the
    # projection first linearised at a bent point finds the nearest zigzag, as SLSQP does
    # from the same point
    length = 3.99
    box = Box(length, 2, 0.0)
    x = np.stack([np.arange(4) * length / 4, np.full(4, length / 2)], axis=1)
    straight = Packing(x, box)
    nl = NeighborList(straight, skin=0.3)
    first = project(straight, nl)
    assert not first  # (CHOLMOD may pass the singular M_AA on a rounding-level pivot: then
    # the multipliers are huge and the end check finds the overlap left)
    bent = straight.with_positions(x + np.array([[0, 0.02], [0, -0.02]] * 2))
    res = project(straight, nl, start=bent)
    assert res, res.reason
    y = res.packing.positions
    assert all_pairs_gaps(y, box)[0].min() > -1e-14
    dy = y[:, 1] - length / 2
    assert np.allclose(np.abs(dy), np.sqrt(1 - (length / 4) ** 2) / 2, rtol=1e-6)
    assert np.all(dy[::2] > 0) and np.all(dy[1::2] < 0)
    x0 = straight.positions.ravel()

    def cons(v):
        return all_pairs_gaps(v.reshape(4, 2), box)[0]

    ref = sp_minimize(lambda v: 0.5 * np.sum((v - x0) ** 2), bent.positions.ravel(),
                      jac=lambda v: v - x0, constraints=[{"type": "ineq", "fun": cons}],
                      method="SLSQP", options={"ftol": 1e-15, "maxiter": 500})
    assert ref.success
    assert np.abs(box.minimum_image(y - ref.x.reshape(4, 2))).max() < 1e-6


def test_projection_optimality_conditions():
    start = overlapping_start(64, 3, 0.5, 7)
    res = project(start, NeighborList(start, skin=0.3))
    assert res, res.reason
    x, x0 = res.packing.positions, start.positions
    assert (res.lam >= 0).all() and (res.lam > 0).sum() > 10
    # stationarity: x − x₀ = Gᵀλ, with G at the end (converged to xtol)
    dr = start.box.minimum_image(x[res.pi] - x[res.pj])
    r = np.sqrt((dr * dr).sum(1))
    u = dr / r[:, None]
    push = np.zeros_like(x)
    np.add.at(push, res.pi, res.lam[:, None] * u)
    np.add.at(push, res.pj, -res.lam[:, None] * u)
    assert np.abs(start.box.minimum_image(x - x0) - push).max() < 1e-9
    # complementarity: the pushing pairs touch
    assert np.abs(r[res.lam > 0] - 1.0).max() < 1e-9


def test_a_jammed_packing_cannot_be_projected():
    pk = prepare(64, 3, 0.8, seed=1).packing  # far above jamming: no overlap-free configuration
    res = project(affine_shear(pk, 1e-5), NeighborList(pk))
    assert not res and res.packing is None and res.reason


def test_floppy_default_and_choices():
    assert AQSParameters().floppy == "fire"
    with pytest.raises(ValueError, match="floppy must be"):
        AQSParameters(floppy="newton")


def test_shear_projects_floppy_steps_only():
    pk = minimize(random_packing(64, 3, 0.5, 11), ftol=1e-14).packing  # unjammed, E = 0
    res = shear(pk, 1e-2, n_steps=8, params=AQSParameters(floppy="project"))
    tr = res.trace
    assert tr.attrs["n_projected"] == 8 and tr.attrs["n_projection_failed"] == 0
    assert (tr.max_force < 1e-12).all() and not tr.plastic.any() and not tr.jammed.any()
    assert (tr.energy[1:] < 1e-26).all()
    # a jammed packing: nothing is projected, and the run equals the default one bit for bit
    jammed = prepare(64, 3, 0.8, seed=2).packing
    a = shear(jammed, 1e-4, n_steps=6, params=AQSParameters(floppy="project")).trace
    b = shear(jammed, 1e-4, n_steps=6).trace
    assert a.attrs["n_projected"] == 0 and a.attrs["n_projection_failed"] == 0
    assert np.array_equal(a.energy, b.energy) and np.array_equal(a.plastic, b.plastic)
    # unjammed after one step, jammed again after the next: the projection finds no
    # overlap-free configuration and the usual strategies take the step
    hop = jam(64, 3, seed=3, p_target=1e-7).packing
    c = shear(hop, 1e-4, n_steps=6, params=AQSParameters(floppy="project")).trace
    assert c.jammed[0] and not c.jammed[1] and c.jammed[2:].all()
    assert c.attrs["n_projected"] == 0 and c.attrs["n_projection_failed"] == 1
    assert (c.max_force < 1e-12).all()


def test_projected_run_resumes_bit_for_bit(tmp_path):
    start = jam(64, 3, seed=1, p_target=1e-7).packing  # unjams at once at constant volume
    params = AQSParameters(floppy="project")
    whole = shear(start, 1e-4, n_steps=10, params=params, save_every=5, out=tmp_path / "a.h5")
    assert whole.trace.attrs["n_projected"] >= 5
    half = shear(start, 1e-4, n_steps=5, params=params, out=tmp_path / "b.h5")
    rest = shear(half.packing, 1e-4, n_steps=10, params=params, previous=half.trace,
                 out=tmp_path / "b.h5")
    for col in ("energy", "shear_stress", "pressure", "jammed", "plastic"):
        assert np.array_equal(getattr(whole.trace, col), getattr(rest.trace, col)), col
    assert np.array_equal(whole.packing.positions, rest.packing.positions)


def test_pairs_beyond_a_thin_list_are_added_and_solved_again():
    """A list whose skin is thinner than the projection's moves misses pairs that the end
    overlaps; the projection adds them and solves once more: the end has no overlap among all
    pairs (brute force) and equals the projection on a list wide enough to hold every pair."""
    start = overlapping_start(64, 3, 0.5, 7)
    wide = project(start, NeighborList(start, skin=0.3))
    thin_list = NeighborList(start, skin=1e-4)
    first = project(start, thin_list, pairs=_list_pairs(start, thin_list))  # no second round
    assert not first and "overlap" in first.reason  # the thin list alone does not suffice
    thin = project(start, NeighborList(start, skin=1e-4))
    assert wide and thin, (wide.reason, thin.reason)
    x = thin.packing.positions
    g, _, _ = all_pairs_gaps(x, start.box)
    assert g.min() > -1e-14
    assert np.abs(start.box.minimum_image(x - wide.packing.positions)).max() < 1e-8


def _list_pairs(packing, nl):
    from jamlab.spheres.aqs.projection import candidate_pairs

    return candidate_pairs(packing, nl)
