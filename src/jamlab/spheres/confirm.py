"""Jump or kink: the confirmation of a candidate plastic step by redoing it in smaller steps.

A step ``γ → γ + h`` from a minimum is a *candidate* when its trapezoid residual
``r = ΔV − ½ h (Σ_0 + Σ_1)`` (``V`` the potential minimised — the enthalpy at fixed pressure, the
energy at constant volume —, ``Σ = ∂V/∂γ`` the shear stress; :func:`trapezoid_residual`) is too
large for a smooth branch. Two things give that: a **jump** (the minimum is left: the residual is
the event's own ``−S``, independent of the step length) and a **kink** (a contact opens or
closes on the branch: the stiffness changes inside the step and ``r ~ ΔG h²``). Redone in pieces of
length ``h/k`` from the same minimum, a jump keeps its residual in the one piece that contains it,
while a kink leaves at most ``≈ r/k`` in any piece: for a kink at fraction ``a`` of the step
``r ∝ h² a(1 − a)`` and the piece containing it (at fraction ``a' = ka`` of the piece) keeps
``(h/k)² a'(1 − a')``, at most ``r/k`` (``a → 0``) and typically ``r/k²``. The step is a jump when
one piece of length ``h/k`` keeps more than ``share · |r|`` (``share = 1/4``, ``k = 16``).

:func:`jump_in_chain` redoes the pieces one after the other and stops at the first that keeps
more than the bound (the verdict is that of the whole chain; a jump in the middle costs half of
it). Tried and not kept: a bisection (halve the step, examine only the halves above the bound,
``2 log₂ k`` problems for a jump, 2–6 for a kink) — at N = 1000, p = 1e-4, δγ = 1e-5 (30 steps,
the same 5 plastic steps) it was *slower*, 795 against 615 ms per step, because a jump is redone
at every level and each time FIRE must carry it (53 FIRE fallbacks against 28).

``advance(packing, dh) -> (minimum, V, Σ, iterations)`` is the protocol's step: affine shear by
``dh`` from a minimum, then its minimisation (``packing`` is then the parent of that problem).

:func:`jump_located` reaches the chain's verdict on a jump without carrying the event again: the
piece that contains it is the one where the branch of the start ends, found by bisection with
``probe``s — the same step made by Newton alone, which fails where the branch ends instead of
handing the problem to FIRE —, and the minimum at the piece's end is the single step's own
post-event minimum continued *backwards* by Newton along its branch (where that branch does not
reach back so far, the chain's own piece: ``advance`` from the piece's start, FIRE carrying the
event, the chain's pieces after it, then those before it from the start: the whole chain, its
later pieces from the probe's minimum). A piece that keeps more than the bound is a jump, as in
the chain; a piece located by the probes alone that keeps less leaves the verdict to the whole
chain. ``probe(packing, dh) -> (minimum, V, Σ) | None``.

A single step of ``δγ`` can land in a lower minimum than quasi-static driving reaches (the 16
pieces jump by less than a quarter of the step's drop, or not at all): its end is not the
continuation of its start — the constant-volume rule —, so it is a jump. :func:`jump_located`
sees that where the end's branch reaches back to the located piece; :func:`jump_in_chain`, given
the single step's end ``v_end``, compares it with the chain's end (without it, the chain called
such a step a kink: measured in ``docs/aqs.md``, e.g. a step of N = 1000, p = 1e-4 whose
residual was 70 times the run's plastic threshold, its chain's largest piece 7 % of it).

The share is of ``|r|``, and in a step with a large stress drop ``D`` most of ``r = −S −
D δγ (½ − a)`` is the drop's term, which the piece holding the event keeps only ``1/k`` of: a jump
of a few thresholds there keeps less than a quarter of ``r``. So where the chain finds no jump,
its largest piece (:class:`LargestPiece`, seen by :func:`jump_in_chain` and :func:`jump_located`)
is redone in ``HELD_SUBPIECES`` sub-pieces (:func:`residual_held`): a jump keeps its residual in
one of them (it holds as the pieces shrink), a kink at most ``1/HELD_SUBPIECES`` of it; the caller
flags the step when the held residual exceeds the run's threshold (``docs/aqs.md``, "The chain's
share misses small jumps").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jamlab.analysis.avalanches import branch_residual, jammed_steps, noise_floor
from jamlab.spheres.potential import Packing

__all__ = ["HELD_SHARE", "HELD_SUBPIECES", "Advance", "LargestPiece", "Probe", "jump_in_chain",
           "jump_located", "plastic_threshold", "released_at_least", "residual_held",
           "trapezoid_residual"]

HELD_SUBPIECES = 4
"""Sub-pieces :func:`residual_held` redoes a chain's largest piece in."""
HELD_SHARE = 0.5
"""The share of the piece's residual one sub-piece must keep to be a jump (a kink keeps at most
``1/HELD_SUBPIECES``: a margin of 2)."""

Advance = Callable[[Packing, float], tuple[Packing, float, float, int]]
Probe = Callable[[Packing, float], "tuple[Packing, float, float] | None"]


