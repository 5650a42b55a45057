"""Minimum of the enthalpy ``H = E + p V`` over positions and the (isotropic) box volume.

The box stays a cube of side ``L`` (``V = L^d``) with its Lees–Edwards strain ``γ`` fixed; a change
of volume is an affine isotropic rescaling ``r_i → r_i L'/L`` (reduced coordinates and ``γ`` kept).

**Method: nested minimisation** (documented in ``docs/aqs.md``, "At the jamming point"). With
``E*(L)`` the energy minimised over positions at fixed ``L`` (on one branch),

    dH*/dL = dE*/dL + d p_t L^{d−1} = d L^{d−1} (p_t − p(L)),

because ``dE*/dV = −p`` at a minimum (the virial pressure of SPEC §3; positions relaxed, so only
the explicit volume dependence counts). So ``H`` is stationary over ``L`` exactly where the
relaxed pressure equals the target, and it is a minimum since ``p(L)`` decreases with ``L`` along
a branch (positive bulk modulus). The outer problem is one-dimensional and monotone: it is solved
on ``s = ln L`` by a safeguarded secant iteration (first slope from the affine response, a
bracket and bisection once the target is bracketed — and where the bracket shrinks below what
the tolerance can resolve without reaching ``p_t``, ``p(L)`` jumps there (two branches, the
minimiser falling from one to the other): the iteration restarts from the looser state, then the
denser one, following that branch alone; from a state that carries less than
``p_t/10`` — unjammed, or jammed at a much lower pressure — the step is taken from the loosest
known state with ``p > p_t``, or, if there is none, the box is compressed by steps
``p_t/|DEFAULT_SLOPE| · 2^k``; at most 0.01 in ``ln L`` per step), the inner one at fixed box
by ``relax``: the compiled FIRE of :func:`jamlab.spheres.fire.minimize` (default), or the
Newton relaxer of :mod:`jamlab.spheres.newton_relax` (fixed-pressure AQS's default).

Why not FIRE with the box as an extra degree of freedom (LAMMPS ``fix box/relax iso``): that
needs a box "mass" to tune, mixes a force and a pressure tolerance in one dynamics, and every
recorded minimum would be a minimum of a different objective than the constant-volume one. Here
every recorded configuration is a fixed-volume minimum converged to ``max_i |F_i| < ftol`` (the
same criterion as constant-volume AQS), the fixed-volume minimiser can be swapped, and near
jamming, where the bulk modulus stays finite while the shear modulus vanishes, the outer
iteration converges in a few steps.

**Converged** means ``max_i |F_i| < ftol`` and ``|p − p_t| ≤ tol`` with
``tol = max(ptol · p_t, p_floor(ftol))``: ``ptol`` relative (default 1e-6), but never below the
pressure resolution of a minimum converged to ``ftol``
(:func:`jamlab.spheres.rigidity.pressure_floor`, ``≈ 1.2e-11`` at ``ftol = 1e-12``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

from jamlab import validation
from jamlab.spheres.aqs.network import find_backbone
from jamlab.spheres.aqs.saddle import MAX_DESCENTS, saddle_push
from jamlab.spheres.box import Box
from jamlab.spheres.confirm import trapezoid_residual
from jamlab.spheres.fire import FireParameters, MinimizeResult, minimize, polish_reading
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.potential import Packing, evaluate, pressure
from jamlab.spheres.rigidity import pressure_floor

__all__ = ["POLISH_COUNT", "EnthalpyResult", "box_side_guess", "enthalpy",
           "enthalpy_and_stress", "leave_saddle", "minimize_enthalpy", "minimize_step",
           "polish_recorded", "pressure_tolerance", "rescale_box"]

DEFAULT_SLOPE = -1.0
"""``dp/d ln L`` assumed when no contact carries the affine response (an unjammed start): the
order of ``−d φ dp/dφ`` near jamming in 3D (``dp/dφ ≈ 0.5–1`` for harmonic spheres)."""

_AFFINE_STEP = 1e-8  # ln L step of the finite-difference affine slope
_CARRIES = 0.1  # a state with p > 0.1 p_t is on a branch whose local slope is trusted
_MAX_STEP = 0.01  # largest change of ln L per outer step


def rescale_box(packing: Packing, length: float) -> Packing:
    """Isotropic affine rescaling to box side ``length``: ``r_i → r_i L'/L``, strain kept."""
    scale = float(length) / packing.box.length
    return replace(
        packing,
        positions=packing.positions * scale,
        box=Box(float(length), packing.dim, packing.box.strain),
        check_coincidence=False,  # a dilation keeps distinct particles distinct
    )


