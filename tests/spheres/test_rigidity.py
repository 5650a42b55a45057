"""The jammed flag against an independent brute force: contacts over every pair and every periodic
image (``spheres_brute``), rattlers removed one particle at a time from a work queue (not the
sweep of ``remove_rattlers``), pressure from the brute-force virial, and the floor
``10 ftol N / L^d`` written out here."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from spheres_brute import brute_jammed_state as brute_state
from spheres_brute import pair_terms

from jamlab.spheres import Box, Packing, jam, minimize
from jamlab.spheres.packing import rescale
from jamlab.spheres.rigidity import is_jammed, jammed_verdict, pressure_floor


def check_against_brute(packing: Packing, ftol: float = 1e-12):
    s = is_jammed(packing, ftol)
    b = brute_state(packing, ftol)
    assert s.n_backbone == b["n_kept"]
    assert s.n_contacts_backbone == b["n_c"]
    # 1 − r of an overlap ~1e-13 carries rounding ~1e-16 per pair: an absolute tolerance
    assert s.pressure == pytest.approx(b["p"], rel=1e-10, abs=1e-15)
    assert s.p_floor == pytest.approx(b["floor"], rel=1e-14)
    assert s.jammed == b["jammed"]
    return s


@pytest.fixture(scope="module")
def jammed32():
    r = jam(32, 3, seed=1, p_target=1e-4)
    assert r.ok
    return r.packing


def test_jammed_packing_at_p_1e4(jammed32):
    s = check_against_brute(jammed32)
    assert s.jammed and s.reason == ""
    assert 5e-5 < s.pressure < 2e-4
    assert s.excess == 0  # jam stops on an isostatic backbone


@pytest.mark.parametrize("seed,factor", [(1, 1 - 2e-4), (2, 1 - 1e-4)])
def test_unjammed_after_decompression(seed, factor):
    # just below φ_J: overlaps survive the affine step, FIRE removes them to ftol
    r = jam(32, 3, seed=seed, p_target=1e-4)
    m = minimize(rescale(r.packing, r.packing.phi * factor), ftol=1e-12)
    assert m.converged and m.energy > 0  # residual overlaps at the ftol resolution
    s = check_against_brute(m.packing)
    assert not s.jammed and s.n_backbone == 0
    # the residual pressure of the floppy minimum is far below the floor (docs/aqs.md)
    assert 0 < s.pressure < 0.1 * s.p_floor


def test_floppy_chain_with_pressure_is_not_jammed():
    # a compressed straight chain along x through the periodic box: forces balance exactly and
    # p > 0, but each particle has 2 contacts (< d + 1): a floppy, self-stressed line
    n, L = 8, 7.6  # spacing 0.95 < 1
    pos = np.zeros((n, 3))
    pos[:, 0] = np.arange(n) * L / n
    pos[:, 1] = pos[:, 2] = L / 2
    chain = Packing(pos, Box(L, 3))
    s = check_against_brute(chain)
    assert s.pressure > 1e3 * s.p_floor
    assert not s.jammed and s.n_backbone == 0


def test_hypostatic_backbone_is_not_jammed(jammed32):
    # remove a backbone particle with exactly d + 1 contacts whose neighbours keep >= d + 1:
    # N_c' drops by 4, d(N' - 1) by 3, so the backbone is one contact short (still stressed)
    b = brute_state(jammed32, 1e-12)
    pos = jammed32.wrapped().positions
    i, j, _ = pair_terms(pos, jammed32.box.length, jammed32.strain)
    deg = np.bincount(np.concatenate([i, j]), minlength=jammed32.n)
    for k in range(jammed32.n):
        partners = np.concatenate([j[i == k], i[j == k]])
        if deg[k] == 4 and np.all(deg[partners] >= 5):
            break
    else:
        pytest.skip("no removable buckler in this packing")
    smaller = Packing(np.delete(pos, k, axis=0), jammed32.box)
    s = check_against_brute(smaller)
    assert b["jammed"] and not s.jammed
    assert s.excess == -1 and s.pressure > s.p_floor
    # with a particle gone its neighbours' forces no longer balance: not a minimum either; the
    # count alone (condition 2) rejects it as well
    assert "not a minimum" in s.reason
    assert "hypostatic" in jammed_verdict(3, s.n_backbone, s.n_contacts_backbone, s.pressure,
                                         s.p_floor)


def test_a_configuration_that_is_not_a_minimum_is_not_judged():
    """Overlapping random spheres: a dense backbone above isostatic and a large pressure pass
    conditions 1–3, but the forces do not balance (max|F_i| ≫ ftol), so no verdict of rigidity
    is given: not jammed, "not a minimum" (the brute force sums the pair forces)."""
    from jamlab.spheres import random_packing

    p = random_packing(16, 2, 1.2, 0)
    s = check_against_brute(p)
    b = brute_state(p, 1e-12)
    assert b["max_force"] > 1.0 and b["n_c"] >= 2 * (b["n_kept"] - 1) + 1 and b["p"] > b["floor"]
    assert not s.jammed and s.reason.startswith("not a minimum")


def test_pressure_below_the_floor_of_a_coarse_ftol(jammed32):
    # the same jammed packing, judged at a tolerance whose floor exceeds its pressure
    ftol = 1e-4
    s = check_against_brute(jammed32, ftol)
    assert s.excess == 0 and s.pressure < s.p_floor and not s.jammed
    assert "floor" in s.reason


def test_floor_formula_and_bad_ftol():
    assert pressure_floor(100, 3, 5.0, 1e-12) == pytest.approx(10 * 1e-12 * 100 / 125)
    with pytest.raises(ValueError, match="ftol"):
        pressure_floor(100, 3, 5.0, 0.0)


def test_sheared_frame_is_handled(jammed32):
    # the flag does not depend on the Lees–Edwards representative: at γ = 1 the periodic
    # lattice is the one of γ = 0, so the same positions are the same minimum
    moved = replace(jammed32, box=jammed32.box.with_strain(1.0))
    a, b = is_jammed(jammed32), check_against_brute(moved)
    assert (a.jammed, a.n_contacts_backbone) == (b.jammed, b.n_contacts_backbone)
