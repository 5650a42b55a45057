"""Hybrid FIRE + Newton minimiser (:mod:`jamlab.spheres.newton`): same minimum as plain FIRE.

Small jammed packings (N = 32–64, p ≈ 1e-4) sheared affinely by a few AQS steps, minimised by
plain FIRE and by the hybrid to ``max_i |F_i| < 1e-12``: the energies agree to 1e-12 relative
and the backbone positions to 1e-6 after removing the mean displacement (FIRE stopped at
``ftol`` is off by ``~ftol/λ_min ≈ 1e-8`` along the softest mode here). No timing asserts.
"""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.spheres import random_packing
from jamlab.spheres.aqs.network import affine_to, find_backbone
from jamlab.spheres.fire import minimize
from jamlab.spheres.newton import HybridParameters, minimize_hybrid
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import NeighborList, energy_and_forces

FTOL = 1e-12


def _max_force(packing) -> float:
    f = energy_and_forces(packing)[1]
    return float(np.sqrt(np.max(np.sum(f * f, axis=1))))


def _compare(fire, hybrid, nl) -> None:
    assert fire.converged and hybrid.converged
    assert hybrid.max_force < FTOL
    assert _max_force(hybrid.packing) < FTOL  # recomputed independently of the result
    # (abs: an unjammed minimum has E ~ N ftol², i.e. zero)
    n = fire.packing.n
    assert hybrid.energy == pytest.approx(fire.energy, rel=1e-12, abs=n * FTOL**2)
    bb = find_backbone(fire.packing, nl)
    if not bb.any():
        return
    dr = fire.packing.box.minimum_image(hybrid.packing.positions - fire.packing.positions)
    dr -= dr[bb].mean(axis=0)
    assert np.max(np.abs(dr[bb])) < 1e-6


@pytest.fixture(scope="module")
def jammed():
    out = []
    for n, seed in ((32, 1), (48, 2), (64, 1)):
        res = jam(n, 3, seed=seed, p_target=1e-4)
        assert res.ok
        out.append(res.packing)
    return out


@pytest.mark.parametrize("index", [0, 1, 2])
def test_hybrid_reaches_fires_minimum_on_aqs_steps(jammed, index):
    cur = jammed[index]
    nl = NeighborList(cur)
    used_newton = 0
    for dgamma in (1e-5, 1e-4, 1e-3):  # elastic to plastic
        for _ in range(2):
            affine = affine_to(cur, cur.strain + dgamma)
            fire = minimize(affine, FTOL, 2_000_000, neighbors=nl)
            hybrid = minimize_hybrid(affine, FTOL, switch=1e-8, neighbors=nl)
            _compare(fire, hybrid, nl)
            assert hybrid.iterations == hybrid.fire_iterations + hybrid.newton_iterations
            used_newton += hybrid.newton_ok
            cur = fire.packing
    assert used_newton > 0  # the Newton path itself was exercised


def test_hybrid_from_a_loose_switch_still_same_minimum(jammed):
    # from max|F| < 1e-6 Newton may fail or need cleanup; the minimum must not change
    cur = jammed[2]
    nl = NeighborList(cur)
    affine = affine_to(cur, cur.strain + 1e-4)
    fire = minimize(affine, FTOL, 2_000_000, neighbors=nl)
    hybrid = minimize_hybrid(affine, FTOL, switch=1e-6, neighbors=nl)
    _compare(fire, hybrid, nl)


def test_unjammed_falls_back_to_fire():
    # φ = 0.45, far below jamming: overlaps are removed, no backbone, Newton never applies
    start = random_packing(40, 3, 0.45, 7)
    fire = minimize(start, FTOL, 2_000_000)
    hybrid = minimize_hybrid(start, FTOL, switch=1e-4)
    assert hybrid.converged and hybrid.max_force < FTOL
    assert _max_force(hybrid.packing) < FTOL
    assert not hybrid.newton_ok and hybrid.n_factorisations == 0
    assert hybrid.newton_iterations == 0
    assert hybrid.energy == pytest.approx(fire.energy, abs=1e-20)


def test_no_attempts_is_plain_fire(jammed):
    cur = jammed[0]
    affine = affine_to(cur, cur.strain + 1e-4)
    fire = minimize(affine, FTOL, 2_000_000)
    hybrid = minimize_hybrid(affine, FTOL, params=HybridParameters(max_attempts=0))
    assert hybrid.n_attempts == 0 and not hybrid.newton_ok
    assert hybrid.fire_iterations >= fire.iterations - 100  # FIRE restarted at the switch
    _compare(fire, hybrid, NeighborList(cur))


def test_budget_exhaustion_is_reported(jammed):
    cur = jammed[1]
    affine = affine_to(cur, cur.strain + 1e-3)
    hybrid = minimize_hybrid(affine, FTOL, max_iter=5)
    assert not hybrid.converged
    assert hybrid.max_force >= FTOL
    assert hybrid.fire_iterations <= 5


def test_rejects_bad_arguments(jammed):
    with pytest.raises(ValueError):
        minimize_hybrid(jammed[0], ftol=0.0)
    with pytest.raises(ValueError):
        minimize_hybrid(jammed[0], switch=float("nan"))
    with pytest.raises(ValueError):
        HybridParameters(switch_factor=1.5)