def enthalpy(energy: float, target_pressure: float, packing: Packing) -> float:
    """``H = E + p_t L^d`` (extensive, like ``E``)."""
    return float(energy + target_pressure * packing.box.volume)


def enthalpy_and_stress(packing: Packing, target_pressure: float) -> tuple[float, float]:
    """``(H = E + p_t V, Σ)`` of a minimum, as the fixed-pressure trace records them."""
    ev = evaluate(packing)
    return enthalpy(ev.energy, target_pressure, packing), ev.shear_stress


def pressure_tolerance(packing: Packing, target_pressure: float, ftol: float, ptol: float) -> float:
    """``tol = max(ptol · p_t, p_floor(ftol))`` (module docstring)."""
    floor = pressure_floor(packing.n, packing.dim, packing.box.length, ftol)
    return max(ptol * target_pressure, floor)


@dataclass(frozen=True, eq=False)
class EnthalpyResult:
    """Outcome of :func:`minimize_enthalpy`.

    ``packing``: the final minimum (box side chosen by the outer iteration); ``energy`` ``E``,
    ``enthalpy`` ``H = E + p_t V``, ``pressure`` ``p`` there; ``target_pressure`` ``p_t``,
    ``tolerance`` the pressure tolerance used; ``max_force``; ``iterations``: FIRE iterations
    summed over the inner minimisations; ``volume_steps``: box rescalings; ``converged``: forces
    below ``ftol`` and ``|p − p_t| ≤ tolerance``; ``time``: wall-clock seconds.
    """

    packing: Packing
    energy: float
    enthalpy: float
    pressure: float
    target_pressure: float
    tolerance: float
    max_force: float
    iterations: int
    volume_steps: int
    converged: bool
    time: float
    ftol: float
    slope: float = math.nan  # the last secant slope dp/d ln L (NaN: none measured)

    @property
    def phi(self) -> float:
        return self.packing.phi


def _affine_slope(packing: Packing, p0: float) -> float:
    """``dp/d ln L`` of the unrelaxed affine response (finite difference)."""
    h = _AFFINE_STEP
    p1 = pressure(rescale_box(packing, packing.box.length * math.exp(h)))
    return (p1 - p0) / h