def trapezoid_residual(v0: float, s0: float, v1: float, s1: float, step: float) -> float:
    """``r = v1 − v0 − step s0 − ½ step (s1 − s0)`` — the trapezoid rule's residual of one step
    (``O(step³)`` on a smooth branch; ``docs/aqs.md``)."""
    return v1 - v0 - step * s0 - 0.5 * step * (s1 - s0)


@dataclass
class LargestPiece:
    """The piece of a chain that kept the largest ``|residual|`` so far (none: ``residual`` 0):
    its start minimum, ``V`` and ``Σ`` there, its length — what :func:`residual_held` redoes."""

    residual: float = 0.0
    start: Packing | None = None
    v: float = math.nan
    s: float = math.nan
    length: float = math.nan

    def see(self, residual: float, start: Packing, v: float, s: float, length: float) -> None:
        if abs(residual) > abs(self.residual):
            self.residual, self.start, self.v, self.s, self.length = residual, start, v, s, length


def jump_in_chain(
    advance: Advance, start: Packing, v0: float, s0: float, step: float, r_step: float, k: int,
    share: float = 0.25, v_end: float | None = None, largest: LargestPiece | None = None,
) -> tuple[bool, int]:
    """The step from ``start`` (at potential ``v0``, stress ``s0``) redone in ``k`` pieces one
    after the other: True as soon as one keeps more than ``share · |r_step|`` (the rest are not
    computed); when none does, True if the single step's own end minimum (potential ``v_end``,
    if given) lies lower than the chain's end by more than that bound — the single step left
    the branches quasi-static driving follows, into a lower minimum: a jump, as in
    :func:`jump_located` —, else False; and the inner iterations spent. ``largest`` (if given)
    sees every piece computed."""
    cur, v, s = start, v0, s0
    iterations = 0
    bound = share * abs(r_step)
    for _ in range(k):
        nxt, v2, s2, its = advance(cur, step / k)
        iterations += its
        r = trapezoid_residual(v, s, v2, s2, step / k)
        if largest is not None:
            largest.see(r, cur, v, s, step / k)
        if abs(r) > bound:
            return True, iterations
        cur, v, s = nxt, v2, s2
    return v_end is not None and v - v_end > bound, iterations


def jump_located(
    probe: Probe, advance: Advance, start: Packing, v0: float, s0: float, end: Packing,
    v1: float, s1: float, step: float, r_step: float, k: int, share: float = 0.25,
    largest: LargestPiece | None = None,
) -> tuple[bool | None, int]:
    """Is the step from ``start`` (``v0``, ``s0``) to the minimum ``end`` (``v1``, ``s1``) a jump,
    decided on the piece of length ``step/k`` where the branch of ``start`` ends (module
    docstring)? ``True`` when that piece keeps more than ``share · |r_step|``; ``None`` when
    the probes located the piece and it keeps less (the caller runs :func:`jump_in_chain`);
    ``False`` when the chain's own pieces ran (below) and none kept more; and how many pieces
    ``advance`` computed (0: the probes alone decided).

    The bisection keeps ``lo`` (the branch of ``start`` reaches ``lo · step/k``) and ``hi``
    (it does not reach ``hi · step/k``, or ``hi = k``: the step itself left the branch),
    probing from ``start`` directly, so each probe is one problem, not a chain of them. The
    piece ends at ``end`` itself if ``hi = k``, else at ``end``'s minimum followed back to
    ``hi`` by a probe; where ``end``'s branch does not reach back so far, the piece is the
    chain's own (``advance`` from the minimum at ``lo``, carrying the event), and below the
    bound the chain goes on from its end over the remaining pieces (a probe can fail short of
    the branch's end, on a rearrangement below the bound, with the jump further on), the
    single step's end compared as :func:`jump_in_chain` does, and then over the ``lo`` pieces
    before it from ``start``: every piece of the chain is then computed and the verdict is
    final. It differs from :func:`jump_in_chain`'s only in where the pieces from ``lo`` on
    start: at the probe's minimum at ``lo``, not the chain's (the same branch's minimum unless
    the chain's first pieces cross an event below the bound). Before, the caller ran the whole
    chain again (``docs/aqs.md``, "The located confirmation finishes the chain it started").

    Why a located piece below the bound is not final: a probe that succeeds may have crossed a
    small event (Newton from ``start`` converging to a post-event minimum close by), so a piece
    below the bound does not prove that no other piece keeps more; a piece above it is a drop
    of more than the bound between two minima ``step/k`` apart, which is the chain's
    criterion. ``largest`` (if given) sees the pieces ``advance`` computed."""
    h = step / k
    lo, hi = 0, k
    lo_min, lo_state = start, (v0, s0)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        got = probe(start, mid * h)
        if got is None:
            hi = mid
        else:
            lo, lo_min, lo_state = mid, got[0], got[1:]
    bound = share * abs(r_step)
    hi_state = (v1, s1) if hi == k else probe(end, -(k - hi) * h)
    if hi_state is not None:
        return (True if abs(trapezoid_residual(*lo_state, *hi_state[-2:], h)) > bound
                else None), 0
    # the end's branch does not reach back: the chain's own piece from lo, the chain's pieces
    # after it (Newton may fail short of the branch's end, e.g. on a rearrangement below the
    # bound, with the jump further on), then those before it
    cur, v, s, _ = advance(lo_min, h)
    r = trapezoid_residual(*lo_state, v, s, h)
    if largest is not None:
        largest.see(r, lo_min, *lo_state, h)
    if abs(r) > bound:
        return True, 1
    calls = [1]

    def counted(packing: Packing, dh: float):
        calls[0] += 1
        return advance(packing, dh)

    jump, _ = jump_in_chain(counted, cur, v, s, (k - hi) * h, r_step, k - hi, share, v1,
                            largest)
    if not jump and lo > 0:
        # the pieces before lo, which the probes crossed without proving them smooth; with
        # them every piece of the chain has run: the verdict is final
        jump, _ = jump_in_chain(counted, start, v0, s0, lo * h, r_step, lo, share,
                                largest=largest)
    return jump, calls[0]


