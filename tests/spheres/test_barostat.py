"""Fixed-pressure minimisation against an independent scan of the fixed-volume energy E*(L).

For each box side of a scan around the result, the configuration is rescaled and minimised at
fixed volume with plain FIRE; ``H(L) = E*(L) + p_t L^d`` must be smallest at the result's side
(parabola through the scan), and the slope ``−dE*/dV`` (central difference, no virial) must be the
target pressure.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jamlab.spheres import jam, minimize
from jamlab.spheres.barostat import minimize_enthalpy, rescale_box
from jamlab.spheres.packing import rescale
from jamlab.spheres.rigidity import is_jammed


@pytest.fixture(scope="module")
def packings():
    out = {}
    for seed in (1, 2):
        r = jam(32, 3, seed=seed, p_target=1e-4)
        assert r.ok
        out[seed] = r.packing
    return out


def e_star(packing, length):
    m = minimize(rescale_box(packing, length), ftol=1e-13)
    assert m.converged
    return m.energy


@pytest.mark.parametrize("seed,p_t", [(1, 1e-3), (2, 1e-3), (1, 1e-5)])
def test_enthalpy_minimum_matches_a_scan_over_the_box(packings, seed, p_t):
    start = packings[seed]
    res = minimize_enthalpy(start, p_t)
    assert res.converged
    assert res.max_force < 1e-12
    assert abs(res.pressure - p_t) <= res.tolerance
    assert res.tolerance == pytest.approx(max(1e-6 * p_t, 10e-12 * 32 / res.packing.box.volume))
    # H went down from the start (the start is a fixed-volume minimum at another volume)
    e0 = minimize(start, ftol=1e-12).energy
    assert res.enthalpy < e0 + p_t * start.box.volume
    assert is_jammed(res.packing).jammed

    L = res.packing.box.length
    d = res.packing.dim
    # scan ln L over ± a few % of the pressure (dp/dlnL ≈ −1.6 here)
    h = 0.02 * p_t
    ks = np.arange(-3, 4)
    lengths = L * np.exp(ks * h)
    H = np.array([e_star(res.packing, x) + p_t * x**d for x in lengths])
    assert np.all(H >= res.enthalpy - 1e-12 * abs(res.enthalpy))
    a, b, _ = np.polyfit(ks * h, H - res.enthalpy, 2)
    s_min = -b / (2 * a)
    assert abs(s_min) < 0.05 * h  # the scan's minimum is at the result's box, to 5 % of a step
    # −dE*/dV by a central difference at the result: the target pressure
    e_plus, e_minus = e_star(res.packing, L * math.exp(h)), e_star(res.packing, L * math.exp(-h))
    p_fd = -(e_plus - e_minus) / ((L * math.exp(h)) ** d - (L * math.exp(-h)) ** d)
    assert p_fd == pytest.approx(p_t, rel=2e-3)  # O(h²) curvature of p(L)


def test_from_an_unjammed_start(packings):
    # below φ_J: no contact carries the affine response; the box must shrink until p = p_t
    loose = minimize(rescale(packings[1], packings[1].phi * 0.99), ftol=1e-12).packing
    assert not is_jammed(loose).jammed
    res = minimize_enthalpy(loose, 1e-4)
    assert res.converged and abs(res.pressure - 1e-4) <= res.tolerance
    assert res.phi > loose.phi


def test_bad_input(packings):
    with pytest.raises(ValueError, match="> 0"):
        minimize_enthalpy(packings[1], -1e-3)
    with pytest.raises(ValueError, match="resolution floor"):
        minimize_enthalpy(packings[1], 1e-13)
    with pytest.raises(ValueError, match="ptol"):
        minimize_enthalpy(packings[1], 1e-3, ptol=0.0)
