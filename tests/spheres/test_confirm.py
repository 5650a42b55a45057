"""The confirmation of candidate plastic steps (jamlab.spheres.confirm) and its use at fixed p.

The chain is checked on an exactly solvable branch (a quadratic potential of the strain alone,
with a kink or a jump at a known strain), where the residual of every piece is known in closed
form; so is the located verdict (two branches that overlap in strain: the start's ends at the
jump, the end's reaches back to a known strain); the ``continued`` and ``located`` rules of
fixed-pressure AQS are checked against redoing every candidate by the chain.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jamlab.analysis.avalanches import noise_floor
from jamlab.spheres.confirm import (
    jump_in_chain,
    jump_located,
    released_at_least,
    trapezoid_residual,
)
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


class Branch:
    """``V(γ)`` with modulus ``g`` below ``kink`` and ``g2`` above (continuous ``V`` and
    ``Σ = V'``), minus ``drop`` beyond ``jump``; ``advance`` counts its calls."""

    def __init__(self, g=1.0, g2=1.0, kink=np.inf, jump=np.inf, drop=0.0):
        self.g, self.g2, self.kink, self.jump, self.drop = g, g2, kink, jump, drop
        self.calls = 0

    def value(self, x):
        v = 0.5 * self.g * x * x
        s = self.g * x
        if x > self.kink:
            d = x - self.kink
            v = 0.5 * self.g * self.kink**2 + self.g * self.kink * d + 0.5 * self.g2 * d * d
            s = self.g * self.kink + self.g2 * d
        if x > self.jump:
            v -= self.drop
        return v, s

    def advance(self, x, dh):
        self.calls += 1
        v, s = self.value(x + dh)
        return x + dh, v, s, 7


def residual_of_step(b: Branch, x0: float, h: float) -> float:
    v0, s0 = b.value(x0)
    v1, s1 = b.value(x0 + h)
    return trapezoid_residual(v0, s0, v1, s1, h)


def test_trapezoid_residual_of_a_smooth_quadratic_branch_is_zero():
    # V = g x²/2 is integrated exactly by the trapezoid rule
    b = Branch(g=3.0)
    assert residual_of_step(b, 0.2, 0.05) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("a", [0.03, 0.3, 0.5, 0.77])
def test_a_kink_is_not_a_jump_and_every_piece_is_redone(a):
    h, x0 = 1e-2, 0.1
    b = Branch(g=1.0, g2=1.6, kink=x0 + a * h)
    r = residual_of_step(b, x0, h)
    # the kink's residual: −(g2 − g) h² a(1 − a)... up to sign, ∝ a(1 − a) (closed form)
    assert abs(r) == pytest.approx(0.5 * 0.6 * h * h * a * (1 - a), rel=1e-6)
    v0, s0 = b.value(x0)
    jump, its = jump_in_chain(b.advance, x0, v0, s0, h, r, 16)
    assert not jump
    assert b.calls == 16 and its == 16 * 7


@pytest.mark.parametrize("where", [0.01, 0.45, 0.99])
def test_a_jump_is_found_in_its_piece_and_the_chain_stops_there(where):
    h, x0 = 1e-2, 0.1
    b = Branch(g=1.0, g2=1.6, kink=x0 + 0.2 * h, jump=x0 + where * h, drop=1e-5)
    r = residual_of_step(b, x0, h)
    v0, s0 = b.value(x0)
    jump, its = jump_in_chain(b.advance, x0, v0, s0, h, r, 16)
    assert jump
    # the piece that contains the jump is the last one computed
    assert b.calls == int(where * 16) + 1


def test_a_jump_smaller_than_a_quarter_of_the_residual_is_a_kink():
    # the rule: one piece must keep more than |r|/4; a small jump on a strong kink does not (the
    # chain's largest piece redone smaller finds it: test_confirm_held.py)
    h, x0 = 1e-2, 0.1
    b = Branch(g=1.0, g2=3.0, kink=x0 + 0.5 * h, jump=x0 + 0.1 * h, drop=1e-7)
    r = residual_of_step(b, x0, h)
    assert 1e-7 < 0.25 * abs(r)
    v0, s0 = b.value(x0)
    assert not jump_in_chain(b.advance, x0, v0, s0, h, r, 16)[0]


@pytest.mark.parametrize(("deeper", "expected"), [(0.0, False), (1e-6, False), (1e-5, True)])
def test_a_single_step_that_lands_below_the_chains_end_is_a_jump(deeper, expected):
    # quasi-static driving (the chain) follows a kinked branch without a jump; the single step
    # landed in a minimum `deeper` below that branch's end. Its residual is the kink's plus
    # −deeper; with the single step's end given, the chain calls it a jump when the end lies
    # lower than the chain's by more than |r|/4 (the constant-volume rule: the end is not the
    # continuation of the start), and without it a kink, as before
    h, x0 = 1e-2, 0.1
    b = Branch(g=1.0, g2=1.6, kink=x0 + 0.3 * h)
    v0, s0 = b.value(x0)
    v1, s1 = b.value(x0 + h)
    v_end = v1 - deeper
    r = trapezoid_residual(v0, s0, v_end, s1, h)
    kink_only = abs(residual_of_step(b, x0, h))
    assert kink_only == pytest.approx(0.5 * 0.6 * h * h * 0.3 * 0.7, rel=1e-6)
    jump, its = jump_in_chain(b.advance, x0, v0, s0, h, r, 16, v_end=v_end)
    # |r| = 6.3e-6 + deeper: a quarter of it is above 1e-6 and below 1e-5
    assert jump == (deeper > 0.25 * abs(r)) == expected and its == 16 * 7
    assert not jump_in_chain(b.advance, x0, v0, s0, h, r, 16)[0]


class TwoBranches:
    """The start's branch ``V(γ)`` of :class:`Branch` (kink, no drop) ends at ``jump``; the
    post-event branch ``V(γ) − drop`` exists from ``back`` on for Newton (``back < jump``:
    hysteresis). ``probe((branch, γ), dh)`` follows the branch it starts on, ``None`` past its
    end; ``advance`` (FIRE) lands on the post-event branch once past ``jump``."""

    def __init__(self, jump, back, drop, g2=1.0, kink=np.inf):
        self.line = Branch(g=1.0, g2=g2, kink=kink)
        self.jump, self.back, self.drop = jump, back, drop
        self.probes: list[float] = []
        self.advances = 0

    def value(self, state):
        branch, x = state
        v, s = self.line.value(x)
        return (v - self.drop, s) if branch == "post" else (v, s)

    newton_end = np.inf  # Newton may fail short of the branch's end (below the bound)

    def probe(self, state, dh):
        branch, x = state
        x2 = x + dh
        self.probes.append(x2)
        if (branch == "pre" and x2 > min(self.jump, self.newton_end)) or (
                branch == "post" and x2 < self.back):
            return None
        return ((branch, x2), *self.value((branch, x2)))

    def advance(self, state, dh):
        self.advances += 1
        branch, x = state
        x2 = x + dh
        state = ("post" if x2 > self.jump else branch, x2)
        return (state, *self.value(state), 11)

    def verdict(self, x0, h):
        start, end = ("pre", x0), (("post" if x0 + h > self.jump else "pre"), x0 + h)
        v0, s0 = self.value(start)
        v1, s1 = self.value(end)
        r = trapezoid_residual(v0, s0, v1, s1, h)
        return r, jump_located(self.probe, self.advance, start, v0, s0, end, v1, s1, h, r, 16)


def chain_verdict(x0, h, r, **branch):
    b = Branch(g=1.0, **branch)
    v0, s0 = b.value(x0)
    return jump_in_chain(b.advance, x0, v0, s0, h, r, 16)[0]


@pytest.mark.parametrize("where", [0.02, 0.4, 0.7, 0.97])
def test_located_verdict_finds_the_piece_where_the_branch_ends(where):
    h, x0 = 1e-2, 0.1
    b = TwoBranches(jump=x0 + where * h, back=x0 - h, drop=1e-5, g2=1.6, kink=x0 + 0.3 * h)
    r, (jump, pieces) = b.verdict(x0, h)
    assert jump is True and pieces == 0 and b.advances == 0
    # bisection: 4 probes forward; one back from the end unless the jump is in the last piece
    piece = int(where * 16)
    assert len(b.probes) == 4 + (piece < 15)
    if piece < 15:
        # the probe back lands on the end of the piece that contains the jump
        assert b.probes[-1] == pytest.approx(x0 + (piece + 1) * h / 16, rel=1e-12)
    # the chain's verdict on the same step (the post-event branch is what the jump reaches)
    assert chain_verdict(x0, h, r, g2=1.6, kink=x0 + 0.3 * h, jump=x0 + where * h, drop=1e-5)


def test_located_verdict_carries_the_piece_where_the_end_branch_does_not_reach_back():
    # the end's branch exists only from 0.9 h on: the piece [6/16, 7/16] that contains the jump
    # at 0.4 h is the chain's own (one advance), and it keeps the drop
    h, x0 = 1e-2, 0.1
    b = TwoBranches(jump=x0 + 0.4 * h, back=x0 + 0.9 * h, drop=1e-5)
    r, (jump, pieces) = b.verdict(x0, h)
    assert jump and pieces == 1 and b.advances == 1 and len(b.probes) == 5
    assert chain_verdict(x0, h, r, jump=x0 + 0.4 * h, drop=1e-5)


def test_located_verdict_goes_on_with_the_chain_after_a_piece_below_the_bound():
    # Newton fails from 0.2 h on (a rearrangement below the bound, say), the jump is at 0.55 h
    # and the end's branch reaches back only to 0.9 h: the probes locate [3/16, 4/16], the chain's
    # piece there keeps nothing, and the chain goes on from 4/16 to the jump's piece, 9/16
    h, x0 = 1e-2, 0.1
    b = TwoBranches(jump=x0 + 0.55 * h, back=x0 + 0.9 * h, drop=1e-5)
    b.newton_end = x0 + 0.2 * h
    r, (jump, pieces) = b.verdict(x0, h)
    assert jump and pieces == 1 + (9 - 4) == b.advances
    assert chain_verdict(x0, h, r, jump=x0 + 0.55 * h, drop=1e-5)


def test_located_verdict_runs_the_rest_of_the_chain_where_it_carried_a_piece():
    # Newton fails from 0.2 h on (a rearrangement of 1e-9, below the bound), a kink at 0.5 h,
    # no jump; the end's branch reaches back only to 0.9 h: the chain's own piece [3/16, 4/16]
    # keeps less than the bound, so do the pieces after it and, last, the 3 before it — every
    # piece of the chain ran, once: the verdict is final (False: a kink, as the chain says)
    # and no piece is redone by the caller
    h, x0 = 1e-2, 0.1
    b = TwoBranches(jump=x0 + 0.2 * h, back=x0 + 0.9 * h, drop=1e-9, g2=1.6, kink=x0 + 0.5 * h)
    r, (jump, pieces) = b.verdict(x0, h)
    assert 1e-9 < 0.25 * abs(r)
    assert jump is False and pieces == 16 == b.advances
    assert not chain_verdict(x0, h, r, g2=1.6, kink=x0 + 0.5 * h, jump=x0 + 0.2 * h, drop=1e-9)
    # a jump in the pieces before the located one, which Newton's probes crossed (converging
    # to the post-event minimum close by) up to where they fail, 0.2 h: the located piece and
    # those after it keep nothing, the chain's first pieces find the jump (before, the caller
    # ran the whole chain again for this)
    c = TwoBranches(jump=x0 + 0.1 * h, back=x0 + 0.9 * h, drop=1e-5, g2=1.6, kink=x0 + 0.5 * h)

    def probe_across_the_jump(state, dh):
        branch, x = state
        x2 = x + dh
        c.probes.append(x2)
        if (branch == "pre" and x2 > x0 + 0.2 * h) or (branch == "post" and x2 < c.back):
            return None
        state = ("post" if x2 > c.jump else branch, x2)
        return (state, *c.value(state))

    start, end = ("pre", x0), ("post", x0 + h)
    v0, s0 = c.value(start)
    v1, s1 = c.value(end)
    rc = trapezoid_residual(v0, s0, v1, s1, h)
    jump, pieces = jump_located(probe_across_the_jump, c.advance, start, v0, s0, end, v1, s1,
                                h, rc, 16)
    # pieces: [3/16, 4/16], the 12 after it, then [0, 1/16] and [1/16, 2/16] (the jump at 0.1 h)
    assert jump is True and pieces == 1 + 12 + 2 == c.advances
    assert chain_verdict(x0, h, rc, g2=1.6, kink=x0 + 0.5 * h, jump=x0 + 0.1 * h, drop=1e-5)


def test_located_verdict_leaves_kinks_and_small_jumps_to_the_chain():
    h, x0 = 1e-2, 0.1
    # a kink, the branch never ends: 4 probes reach 15/16, the last piece keeps < |r|/4
    k = TwoBranches(jump=np.inf, back=-np.inf, drop=0.0, g2=1.6, kink=x0 + 0.5 * h)
    r, verdict = k.verdict(x0, h)
    assert abs(r) > 0 and verdict == (None, 0) and len(k.probes) == 4
    assert not chain_verdict(x0, h, r, g2=1.6, kink=x0 + 0.5 * h)
    # a jump smaller than a quarter of the residual (a strong kink elsewhere): undecided, and a
    # kink for the chain
    small = TwoBranches(jump=x0 + 0.1 * h, back=x0 - h, drop=1e-7, g2=3.0, kink=x0 + 0.5 * h)
    r, verdict = small.verdict(x0, h)
    assert 1e-7 < 0.25 * abs(r)
    assert verdict == (None, 0)
    assert not chain_verdict(x0, h, r, g2=3.0, kink=x0 + 0.5 * h, jump=x0 + 0.1 * h, drop=1e-7)


@pytest.fixture(scope="module")
def both_rules():
    r = jam(64, 3, seed=1, p_target=1e-4)
    # the chain rule redoes every candidate when it happens (its verdicts are what is compared);
    # the continued rule with its default deferral redoes only those that can be plastic (all of
    # them, whatever their residual: confirm_below=inf)
    runs = {c: shear_at_pressure(r.packing, 1e-4, pressure=1e-3, n_steps=60, confirm=c,
                                 defer_confirmation=c != "chain", confirm_below=math.inf)
            for c in ("continued", "chain", "located")}
    return r.packing, runs


def test_continued_candidates_are_kinks_when_every_candidate_is_redone(both_rules):
    _, runs = both_rules
    chain = runs["chain"]
    h, s, g = chain["enthalpy"], chain["shear_stress"], chain["gamma"]
    r = np.concatenate([[0.0], np.diff(h) - np.diff(g) * s[:-1] - 0.5 * np.diff(g) * np.diff(s)])
    candidates = np.abs(r) > 0.1 * 1e-4**2
    continued = candidates & chain.continued
    assert chain.attrs["n_candidates"] == int(candidates.sum())
    # the case has both kinds of candidate; the chain calls every continued one a kink
    assert continued.sum() >= 2 and (candidates & ~chain.continued).sum() >= 2
    assert not chain.confirmed[continued].any()
    cont = runs["continued"]
    assert cont.attrs["n_candidates_continued"] >= 2
    # a continued step used no FIRE, and a candidate not redone adds none; a step not
    # continued used FIRE or settled rattlers without it (moved together, or a caged one put
    # on the backbone: each such step counted at least once by the relaxer's counters)
    assert (cont["iterations"][cont.continued] == 0).all()
    without_fire = int((cont["iterations"][~cont.continued][1:] == 0).sum())
    assert without_fire <= (cont.attrs["n_rattlers_moved_together"]
                            + cont.attrs["n_rattler_rejoined"])
    assert (cont["iterations"][~cont.continued][1:] > 0).sum() >= 2
    np.testing.assert_array_equal(cont["plastic"], chain["plastic"])
    assert chain.attrs["confirm"] == "chain" and cont.attrs["confirm"] == "continued"


def test_located_verdicts_are_the_chains_and_carry_no_event_twice(both_rules):
    # the same run (the deferred redoing comes after the last step: identical rows), each redone
    # candidate decided on the piece where the branch ends; on this run every one of them is a
    # jump for the chain as well (no single step here lands below the quasi-static branch)
    _, runs = both_rules
    loc, cont, chain = runs["located"], runs["continued"], runs["chain"]
    assert loc.attrs["confirm"] == "located"
    for k in ("enthalpy", "shear_stress", "box_length", "z"):
        np.testing.assert_array_equal(loc[k], cont[k])
    assert loc.attrs["n_candidates_located"] >= 2 and cont.attrs["n_candidates_located"] == 0
    np.testing.assert_array_equal(loc["plastic"], chain["plastic"])
    # a located jump costs Newton probes and no second FIRE run of its event: fewer iterations
    # added to the redone rows than the chain's pieces
    redone = loc.confirmed & ~cont.continued
    assert redone.sum() >= 2
    assert loc["iterations"][redone].sum() < cont["iterations"][redone].sum()


def test_resuming_with_another_confirmation_is_refused(both_rules):
    packing, runs = both_rules
    part = shear_at_pressure(packing, 1e-4, pressure=1e-3, n_steps=3, confirm="chain")
    with pytest.raises(ValueError, match="confirm="):
        shear_at_pressure(part.packing, 1e-4, pressure=1e-3, n_steps=6, confirm="continued",
                          previous=part.trace())
    with pytest.raises(ValueError, match="confirm must be one of"):
        shear_at_pressure(packing, 1e-4, pressure=1e-3, n_steps=2, confirm="bisect")



def test_deferred_confirmation_gives_the_flags_of_the_immediate_one():
    # a candidate is redone after the run only where the run's threshold lets it be plastic; the
    # flags are those of redoing each candidate when it happens. (At N = 128, p = 1e-4,
    # δγ = 1e-4 the threshold, 10 σ of the residuals, is ~8× the candidates' floor 0.1 δγ².)
    r = jam(128, 3, seed=2, p_target=1e-4)
    late, now = (shear_at_pressure(r.packing, 1e-4, pressure=1e-4, n_steps=60,
                                   defer_confirmation=d, confirm_below=math.inf)
                 for d in (True, False))
    assert late.attrs["confirm_deferred"] == 1 and now.attrs["confirm_deferred"] == 0
    np.testing.assert_array_equal(late["plastic"], now["plastic"])
    assert late["plastic"].sum() >= 2
    skipped = late.attrs["n_candidates_below_threshold"]
    assert skipped >= 3 and now.attrs["n_candidates_below_threshold"] == 0
    assert late.attrs["n_candidates"] == now.attrs["n_candidates"]
    # the skipped candidates are those of the run's own candidates (not continued by Newton)
    # whose |r| the run's threshold rejects: not plastic either way
    h, s, g = late["enthalpy"], late["shear_stress"], late["gamma"]
    res = np.concatenate([[0.0], np.diff(h) - np.diff(g) * s[:-1]
                          - 0.5 * np.diff(g) * np.diff(s)])
    thr = late.attrs["plastic_threshold"]
    assert thr > 0.1 * 1e-4**2
    redo = (np.abs(res) > 0.1 * 1e-4**2) & ~late.continued
    redo[0] = False
    assert (redo & (np.abs(res) <= thr)).sum() == skipped
    assert not late.confirmed[np.abs(res) <= thr].any()
    # and every plastic step was redone (confirmed) in both
    assert late.confirmed[late["plastic"]].all() and now.confirmed[now["plastic"]].all()


@pytest.mark.parametrize("a", [0.0, 0.2, 0.5, 0.8, 1.0])
@pytest.mark.parametrize("stress_drop", [0.0, 3e-3, -2e-3])
def test_released_at_least_bounds_the_event_whatever_its_place_in_the_step(a, stress_drop):
    # one event at the fraction a of the step: enthalpy −S and stress −D at once, on a branch of
    # modulus G; exact V(γ) and Σ(γ), the residual from them, and the bound below S
    g, h, x0, big_s = 2.0, 1e-2, 0.1, 5e-6
    xa = x0 + a * h

    def value(x):
        v, s = 0.5 * g * x * x, g * x
        if x > xa:
            v, s = v - big_s - stress_drop * (x - xa), s - stress_drop
        return v, s

    v0, s0 = value(x0)
    v1, s1 = value(x0 + h)
    r = trapezoid_residual(v0, s0, v1, s1, h)
    least = released_at_least(np.array([r]), np.array([s1 - s0]), np.array([h]), g)[0]
    released = big_s if a < 1.0 else 0.0
    assert least <= released + 1e-15  # (rounding of V ≈ 1e-2)
    # tight where the event sits at an end of the step (a = 0: the whole step on the new branch)
    if a == 0.0:
        assert least == pytest.approx(released - (abs(stress_drop) * h if stress_drop < 0 else 0),
                                      abs=1e-15)
    # and without a stress drop it is −r itself
    if stress_drop == 0.0:
        assert least == pytest.approx(-r, abs=1e-15)


def test_candidates_that_surely_released_enough_are_jumps_without_the_confirmation():
    # the same run with every candidate confirmed (confirm_below=inf) and with the default band
    # (5): the stepping is the same (bit for bit), the candidates that released for certain more
    # than 5 max(threshold, δγ²) are not redone, and the flags are those of the full
    # confirmation (the band's premise — each of them a jump for the confirmation — checked on
    # the run itself)
    r = jam(128, 3, seed=2, p_target=1e-4)
    dg = 1e-4
    # 100 steps: two such candidates (60 had two only with the box-side guess extrapolated after
    # every step, volume_guess="always")
    full, band = (shear_at_pressure(r.packing, dg, pressure=1e-4, n_steps=100,
                                    confirm_below=k) for k in (math.inf, 5.0))
    for k in ("enthalpy", "shear_stress", "box_length", "pressure", "z", "jammed"):
        np.testing.assert_array_equal(band[k], full[k])
    assert band.attrs["confirm_below"] == 5.0 and full.attrs["confirm_below"] == math.inf
    thr = full.attrs["plastic_threshold"]
    assert band.attrs["plastic_threshold"] == thr
    h, s, g = full["enthalpy"], full["shear_stress"], full["gamma"]
    dh, ds, steps = np.diff(h) - np.diff(g) * s[:-1], np.diff(s), np.diff(g)
    res = dh - 0.5 * steps * ds
    # the modulus: the median dΣ/dγ over the run's elastic steps (the analysis' noise floor)
    modulus = noise_floor(dh, ds, steps, jammed=full["jammed"]).modulus
    least = -res - 0.5 * steps * np.abs(modulus * steps - ds)
    jammed = full["jammed"][1:] & full["jammed"][:-1]
    sure = np.concatenate([[False], (least > 5.0 * max(thr, dg**2)) & (np.abs(res) > thr)
                           & jammed & ~full.continued[1:]])
    assert sure.sum() >= 2 and band.attrs["n_candidates_sure"] == sure.sum()
    assert full.attrs["n_candidates_sure"] == 0
    # the full confirmation called each of them a jump, and the band did not redo them
    assert full.confirmed[sure].all() and not band.confirmed[sure].any()
    np.testing.assert_array_equal(band["plastic"], full["plastic"])
    # a candidate Newton continued is a kink, unless it surely released more than the band
    # (then plastic: "Jumps Newton continued through"); with every candidate confirmed
    # (confirm_below=inf) nothing is sure, and a continued candidate is a kink
    cont_sure = np.concatenate([[False], (least > 5.0 * max(thr, dg**2)) & (np.abs(res) > thr)
                                & jammed & band.continued[1:]])
    assert band.attrs["n_candidates_continued_sure"] == cont_sure.sum()
    np.testing.assert_array_equal(band["plastic"][band.continued], cont_sure[band.continued])
    assert not full["plastic"][full.continued].any()
    assert full.attrs["n_candidates_continued_sure"] == 0
    # the candidates not redone cost no confirmation iterations
    assert band["iterations"][sure].sum() < full["iterations"][sure].sum()
    with pytest.raises(ValueError, match="confirm_below must be >= 1"):
        shear_at_pressure(r.packing, dg, pressure=1e-4, n_steps=2, confirm_below=0.5)
    with pytest.raises(ValueError, match="confirm_below must be >= 1"):
        shear_at_pressure(r.packing, dg, pressure=1e-4, n_steps=2, confirm_below=math.nan)
