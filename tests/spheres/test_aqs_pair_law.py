"""AQS shear beyond the paper's system: Hertzian contacts (α = 5/2), bidisperse and polydisperse
packings. Checks that do not use jamlab's own classification: the trapezoid rule along elastic
branches (Σ = dE/dγ), converging at second order in δγ, and plain FIRE's minima."""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.spheres.aqs import shear
from jamlab.spheres.packing import prepare


def _integrated_residual(tr) -> float:
    """``E(γ_end) − E(γ_0) − ∫ Σ dγ`` with the trapezoid rule over the trace's steps."""
    e, s, g = tr.energy, tr.shear_stress, tr.gamma
    return float((e[-1] - e[0]) - np.sum(0.5 * np.diff(g) * (s[1:] + s[:-1])))


@pytest.mark.parametrize("seed", [2, 3])
def test_hertzian_elastic_steps_obey_the_trapezoid_rule(seed):
    """3D Hertzian UNSAT packing (φ = 0.7): over the same strain interval, halving δγ divides
    the integrated trapezoid residual by ≈ 4 (second order: Σ is the derivative of E along the
    branch); at the finest step it is below 1e-5 of the energy change (a relative error ε in
    Σ would leave ε ΔE)."""
    res = prepare(128, 3, 0.7, seed, alpha=2.5)
    assert res.ok, res.reason
    residuals, de = [], None
    for k in (1, 2, 4):
        tr = shear(res.packing, 2e-4 / k, n_steps=10 * k).trace
        assert not tr.plastic.any()  # a smooth branch over [0, 2e-3] for these seeds
        assert np.all(tr.max_force < 1e-12)
        residuals.append(_integrated_residual(tr))
        de = tr.energy[-1] - tr.energy[0]
    ratios = [residuals[i] / residuals[i + 1] for i in range(2)]
    assert all(3.0 < r < 8.0 for r in ratios), (residuals, ratios)
    assert abs(residuals[-1]) < 1e-5 * abs(de)


def test_hertzian_fast_path_equals_plain_fire():
    """φ = 0.7, α = 5/2, N = 128, 60 steps of 1e-4: the fast path and plain FIRE reach the same
    minima (energies to 1e-10) and flag the same plastic steps."""
    res = prepare(128, 3, 0.7, 1, alpha=2.5)
    fast = shear(res.packing, 1e-4, n_steps=60).trace
    fire = shear(res.packing, 1e-4, n_steps=60, minimizer="fire").trace
    assert fast.plastic.sum() >= 1  # the run crosses at least one avalanche
    np.testing.assert_array_equal(fast.plastic, fire.plastic)
    np.testing.assert_allclose(fast.energy, fire.energy, rtol=1e-10, atol=0)


@pytest.mark.parametrize("dim,sizes", [(2, "bidisperse"), (3, "polydisperse:0.15")])
def test_size_disperse_shear_runs_and_matches_fire(dim, sizes):
    res = prepare(96, dim, 0.9 if dim == 2 else 0.72, 4, sizes=sizes)
    assert res.ok, res.reason
    fast = shear(res.packing, 1e-4, n_steps=40).trace
    fire = shear(res.packing, 1e-4, n_steps=40, minimizer="fire").trace
    np.testing.assert_array_equal(fast.plastic, fire.plastic)
    np.testing.assert_allclose(fast.energy, fire.energy, rtol=1e-10, atol=0)
    assert np.all(fast.max_force < 1e-12)
