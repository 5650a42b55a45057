"""The Newton inner minimiser of fixed-pressure AQS (:mod:`jamlab.spheres.newton_relax`).

Compared with FIRE (an independent minimiser, no shared iteration): from the same starts both
must reach the same minimum, and whole fixed-pressure runs with either must record the same
rows and flags. The Newton path must actually be taken (its counters), and it must hand over to
FIRE where it does not apply.
"""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.spheres import jam
from jamlab.spheres.barostat import rescale_box
from jamlab.spheres.box import Box
from jamlab.spheres.contacts import backbone_mask
from jamlab.spheres.fire import minimize
from jamlab.spheres.newton_relax import (
    NewtonRelaxer,
    free_rattlers,
    minimize_rattlers,
    settle_rattlers,
)
from jamlab.spheres.potential import affine_shear, contacts, evaluate
from jamlab.spheres.pressure_shear import shear_at_pressure
from jamlab.spheres.state import Packing


@pytest.fixture(scope="module")
def minimum():
    # jam, then brought to p = 1e-3 by the (FIRE) enthalpy minimisation
    r = jam(64, 3, seed=3, p_target=1e-3)
    first = shear_at_pressure(r.packing, 1e-6, pressure=1e-3, n_steps=1, minimizer="fire")
    assert first["converged"].all() and first["jammed"].all()
    return first.packing


def _same_minimum(a, b, tol=1e-9):
    """Same minimum up to a global translation (Newton pins one particle, FIRE does not) and
    the rattlers (each anywhere in its cage where it overlaps nothing)."""
    ci, cj, _ = contacts(b)
    bb = backbone_mask(ci, cj, b.n, b.dim + 1)
    u = a.box.minimum_image(a.positions - b.positions)[bb]
    u -= u.mean(axis=0)
    assert np.max(np.abs(u)) < tol
    ea, eb = evaluate(a), evaluate(b)
    assert ea.max_force < 1e-12 and eb.max_force < 1e-12
    assert abs(ea.energy - eb.energy) <= 1e-12 * abs(eb.energy)


def test_first_call_is_fire_then_newton_finds_fires_minimum(minimum):
    relax = NewtonRelaxer()
    first = relax(minimum)  # no reference minimum yet: FIRE
    assert first.converged and relax.counters["n_fire_fallbacks"] == 1
    cur = first.packing
    for k in range(6):
        # a small shear and a small rescaling, as one inner problem of a fixed-pressure step
        start = rescale_box(affine_shear(cur, 2e-6), cur.box.length * (1 + 1e-7 * (-1) ** k))
        newton = relax(start)
        fire = minimize(start)
        assert newton.converged and newton.iterations == 0  # no FIRE iteration was spent
        _same_minimum(newton.packing, fire.packing)
        cur = newton.packing
    # (the first call's FIRE was finished by Newton, which counts as an accepted Newton call)
    assert relax.counters["n_fire_finished_by_newton"] == 1
    assert relax.counters["n_newton_accepted"] == 6 + 1


def test_contact_changes_are_followed(minimum):
    """A larger shear changes contacts inside the step; the active set follows them."""
    relax = NewtonRelaxer()
    cur = relax(minimum).packing
    changed = 0
    for _ in range(10):
        start = affine_shear(cur, 1e-4)
        newton = relax(start)
        fire = minimize(start)
        assert newton.converged
        if newton.iterations == 0:  # taken by Newton: must be FIRE's minimum
            _same_minimum(newton.packing, fire.packing)
            before = {tuple(p) for p in np.column_stack(contacts(cur)[:2])}
            after = {tuple(p) for p in np.column_stack(contacts(newton.packing)[:2])}
            changed += before != after
        cur = fire.packing
    assert relax.counters["n_newton_accepted"] >= 5
    assert changed >= 1 and relax.counters["n_contact_changes"] >= 1


def test_reset_forgets_the_reference(minimum):
    relax = NewtonRelaxer()
    relax(minimum)
    relax.reset()
    assert relax.reference is None and relax.fac is None
    relax(affine_shear(minimum, 1e-6))
    assert relax.counters["n_fire_fallbacks"] == 2