def minimize_enthalpy(
    packing: Packing,
    target_pressure: float,
    ftol: float = 1e-12,
    ptol: float = validation.DEFAULT_PTOL,
    max_volume_steps: int = 60,
    max_iter: int = 1_000_000,
    params: FireParameters | None = None,
    length_guess: float | None = None,
    slope_guess: float | None = None,
    relax: Callable[..., MinimizeResult] | None = None,
    parent: Packing | None = None,
) -> EnthalpyResult:
    """Minimise ``H = E + p_t V`` over positions and the box side at fixed strain.

    ``length_guess`` (optional): box side to start the outer iteration from (e.g. extrapolated
    along an AQS run); the configuration is rescaled to it before the first minimisation.
    ``slope_guess`` (optional, < 0): ``dp/d ln L`` for the first secant step instead of the
    affine slope (e.g. the relaxed slope of the previous AQS step, returned as ``slope``: along
    a branch the bulk modulus barely changes, so one volume step usually suffices).
    ``relax(packing, ftol=, max_iter=, params=)``: the fixed-box minimiser (default FIRE,
    :func:`jamlab.spheres.fire.minimize`; :class:`jamlab.spheres.newton_relax.NewtonRelaxer`,
    which is also told the minimum each start was made from: ``parent`` — the minimum
    ``packing`` was sheared from, if it is one — for the first, the minimum being rescaled for
    the volume steps).
    Non-convergence is reported (``converged=False``), not raised.
    """
    if not (validation.is_real(target_pressure) and math.isfinite(target_pressure)):
        raise ValueError(f"target pressure must be a finite number, got {target_pressure!r}")
    if not target_pressure > 0:
        raise ValueError(f"target pressure must be > 0, got {target_pressure!r}")
    if not (validation.is_real(ptol) and math.isfinite(ptol) and ptol > 0):
        raise ValueError(f"ptol must be finite and > 0, got ptol={ptol!r}")
    target_pressure, ptol = float(target_pressure), float(ptol)
    if not (validation.is_integer(max_volume_steps) and max_volume_steps >= 0):
        raise ValueError(f"max_volume_steps must be an integer >= 0, got {max_volume_steps!r}")
    floor = pressure_floor(packing.n, packing.dim, packing.box.length, ftol)
    if not target_pressure > floor:
        raise ValueError(
            f"target pressure {target_pressure:.3e} is not above the resolution floor "
            f"{floor:.3e} of ftol={ftol:.1e} (see jamlab.spheres.rigidity)"
        )
    t0 = time.perf_counter()
    pt = float(target_pressure)
    tol = pressure_tolerance(packing, pt, ftol, ptol)

    def inner(start: Packing, made_from: Packing | None):
        if relax is None:
            return minimize(start, ftol=ftol, max_iter=max_iter, params=params, skin=RELAX_SKIN)
        return relax(start, ftol=ftol, max_iter=max_iter, params=params, parent=made_from)

    if length_guess is not None:
        packing = rescale_box(packing, length_guess)
    res = inner(packing, parent)
    iterations = res.iterations
    cur = res.packing
    p = pressure(cur)
    s = math.log(cur.box.length)
    lo, hi = -math.inf, math.inf  # ln L with p > p_t (too dense) / p < p_t (too loose)
    lo_state: tuple | None = None  # (ln L, p, minimum, result): the loosest state with p > p_t
    hi_state: tuple | None = None  # the same, the densest state with p < p_t
    prev: tuple[float, float] | None = None  # the last state that carries pressure
    last_slope = math.nan
    n_loose = 0
    steps = 0
    restarts = 0
    while res.converged and abs(p - pt) > tol and steps < max_volume_steps:
        if p > pt:
            if s > lo:
                lo, lo_state = s, (s, p, cur, res)
        else:
            if s < hi:
                hi, hi_state = s, (s, p, cur, res)
        base = cur
        if p > _CARRIES * pt:
            # Newton/secant from here; the affine slope is steeper than the relaxed one, so the
            # first step undershoots and stays on this branch
            slope = math.nan
            if prev is not None and prev[0] != s:
                slope = (p - prev[1]) / (s - prev[0])
            elif slope_guess is not None:
                slope = float(slope_guess)
            if not (math.isfinite(slope) and slope < 0):
                slope = _affine_slope(cur, p)
            if not (math.isfinite(slope) and slope < 0):
                slope = DEFAULT_SLOPE
            s_new = s - (p - pt) / slope
            prev = (s, p)
            last_slope = slope
            n_loose = 0
        elif lo_state is not None:
            # (almost) unjammed here: step from the loosest state that carried more than p_t
            s_lo, p_lo, base, _ = lo_state
            slope = _affine_slope(base, p_lo)
            if not (math.isfinite(slope) and slope < 0):
                slope = DEFAULT_SLOPE
            s_new = s_lo - (p_lo - pt) / slope
        else:
            # unjammed and nothing denser known: compress, doubling the step each time
            s_new = s - (pt / abs(DEFAULT_SLOPE)) * 2.0**n_loose
            n_loose += 1
        s_new = min(max(s_new, s - _MAX_STEP), s + _MAX_STEP)
        if math.isfinite(lo) and math.isfinite(hi) and not lo < s_new < hi:
            s_new = 0.5 * (lo + hi)
        known = last_slope if math.isfinite(last_slope) else DEFAULT_SLOPE
        narrow = math.isfinite(lo) and math.isfinite(hi) and (hi - lo) * abs(known) < tol
        if s_new == s or narrow:
            # the bracket is narrower than p_t's tolerance can resolve (or closed to rounding)
            # while its ends differ by more: p(L) jumps across it (a denser and a looser
            # branch, the minimiser falling from one to the other there). Follow one branch
            # instead: restart from the looser state (p < p_t), then from the denser one,
            # with a fresh bracket and every later step from the last state of that branch
            if restarts >= 2:
                break  # not resolvable (reported as not converged)
            start_state = hi_state if restarts == 0 else lo_state
            restarts += 1
            if start_state is None:
                break
            s, p, cur, res = start_state
            lo, hi, lo_state, hi_state, prev = -math.inf, math.inf, None, None, None
            continue
        res = inner(rescale_box(base, math.exp(s_new)), base)
        iterations += res.iterations
        steps += 1
        cur = res.packing
        p = pressure(cur)
        if res.converged and prev is not None and prev[0] != s_new and p > _CARRIES * pt:
            last_slope = (p - prev[1]) / (s_new - prev[0])  # the secant over this step
        s = s_new
    energy = float(res.energy)
    return EnthalpyResult(
        packing=cur,
        energy=energy,
        enthalpy=enthalpy(energy, pt, cur),
        pressure=float(p),
        target_pressure=pt,
        tolerance=float(tol),
        max_force=float(res.max_force),
        iterations=int(iterations),
        volume_steps=steps,
        converged=bool(res.converged and abs(p - pt) <= tol),
        time=time.perf_counter() - t0,
        ftol=float(ftol),
        slope=float(last_slope),
    )


