"""The confirmation of candidate plastic steps (jamlab.spheres.confirm) and its use at fixed p.

The chain is checked on an exactly solvable branch (a quadratic potential of the strain alone,
with a kink or a jump at a known strain), where the residual of every piece is known in closed
form; the ``continued`` rule of fixed-pressure AQS is checked against redoing every candidate.
"""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.spheres.confirm import jump_in_chain, trapezoid_residual
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
    # the rule: one piece must keep more than |r|/4; a small jump on a strong kink does not
    h, x0 = 1e-2, 0.1
    b = Branch(g=1.0, g2=3.0, kink=x0 + 0.5 * h, jump=x0 + 0.1 * h, drop=1e-7)
    r = residual_of_step(b, x0, h)
    assert 1e-7 < 0.25 * abs(r)
    v0, s0 = b.value(x0)
    assert not jump_in_chain(b.advance, x0, v0, s0, h, r, 16)[0]


@pytest.fixture(scope="module")
def both_rules():
    r = jam(64, 3, seed=1, p_target=1e-4)
    # the chain rule redoes every candidate when it happens (its verdicts are what is compared);
    # the continued rule with its default deferral redoes only those that can be plastic
    runs = {c: shear_at_pressure(r.packing, 1e-4, pressure=1e-3, n_steps=60, confirm=c,
                                 defer_confirmation=c == "continued")
            for c in ("continued", "chain")}
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
    # a continued step used no FIRE, and a candidate not redone adds none
    assert (cont["iterations"][cont.continued] == 0).all()
    assert (cont["iterations"][~cont.continued][1:] > 0).all()
    np.testing.assert_array_equal(cont["plastic"], chain["plastic"])
    assert chain.attrs["confirm"] == "chain" and cont.attrs["confirm"] == "continued"


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
                                   defer_confirmation=d) for d in (True, False))
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