def residual_held(advance: Advance, piece: LargestPiece, m: int = HELD_SUBPIECES,
                  hold: float = HELD_SHARE) -> tuple[float, int]:
    """The largest piece of a chain that found no jump, redone in ``m`` sub-pieces one after the
    other: the first sub-piece's ``|residual|`` that keeps more than ``hold · |piece residual|``
    (the residual holds as the pieces shrink: a jump), else 0.0 (it falls: a kink keeps at most
    ``1/m`` of it, typically ``1/m²``; module docstring); and the inner iterations spent.

    Why: the chain's share is of ``|r_n|``, and in a step with a large stress drop most of
    ``r_n`` is the drop's ``D δγ (½ − a)`` (:func:`released_at_least`), which the piece holding
    the event keeps only ``1/k`` of: a jump of a few thresholds there keeps less than a quarter
    of ``r_n`` and the chain calls it a kink (``docs/aqs.md``, "The chain's share misses small
    jumps"). The caller flags the step when the held residual exceeds the run's threshold."""
    if piece.start is None or piece.residual == 0.0:
        return 0.0, 0
    cur, v, s = piece.start, piece.v, piece.s
    bound = hold * abs(piece.residual)
    iterations = 0
    for _ in range(m):
        cur, v2, s2, its = advance(cur, piece.length / m)
        iterations += its
        r = abs(trapezoid_residual(v, s, v2, s2, piece.length / m))
        if r > bound:
            return r, iterations
        v, s = v2, s2
    return 0.0, iterations


def plastic_threshold(hj: np.ndarray, sj: np.ndarray, g: np.ndarray, jammed: np.ndarray,
                      dgamma: float, plastic_floor: float,
                      confirm_below: float) -> tuple[float, np.ndarray, np.ndarray]:
    """The run's threshold of the plastic flag and, per row, whether the step passes it (the
    flag before the confirmation of candidates): ``|r_n| > max(10 σ, plastic_floor δγ²)`` between
    two jammed minima (:mod:`jamlab.spheres.pressure_shear`); and whether it is a jump without
    confirmation (:func:`released_at_least` above ``confirm_below · max(threshold, δγ²)``).
    NaN and no step with fewer than 3 jammed steps."""
    passes = np.zeros(g.shape, dtype=bool)
    sure = np.zeros(g.shape, dtype=bool)
    both = jammed_steps(jammed)
    if np.count_nonzero(both) < 3:
        return math.nan, passes, sure
    steps = np.diff(g)
    nf = noise_floor(hj[1:], sj[1:], steps, jammed=jammed)
    threshold = max(nf.threshold(10.0), plastic_floor * dgamma**2)
    resid = branch_residual(hj[1:], sj[1:], steps)
    passes[1:] = both & (np.abs(resid) > threshold)
    if math.isfinite(confirm_below):
        least = released_at_least(resid, sj[1:], steps, nf.modulus)
        sure[1:] = passes[1:] & (least > confirm_below * max(threshold, dgamma**2))
    return threshold, passes, sure


def released_at_least(resid: np.ndarray, stress_jump: np.ndarray, steps: np.ndarray,
                      modulus: float) -> np.ndarray:
    """A lower bound of the enthalpy a step released, from its residual ``r_n`` alone.

    On a branch of modulus ``G`` (extensive, ``dΣ/dγ``) left at the fraction ``a`` of the step
    for one ``S`` lower, where the stress drops by ``D = G δγ − ΔΣ_n``: ``ΔH_n = G δγ²/2 −
    D δγ (1 − a) − S`` and ``ΔΣ_n = G δγ − D``, so ``r_n = −S − D δγ (½ − a)``. Whatever ``a``,
    ``S ≥ −r_n − ½ δγ |D|``: a residual can come from a stress drop that released almost
    nothing (near jamming a large ``D`` costs little enthalpy), and only what is left beyond
    ``½ δγ |D|`` is released for certain. ``G``: the run's median modulus on elastic steps
    (:attr:`~jamlab.analysis.avalanches.NoiseFloor.modulus`)."""
    drop = modulus * steps - stress_jump
    return -resid - 0.5 * steps * np.abs(drop)
