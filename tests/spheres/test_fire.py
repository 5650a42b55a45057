"""FIRE: convergence to max|F_i| < 1e-12, honest non-convergence, neighbour-list reuse."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spheres_brute import brute_force, wrap

import jamlab.spheres as sp
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.io import read_lammps_positions
from reference_data import REFERENCE


def test_fire_reaches_1e12_from_random_start_n1000_3d():
    p = sp.random_packing(1000, 3, 0.8, seed=2024)
    r = minimize(p, ftol=1e-12)
    assert r.converged, r
    assert r.max_force < 1e-12
    # independent check of the residual: brute force over all pairs and images
    ref = brute_force(r.packing.positions, r.packing.box.length, 0.0)
    assert np.sqrt((ref["forces"] ** 2).sum(axis=1)).max() < 1.5e-12
    assert r.energy == pytest.approx(ref["energy"], rel=1e-12)
    assert r.energy < sp.energy(p)


@pytest.mark.parametrize(("dim", "n", "strain"), [(2, 400, 0.3), (4, 300, 1.3), (3, 200, 0.7)])
def test_fire_converges_other_dimensions_and_strains(dim, n, strain):
    p = sp.random_packing(n, dim, 0.85, seed=dim)
    p = sp.Packing(p.positions, p.box.with_strain(strain))
    r = minimize(p)
    assert r.converged and r.max_force < 1e-12
    assert sp.max_force(r.packing) < 1e-12
    w = r.packing.wrapped()
    assert sp.energy(w) == pytest.approx(r.energy, rel=1e-12)


def test_original_fire_variant_converges():
    p = sp.random_packing(200, 3, 0.8, seed=3)
    r = minimize(p, params=FireParameters(variant="fire"))
    assert r.converged and sp.max_force(r.packing) < 1e-12


def test_non_convergence_is_reported():
    p = sp.random_packing(200, 3, 0.8, seed=3)
    r = minimize(p, max_iter=10)
    assert not r.converged
    assert r.iterations == 10
    assert r.max_force >= 1e-12
    assert r.max_force == pytest.approx(sp.max_force(r.packing), rel=1e-10)


def test_bad_arguments():
    p = sp.random_packing(50, 3, 0.5, seed=3)
    with pytest.raises(ValueError, match="ftol"):
        minimize(p, ftol=0.0)
    with pytest.raises(ValueError, match="max_iter"):
        minimize(p, max_iter=-1)
    with pytest.raises(ValueError, match="variant"):
        FireParameters(variant="lbfgs")


def test_neighbor_list_reuse_across_strain_steps():
    """AQS-like use: one list follows affine steps and minimisations; results equal fresh ones."""
    p = minimize(sp.random_packing(300, 3, 0.8, seed=11)).packing
    nl = sp.NeighborList(p)
    for _ in range(3):
        p = sp.affine_shear(p, 1e-3)
        r = minimize(p, neighbors=nl)
        fresh = minimize(p)
        assert r.converged and fresh.converged
        assert r.energy == pytest.approx(fresh.energy, rel=1e-10)
        assert sp.shear_stress(r.packing, nl) == pytest.approx(
            sp.shear_stress(r.packing), rel=1e-12
        )
        p = r.packing


def test_returns_to_lammps_minimum_after_small_kick():
    folder = REFERENCE / "lammps-aqs-n500-phi0.80-1000steps"
    p = read_lammps_positions(folder / "positions.txt")
    e_lammps = float((folder / "trace.csv").read_text().splitlines()[1].split(",")[2])
    assert json.loads((folder / "meta.json").read_text())["n"] == p.n
    r0 = minimize(p)
    assert r0.converged and r0.iterations == 0  # already below 1e-12
    kicked = p.with_positions(p.positions + np.random.default_rng(0).normal(0, 1e-6, (p.n, 3)))
    r = minimize(kicked)
    assert r.converged
    assert r.energy == pytest.approx(e_lammps, rel=1e-10)



def _reference_fire(pos, L, gamma, stops, par):
    """FIRE 2.0 (Guénolé et al. 2020, Algorithm 2, with the displacement cap of the module
    docstring) step by step in plain numpy, forces by brute force over all pairs and images:
    the positions after each number of steps in ``stops``, and how many steps were restarts
    (``P = F·v ≤ 0``)."""
    x = np.array(pos, dtype=float)

    def force(x):
        return brute_force(wrap(x, L, gamma), L, gamma)["forces"]

    f = force(x)
    v = np.zeros_like(x)
    dt, alpha, n_pos, n_neg = par.dt, par.alpha0, 0, 0
    power, restarts, out = 0.0, 0, {}
    for it in range(1, max(stops) + 1):
        if power > 0:
            n_pos, n_neg = n_pos + 1, 0
            if n_pos > par.n_delay:
                dt, alpha = min(dt * par.f_inc, par.dt_max), alpha * par.f_alpha
        else:
            n_pos, n_neg = 0, n_neg + 1
            restarts += it > 1
            fire2 = par.variant == "fire2"
            if it >= par.n_delay or not fire2:  # the 2006 variant has no initial delay
                if dt * par.f_dec >= par.dt_min:
                    dt *= par.f_dec
                alpha = par.alpha0
            if fire2:  # nor the half step back
                x = x - 0.5 * dt * v
            v = np.zeros_like(x)
        v = v + dt * f
        c1, c2 = 1.0 - alpha, alpha * np.linalg.norm(v) / np.linalg.norm(f)
        bound = c1 * np.linalg.norm(v, axis=1).max() + c2 * np.linalg.norm(f, axis=1).max()
        step = min(dt, par.dmax / bound)
        v = c1 * v + c2 * f
        x = x + step * v
        f = force(x)
        power = float(np.sum(f * v))
        if it in stops:
            out[it] = x.copy()
    return out, restarts


@pytest.mark.parametrize(("dim", "n", "strain", "variant"),
                         [(3, 64, 0.0, "fire2"), (3, 80, 0.37, "fire2"), (2, 60, 0.2, "fire2"),
                          (3, 64, 0.0, "fire")])
def test_compiled_loop_follows_the_textbook_algorithm(dim, n, strain, variant):
    """The compiled loop (one pass fewer per step: the next kick made in the force pass, P's
    components summed apart) against Algorithm 2 written out in numpy with brute-force forces,
    after 1 to 300 steps from a random start (restarts with their half step back, the delay,
    the displacement cap, Δt growing to Δt_max); FIRE 2.0 and the 2006 variant."""
    p = sp.random_packing(n, dim, 0.9, seed=7 + dim)
    p = sp.Packing(p.positions, p.box.with_strain(strain))
    par = FireParameters(variant=variant)
    L = p.box.length
    stops = (1, 2, 25, 90, 300)
    ref, restarts = _reference_fire(p.positions, L, strain, stops, par)
    assert restarts >= 1  # the restart branch is exercised
    for steps in stops:
        r = minimize(p, ftol=1e-300, max_iter=steps, params=par)
        assert r.iterations == steps
        x = ref[steps]
        dx = p.box.minimum_image(r.packing.positions - x)
        assert np.abs(dx).max() < 1e-11 * max(1.0, np.abs(x).max()), (steps, np.abs(dx).max())
        assert r.energy == pytest.approx(brute_force(wrap(x, L, strain), L, strain)["energy"],
                                         rel=1e-11)