def minimize_step(
    sheared: Packing, parent: Packing, pressure: float, kw: dict,
    length_guess: float | None, slope_guess: float | None,
) -> tuple[EnthalpyResult, int]:
    """The fixed-pressure minimum of one AQS step, ``(result, retries)``: :func:`minimize_enthalpy`
    from ``sheared`` (the minimum ``parent`` sheared affinely) with ``kw`` and the guesses.

    A step that does not converge but started from the run's history — the extrapolated box side
    ``length_guess``, the slope ``slope_guess``, the Newton relaxer's stored factor
    (``kw["relax"]``) — is taken once more afresh, as a fresh run started at ``parent`` would
    take it: relaxer reset, no guesses (``retries`` = 1; the result's ``iterations``,
    ``volume_steps`` and ``time`` include the first attempt's). Why: FIRE's cost on a step near
    unjamming is heavy-tailed and depends on where it starts. Measured at p = 1e-6, N = 1000
    (sample 6, ``docs/reproduce.md``): one step spent the cap of 1e6 iterations in one FIRE run
    and stopped at max|F| 2.9e-11; the same step taken by a fresh run started at its parent
    converged in 375,011. A converged step is never retried, so a run without failures is
    unchanged; the retry depends only on ``parent`` and the first attempt only on what it did
    before, so a resumed run still equals the uninterrupted one.
    """
    res = minimize_enthalpy(sheared, pressure, length_guess=length_guess,
                            slope_guess=slope_guess, parent=parent, **kw)
    relax = kw.get("relax")
    if res.converged or (length_guess is None and slope_guess is None and relax is None):
        return res, 0  # converged, or nothing to take afresh (the same call again)
    if relax is not None:
        relax.reset()
    again = minimize_enthalpy(sheared, pressure, parent=parent, **kw)
    return replace(again, iterations=again.iterations + res.iterations,
                   volume_steps=again.volume_steps + res.volume_steps,
                   time=again.time + res.time), 1


def box_side_guess(rule: str, gamma, enthalpy, stress, length, floor: float) -> float | None:
    """The box side the next fixed-pressure AQS step starts its minimisation from under ``rule``
    (:data:`jamlab.validation.VOLUME_GUESSES`), or ``None`` for the current one, from the last
    two minima's strain, enthalpy, shear stress and box side (pairs ``(n − 1, n)``):
    ``2 L_n − L_{n−1}``, under
    ``elastic`` only if the last step was not a candidate jump — its trapezoid residual
    (:func:`~jamlab.spheres.confirm.trapezoid_residual`) ``|r| ≤ floor · δγ²``.

    Why: the start is the minimum rescaled to that side, a real perturbation. On an elastic
    stretch it is the branch's own dilatancy to ``O(δγ²)``; after a jump it repeats the jump's
    volume change — a compaction or dilation unrelated to ``δγ`` — and can push the minimum out
    of its basin: at p = 1e-6 a spurious avalanche at the next step (``docs/aqs.md``, "The
    box-side guess after a jump")."""
    validation.volume_guess(rule)
    step = gamma[1] - gamma[0]
    r = trapezoid_residual(enthalpy[0], stress[0], enthalpy[1], stress[1], step)
    if rule == "never" or (rule == "elastic" and abs(r) > floor * step**2):
        return None
    return 2.0 * length[1] - length[0]


