"""The chain's largest piece redone smaller (jamlab.spheres.confirm.residual_held).

A jump keeps its released enthalpy ``S`` in the piece that holds it however short the pieces are;
a kink's residual falls at least as fast as the piece length. The chain's share rule compares a
piece with ``|r_n|``, and where the step's residual is mostly a stress drop's ``D δγ (½ − a)`` a
small jump keeps less than a quarter of it. Checked on an exactly solvable branch: a quadratic
potential of the strain alone with a kink (modulus ``g → g2``) and a jump that releases ``S`` and
drops the stress by ``D`` at known strains, where every residual is known in closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.spheres.confirm import (
    HELD_SHARE,
    HELD_SUBPIECES,
    LargestPiece,
    jump_in_chain,
    residual_held,
    trapezoid_residual,
)


class Branch:
    """``V(γ)``, ``Σ = V'``: modulus ``g`` below ``kink`` and ``g2`` above; beyond ``jump`` the
    potential is lower by ``release + stress_drop (γ − jump)`` (the stress lower by
    ``stress_drop``)."""

    def __init__(self, g=1.0, g2=1.0, kink=np.inf, jump=np.inf, release=0.0, stress_drop=0.0):
        self.g, self.g2, self.kink = g, g2, kink
        self.jump, self.release, self.stress_drop = jump, release, stress_drop
        self.calls = 0

    def value(self, x):
        v, s = 0.5 * self.g * x * x, self.g * x
        if x > self.kink:
            d = x - self.kink
            v = 0.5 * self.g * self.kink**2 + self.g * self.kink * d + 0.5 * self.g2 * d * d
            s = self.g * self.kink + self.g2 * d
        if x > self.jump:
            v -= self.release + self.stress_drop * (x - self.jump)
            s -= self.stress_drop
        return v, s

    def advance(self, x, dh):
        self.calls += 1
        return x + dh, *self.value(x + dh), 3


def chain(b: Branch, x0: float, h: float, k: int = 16):
    v0, s0 = b.value(x0)
    v1, s1 = b.value(x0 + h)
    r = trapezoid_residual(v0, s0, v1, s1, h)
    largest = LargestPiece()
    jump, _ = jump_in_chain(b.advance, x0, v0, s0, h, r, k, largest=largest)
    return r, jump, largest


def test_a_jump_under_a_large_stress_drop_holds_its_release():
    # r_n = −S − D h (½ − a): with D h/2 = 1e-6 and S = 1e-7 the step's residual is 9× S, the
    # jump's piece keeps less than a quarter of it (the chain calls it a kink), and redone in
    # four sub-pieces the one holding the jump keeps S − D (h/64)(½ − a''), closed form
    h, x0, a, release, drop = 1e-2, 0.1, 0.1, 1e-7, 2e-4
    b = Branch(jump=x0 + a * h, release=release, stress_drop=drop)
    r, jump, largest = chain(b, x0, h)
    assert r == pytest.approx(-release - drop * h * (0.5 - a), rel=1e-9)
    assert not jump
    # the piece holding the jump: piece 2 (a' = 0.6), its residual −S − D (h/16)(½ − 0.6)
    assert largest.residual == pytest.approx(-release + drop * h / 16 * 0.1, rel=1e-6)
    assert abs(largest.residual) < 0.25 * abs(r)
    calls = b.calls
    held, its = residual_held(b.advance, largest)
    # sub-piece 3 of 4 (a'' = 2.4 − 2 = 0.4): −S − D (h/64)(½ − 0.4)
    assert held == pytest.approx(release + drop * h / 64 * 0.1, rel=1e-6)
    assert b.calls - calls == 3 and its == 9  # it stops at the sub-piece that holds


@pytest.mark.parametrize("a", [0.01, 0.03, 0.3, 0.52, 0.77, 0.999])
@pytest.mark.parametrize("g2", [0.2, 1.6, 5.0])
def test_a_kink_does_not_hold(a, g2):
    # a kink's residual in a piece of length l at fraction a' is ½ |g2 − g| l² a'(1 − a'): in a
    # sub-piece of l/4 at most a quarter of the piece's (a' → 0), so below HELD_SHARE
    h, x0 = 1e-2, 0.1
    b = Branch(g2=g2, kink=x0 + a * h)
    r, jump, largest = chain(b, x0, h)
    assert not jump and abs(largest.residual) > 0
    held, _ = residual_held(b.advance, largest)
    assert held == 0.0
    assert HELD_SHARE > 1.0 / HELD_SUBPIECES


def test_a_small_jump_on_a_strong_kink_holds():
    # the chain's documented blind spot (test_confirm.py): a jump of 1e-7 in a step whose residual
    # is a kink's 2.5e-5; the kink sits on a piece boundary, so the largest piece is the jump's
    h, x0 = 1e-2, 0.1
    b = Branch(g=1.0, g2=3.0, kink=x0 + 0.5 * h, jump=x0 + 0.1 * h, release=1e-7)
    r, jump, largest = chain(b, x0, h)
    assert not jump and 1e-7 < 0.25 * abs(r)
    held, _ = residual_held(b.advance, largest)
    assert held == pytest.approx(1e-7, rel=1e-6)


def test_a_chain_with_no_piece_seen_holds_nothing():
    # a chain that computed no piece (LargestPiece() as made) gives nothing to redo
    b = Branch(g=2.0)
    assert residual_held(b.advance, LargestPiece()) == (0.0, 0) and b.calls == 0
