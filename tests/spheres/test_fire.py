"""FIRE: convergence to max|F_i| < 1e-12, honest non-convergence, neighbour-list reuse."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spheres_brute import brute_force

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