def leave_saddle(
    res: EnthalpyResult, pressure: float, kw: dict, test: bool
) -> tuple[EnthalpyResult, int]:
    """The fixed-pressure minimum ``res`` pushed off a saddle, if it is one and ``test``:
    ``(result, pushes)``.

    FIRE can stop on a saddle of the energy at fixed box (``max|F| < ftol`` with a resolved
    negative curvature, :mod:`jamlab.spheres.aqs.saddle`), and one is then also a saddle of the
    enthalpy (the positions at fixed box are a subspace of its variables). Measured at
    ``p = 1e-6``: most minima the jammed flag calls hypostatic under pressure were such saddles
    (N = 250: 28 → 3 unjammed with this test; the rest minima at a contact at touching,
    ``docs/aqs.md``). The caller decides where to test (``shear_at_pressure``: the start, every
    step FIRE took part in, every minimum the jammed flag rejects): the pinned backbone
    Hessian's inertia (:func:`~jamlab.spheres.aqs.saddle.saddle_push`); on a saddle the
    particles are pushed along its unstable mode, on its downhill side, and the enthalpy
    minimised again (:func:`minimize_enthalpy` with ``kw`` and FIRE as the fixed-box
    minimiser), at most ``MAX_DESCENTS`` times. The result's ``iterations`` and
    ``volume_steps`` include those of the minimisations before.
    """
    pushes = 0
    while test and res.converged and pushes < MAX_DESCENTS:
        pk = res.packing
        nl = NeighborList(pk)
        push, _ = saddle_push(pk, nl, find_backbone(pk, nl), downhill=True)
        if push is None:
            break
        pushes += 1
        spent = (res.iterations, res.volume_steps)
        # FIRE, not the Newton relaxer: Newton's step on an indefinite Hessian goes back to the
        # stationary point it was pushed off (measured: 10 pushes, the same saddle each time)
        res = minimize_enthalpy(pk.with_positions(pk.positions + push), pressure,
                                **{**kw, "relax": None})
        res = replace(res, iterations=res.iterations + spent[0],
                      volume_steps=res.volume_steps + spent[1])
    return res, pushes


POLISH_COUNT = "n_polished"  # trace attribute: minima relaxed further to be recorded (below)


def polish_recorded(res: EnthalpyResult, kw: dict,
                    max_force: float | None = None) -> tuple[EnthalpyResult, int]:
    """``res`` as the trace records it: ``(result, FIRE runs)``; ``max_force``: the force the
    caller already evaluated from ``res.packing`` (else evaluated here).

    The trace's ``max_force`` is evaluated afresh from the stored packing, and can read just
    above ``ftol`` where the minimiser read just below it (rounding; measured, 4 of the 26,026
    minima of ``data/runs/n500-p1e-6-vg`` at p = 1e-6, N = 500, counted as converged before this
    check). Such a result is relaxed further at fixed box by
    :func:`~jamlab.spheres.fire.polish_reading` (``kw``'s ``max_iter`` and ``params``); its
    pressure, energy, enthalpy and force are then those of the polished packing, and it stays
    converged only if it reads ``< ftol`` and ``|p − p_t| ≤ tolerance``. Every other result is
    returned as it is (a run without such a minimum is unchanged bit for bit). The result's
    ``iterations`` include the polish."""
    fmax = evaluate(res.packing).max_force if max_force is None else max_force
    pt, tol = res.target_pressure, res.tolerance
    start = MinimizeResult(packing=res.packing, energy=res.energy, max_force=fmax, iterations=0,
                           converged=res.converged, time=0.0, ftol=res.ftol)
    out, ev, runs = polish_reading(start, fmax, kw.get("max_iter", 1_000_000), kw.get("params"),
                                   accept=lambda e: abs(e.pressure - pt) <= tol)
    if ev is not None:
        res = replace(
            res, packing=out.packing, energy=ev.energy,
            enthalpy=ev.energy + pt * out.packing.box.volume, pressure=ev.pressure,
            max_force=ev.max_force, iterations=res.iterations + out.iterations,
            converged=out.converged,
        )
    return res, runs  # (nothing ran: out is start, converged as res was)