def test_fixed_pressure_runs_agree_with_fire(minimum):
    kw = dict(pressure=1e-3, n_steps=40)
    a = shear_at_pressure(minimum, 1e-4, minimizer="newton", **kw)
    b = shear_at_pressure(minimum, 1e-4, minimizer="fire", **kw)
    assert a.attrs["n_newton_accepted"] > a.attrs["n_fire_fallbacks"]
    assert a.attrs["minimizer"] == "enthalpy-nested-newton"
    assert b.attrs["minimizer"] == "enthalpy-nested-fire"
    np.testing.assert_array_equal(a["plastic"], b["plastic"])
    np.testing.assert_array_equal(a["jammed"], b["jammed"])
    assert np.all(a["converged"])
    tol = a.columns["pressure"] * 0 + 1e-6 * 1e-3
    assert np.all(np.abs(a["pressure"] - 1e-3) <= np.maximum(tol, 1.2e-11))
    np.testing.assert_allclose(a["enthalpy"], b["enthalpy"], rtol=1e-11, atol=0)
    np.testing.assert_allclose(a["box_length"], b["box_length"], rtol=1e-9, atol=0)
    # both stop somewhere inside |p − p_t| ≤ ptol p_t (ptol = 1e-6): the stress agrees to that
    np.testing.assert_allclose(a["shear_stress"], b["shear_stress"], rtol=1e-5, atol=0)


def test_bad_minimizer_name(minimum):
    with pytest.raises(ValueError, match="minimizer must be one of"):
        shear_at_pressure(minimum, 1e-4, pressure=1e-3, n_steps=2, minimizer="cg")
    with pytest.raises(ValueError, match="refactor_every"):
        NewtonRelaxer(refactor_every=0)


def _cage(gap: float) -> Packing:
    """A rattler (particle 0) at the centre of a cage of two walls along ±x, each overlapping
    it by 1e-4, and four particles along ±y, ±z at distance ``1 + gap`` from it."""
    pos = [[5.0, 5.0, 5.0]]
    for axis in range(3):
        for sign in (1.0, -1.0):
            p = [5.0, 5.0, 5.0]
            p[axis] += sign * ((1.0 - 1e-4) if axis == 0 else (1.0 + gap))
            pos.append(p)
    return Packing(np.array(pos), Box(10.0, 3))


def _overlaps_of(pk, i):
    dr = pk.box.minimum_image(pk.positions[i] - pk.positions)
    r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
    r[i] = np.inf
    return np.flatnonzero(r < 1.0)


def test_free_rattlers_leaves_a_cage_sideways():
    """Opposite overlaps: the pushes cancel; the way out is sideways, where the cage has room
    (brute force: no pair of the rattler overlaps afterwards; the walls do not move)."""
    pk = _cage(gap=0.05)
    assert _overlaps_of(pk, 0).size == 2
    backbone = np.array([False] + [True] * 6)
    out = free_rattlers(pk, backbone)
    assert out is not None
    assert _overlaps_of(out, 0).size == 0
    np.testing.assert_array_equal(out.positions[1:], pk.positions[1:])
    assert np.max(np.abs(out.positions[0] - pk.positions[0])) < 0.05


def test_free_rattlers_reports_a_tight_cage():
    """No room sideways (the side particles overlap it too, all around): cannot be freed."""
    pk = _cage(gap=-1e-4)
    assert _overlaps_of(pk, 0).size == 6
    assert free_rattlers(pk, np.array([False] + [True] * 6)) is None


def test_newton_only_fails_where_the_relaxer_hands_over_to_fire(minimum):
    """The probe of the located confirmation: where the relaxer's Newton reaches a minimum,
    ``newton_only`` reaches the same one; where the relaxer gives the problem to FIRE (the
    branch of the parent ends: an event), it reports no convergence, returns the start
    untouched and spends no FIRE iteration."""
    cur = minimum
    took = failed = 0
    for _ in range(40):
        start = affine_shear(cur, 5e-4)
        full, probe = NewtonRelaxer(), NewtonRelaxer()
        ref = full(start, parent=cur)
        got = probe.newton_only(start, parent=cur)
        assert probe.counters["n_fire_fallbacks"] == 0
        if full.counters["n_fire_fallbacks"]:
            assert not got.converged and got.packing is start and got.iterations == 0
            failed += 1
        else:
            assert got.converged
            _same_minimum(got.packing, ref.packing, tol=1e-12)
            took += 1
        cur = ref.packing
        if took >= 3 and failed >= 2:
            break
    assert took >= 3 and failed >= 2


def test_a_fire_fallback_finished_by_newton_reaches_fires_minimum(minimum):
    """Where Newton gives a start up (an event), FIRE runs to ``finish_below`` and Newton
    finishes from there: the same minimum as FIRE all the way to ``ftol`` (energy to 1e-12
    relative, positions up to the flat directions), forces below ``ftol``, FIRE's iterations
    counted, and ``finish_below=None`` is FIRE alone."""
    cur = minimum
    finished = 0
    for _ in range(40):
        start = affine_shear(cur, 5e-4)
        hybrid, plain = NewtonRelaxer(), NewtonRelaxer(finish_below=None)
        got = hybrid(start, parent=cur)
        ref = plain(start, parent=cur)
        assert plain.counters["n_fire_finished_by_newton"] == 0
        if hybrid.counters["n_fire_fallbacks"]:
            assert plain.counters["n_fire_fallbacks"] == 1
            assert got.converged and got.iterations > 0
            _same_minimum(got.packing, ref.packing, tol=1e-6)
            if hybrid.counters["n_fire_finished_by_newton"]:
                assert got.iterations < ref.iterations
                finished += 1
        cur = ref.packing
        if finished >= 3:
            break
    assert finished >= 3


def _pair_cage(wall_gap: float) -> tuple[Packing, np.ndarray]:
    """Two rattlers (0 and 1) on the x axis, overlapping each other by 2e-3, between walls: 0
    touches a wall on its left, 1 has ``wall_gap`` to spare on its right before the other wall;
    four side particles around each, ``1 + 1e-3`` away (along ±y, ±z for 0; turned by 45° about
    the axis for 1, clear of 0's), hold them on the axis. Only the rattlers overlap."""
    a, b = 5.0, 5.998
    pos = [[a, 5.0, 5.0], [b, 5.0, 5.0], [a - 1.0, 5.0, 5.0], [b + 1.0 + wall_gap, 5.0, 5.0]]
    for x, turn in ((a, 0.0), (b, np.pi / 4)):
        for k in range(4):
            t = turn + k * np.pi / 2
            pos.append([x, 5.0 + 1.001 * np.cos(t), 5.0 + 1.001 * np.sin(t)])
    backbone = np.ones(len(pos), dtype=bool)
    backbone[:2] = False
    return Packing(np.array(pos), Box(12.0, 3)), backbone


def test_rattlers_that_block_each_other_are_freed_together():
    """Moved one at a time, rattler 0 (first) is pressed into its wall by 1 and stays caged;
    moved together, 1 steps aside and both are free (room 2e-3 > their overlap). Checked by the
    independent full evaluation: no force anywhere, the held particles untouched."""
    pk, backbone = _pair_cage(wall_gap=4e-3)
    assert free_rattlers(pk, backbone) is None  # one at a time: caged
    settled, caged = settle_rattlers(pk, backbone)
    assert caged
    out, worst = minimize_rattlers(settled, backbone, ftol=1e-12)
    assert worst < 1e-12
    assert evaluate(out).max_force < 1e-12
    np.testing.assert_array_equal(out.positions[2:], pk.positions[2:])
    # the pair's separation is a contact exactly (the room is larger than the overlap)
    assert 1.0 - 1e-12 < out.positions[1, 0] - out.positions[0, 0]


def test_rattlers_without_room_stay_caged():
    """No room: the walls are 3 - 3e-3 apart where the chain wall–0–1–wall needs 3 (1's wall
    sits 1 - 1e-3 from 1, which overlaps 0 by 2e-3). Together they cannot be freed: at the
    minimum over their places the three overlaps along the axis are equal, 1e-3 each, and each
    contact carries the force 2 h / σ = 2e-3 (V = h²) while the rattlers' net forces vanish."""
    pk, backbone = _pair_cage(wall_gap=-1e-3)
    out, worst = minimize_rattlers(pk, backbone, ftol=1e-12)
    assert worst == pytest.approx(2e-3, rel=1e-6)
    assert np.max(np.abs(evaluate(out).forces[:2])) < 1e-12
    np.testing.assert_array_equal(out.positions[2:], pk.positions[2:])


def test_a_caged_rattler_rejoins_by_newton_at_fires_minimum(minimum):
    """Where a rattler is caged at the backbone's minimum, the rattlers are moved together and
    Newton runs once more with the caged one on the backbone, before FIRE would polish: the
    same minimum as FIRE from the same start (energy to 1e-12, positions up to translation and
    the rattlers), no FIRE iteration. The steps are fixed-box shears of 1e-4 from the module's
    minimum, where the fifth is such a step."""
    relax = NewtonRelaxer()
    cur = relax(minimum).packing
    seen = 0
    for _ in range(8):
        start = affine_shear(cur, 1e-4)
        before = relax.counters["n_rattler_rejoined"] + relax.counters["n_rattlers_moved_together"]
        got = relax(start, parent=cur)
        after = relax.counters["n_rattler_rejoined"] + relax.counters["n_rattlers_moved_together"]
        if after > before:
            assert got.converged and got.iterations == 0
            _same_minimum(got.packing, minimize(start).packing, tol=1e-6)
            seen += 1
        cur = got.packing
    assert seen >= 1 and relax.counters["n_rattler_polish"] == 0
    # with the option off, FIRE polishes there instead
    plain = NewtonRelaxer(settle_caged=False)
    cur = plain(minimum).packing
    for _ in range(8):
        cur = plain(affine_shear(cur, 1e-4), parent=cur).packing
    assert plain.counters["n_rattler_polish"] >= 1
    assert plain.counters["n_rattler_rejoined"] == plain.counters["n_rattlers_moved_together"] == 0
