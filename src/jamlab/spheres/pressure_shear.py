"""Athermal quasi-static shear at fixed pressure: affine step ``δγ``, then minimise the enthalpy.

Per step ``n → n + 1`` (``γ_{n+1} = γ_0 + (n + 1) δγ``, computed, not accumulated): affine
shear ``x_i += (γ_{n+1} − γ_n) y_i`` at the current box, then
:func:`jamlab.spheres.barostat.minimize_enthalpy` (positions and the isotropic box side,
Lees–Edwards strain fixed) to ``max_i |F_i| < ftol`` and ``|p − p_t| ≤ tol``. The recorded
columns (one row per minimum, row 0 the start):

``gamma, energy (E), enthalpy (H = E + p_t L^d), shear_stress (Σ = ∂E/∂γ, extensive), pressure,
phi, box_length, z, z_nr, jammed, max_force, iterations (FIRE, summed over the inner
minimisations and the substeps of a plastic-flag confirmation), volume_steps, converged,
enthalpy_jump, stress_jump, plastic``.

The start, a minimum FIRE took part in, and one the jammed flag rejects are tested for a saddle,
and pushed off it (``barostat.leave_saddle``, ``n_saddles_left``; ``docs/aqs.md``), then
``barostat.polish_recorded`` (``n_polished``): no row reading ``max_force ≥ ftol`` converged.

**Trapezoid rule for the enthalpy** (``docs/aqs.md``, "At the jamming point"). Let
``H*(γ) = min_{x, L} [E(x, L, γ) + p_t L^d]`` along a branch (a smooth family of minima). By the
envelope theorem (the minimiser's ``x`` and ``L`` are stationary), ``dH*/dγ = ∂E/∂γ`` at fixed
reduced coordinates and fixed ``L`` — the shear stress ``Σ`` of ``SPEC.md`` §3, evaluated at the
minimum. So along an elastic step

    ΔH_n ≡ H_{n+1} − H_n − δγ Σ_n = ½ δγ (Σ_{n+1} − Σ_n) − δγ³ Σ''/12 + …,

the constant-volume rule with ``E`` replaced by ``H`` (the ``p_t ΔV`` of dilatancy is part of it;
``E`` alone does not obey it). ``enthalpy_jump`` is ``ΔH_n`` (NaN in row 0), ``stress_jump``
``ΔΣ_n``; the avalanche size at fixed pressure is ``S_n = −ΔH_n``.

**Plastic flag.** The continuation test of constant-volume AQS is not available here. A step is a
*candidate* when its trapezoid residual ``r_n = ΔH_n − ½ δγ ΔΣ_n`` exceeds ``plastic_floor · δγ²``
in absolute value (either sign: near jamming an event with a large stress drop and a small ``S``
has ``r_n > 0``). A contact opening or closing inside the step (a kink) also breaks the rule, and
near jamming by more than the affine estimate ``δγ²/16`` (non-affine displacements amplify the
stiffness change): measured 0.15–0.22 ``δγ²`` at N = 64, p = 1e-3 (``docs/aqs.md``). So a candidate
is redone from the previous minimum in ``confirm_substeps`` (16) pieces
(:func:`jamlab.spheres.confirm.jump_in_chain`): a jump keeps its residual in one piece (``≈ r_n``),
a kink leaves ``≲ r_n/k`` per piece; the step is **plastic** when one piece keeps more than
``|r_n|/4`` (or the single step's end lies lower than the chain's end by more than that: it left
the quasi-static branches), it lies between two jammed minima, and ``|r_n| > max(10 σ,
plastic_floor · δγ²)`` (``σ`` the robust noise of ``r_n`` over the run's jammed steps,
:func:`~jamlab.analysis.avalanches.noise_floor`). With the Newton inner minimiser and
``confirm="continued"`` a candidate whose every inner problem Newton solved from the previous
minimum's contact network — the branch continued through the step, no FIRE — is a kink and is not
redone (a jump leaves the linear-response basin of the branch, where Newton fails and FIRE carries
the event); measured against redoing every candidate (``confirm="chain"``) in ``docs/aqs.md``.
Unless it released for certain more than ``confirm_below`` units (below): Newton does sometimes
cross a small event inside the step and land in the post-event minimum, and such a step is a jump
(measured, ``docs/aqs.md``, "Jumps Newton continued through").
``confirm="located"`` (the default) redoes the same candidates, but decides each first on the one
piece where the branch of the start ends, located by Newton-only probes, without carrying the
event by FIRE a second time (:func:`jamlab.spheres.confirm.jump_located`; the whole chain only
where that piece keeps less than the bound); it also flags the single step that lands lower than
quasi-static driving reaches. Both measured in ``docs/aqs.md``. Where the chain finds no piece
above the bound, its largest piece (if above ``½ plastic_floor · δγ²``) is redone in four
(:func:`jamlab.spheres.confirm.residual_held`): a jump's residual holds as the pieces shrink, a
kink's falls, and the step is plastic when one sub-piece held more than half the piece's residual
and more than the run's threshold — a small jump in a step whose residual is mostly its stress
drop keeps under a quarter of ``r_n`` (``docs/aqs.md``, "The chain's share misses small
jumps"). By default the redoing is
deferred (``defer_confirmation``): once the run's threshold is known, a kept candidate is redone
only if ``|r_n|`` passes it between two jammed minima (the others cannot be plastic: at N = 1000,
p = 1e-4, δγ = 1e-5 two thirds of them) and it did not release for certain more than
``confirm_below`` (5) times ``max(threshold, δγ²)`` (a jump:
:func:`~jamlab.spheres.confirm.released_at_least`). ``confirm_substeps=0`` skips the confirmation
(cheaper, counts kinks). The recorded minimum is always the single step's; the sizes ``S =
−ΔH_n > 0`` follow from :func:`jamlab.analysis.avalanches.avalanche_sizes` (``plastic``, ``jammed``)
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from jamlab import validation
from jamlab.spheres.barostat import (
    POLISH_COUNT,
    box_side_guess,
    enthalpy_and_stress,
    leave_saddle,
    minimize_enthalpy,
    minimize_step,
    polish_recorded,
)
from jamlab.spheres.confirm import (
    LargestPiece,
    jump_in_chain,
    jump_located,
    residual_held,
    trapezoid_residual,
)
from jamlab.spheres.fire import FireParameters
from jamlab.spheres.newton_relax import RELAX_COUNTERS, NewtonRelaxer
from jamlab.spheres.potential import Packing, affine_shear
from jamlab.spheres.pressure_rows import (
    CANDIDATE_COUNTS,
    PRESSURE_COLUMNS,
    RETRY_COUNT,
    SADDLE_COUNT,
    PressureShearResult,
    append_row,
    can_be_plastic,
    minimizer_attribute,
    record_row,
    resumed_rows,
    run_result,
)
from jamlab.spheres.trace import Trace

__all__ = ["CONFIRM_BELOW", "FROM_AQS_OPTION", "MINIMIZERS", "PLASTIC_FLOOR", "PRESSURE_COLUMNS",
           "RETRY_COUNT", "RULES_BEFORE", "SADDLE_COUNT", "PressureShearResult",
           "minimizer_attribute", "shear_at_pressure"]

PLASTIC_FLOOR: float = 0.1  # shear_at_pressure's default: the flag's threshold is >= this × δγ²

CONFIRM_BELOW: float = 5.0
"""Default ``confirm_below`` of :func:`shear_at_pressure`: a candidate step that released for
certain more than this many times ``max(threshold, δγ²)`` is a jump without being redone."""

CONFIRMS: tuple[str, ...] = ("continued", "chain", "located")
"""Which candidate steps are redone in ``confirm_substeps`` pieces, and how (module docstring):
``continued`` — those the Newton relaxer did not continue (it used FIRE in the step); ``chain``
— all of them (the rule before; with plain FIRE both are ``chain``); ``located`` — those of
``continued``, each first decided on the one piece where the branch ends
(:func:`jamlab.spheres.confirm.jump_located`: Newton-only probes, no second FIRE run of the
event), the chain only where that piece, located by the probes alone, keeps less than the
bound (plain FIRE: ``continued``)."""

MINIMIZERS: tuple[str, ...] = ("newton", "fire")
"""Fixed-box minimisers of the inner problem: ``newton`` (:class:`~jamlab.spheres.newton_relax.
NewtonRelaxer`, FIRE where Newton does not apply) and ``fire`` (plain FIRE every time)."""

RULES_BEFORE: dict[str, str] = {"confirm": "chain", "volume_guess": validation.VOLUME_GUESS_BEFORE}
"""The rules a fixed-pressure trace without these attributes was made by (resume checks)."""

FROM_AQS_OPTION: dict[str, str] = {"linear": "newton", "fire": "fire"}
"""The inner minimiser for each ``minimizer`` option of :func:`jamlab.spheres.aqs.shear` (and
``jamlab shear --minimizer``)."""


def _advance(pressure: float, kw: dict, slope: float | None) -> Callable:
    """The fixed-pressure step of :func:`jamlab.spheres.confirm.jump_in_chain`: affine shear by
    ``dh``, then :func:`minimize_enthalpy` with the minimum it was made from as ``parent``.
    ``slope`` (``dp/d ln L``, the run's) starts each volume iteration, and from the second piece
    on the box side starts from the extrapolation of the chain's last two minima (as the steps
    do) — guesses only: the minima are those of the plain iteration, to its tolerance. Without
    ``slope`` (plain FIRE) no guesses are made."""
    lengths: list[float] = []

    def advance(cur: Packing, dh: float):
        guess = None
        if slope is not None and len(lengths) >= 2:
            guess = 2.0 * lengths[-1] - lengths[-2]
        res = minimize_enthalpy(affine_shear(cur, dh), pressure, parent=cur,
                                length_guess=guess, slope_guess=slope, **kw)
        if not lengths:
            lengths.append(cur.box.length)
        lengths.append(res.packing.box.length)
        return (res.packing, *enthalpy_and_stress(res.packing, pressure), res.iterations)

    return advance


def shear_at_pressure(
    packing: Packing,
    dgamma: float,
    gamma_max: float | None = None,
    pressure: float = 1e-4,
    *,
    n_steps: int | None = None,
    ftol: float = 1e-12,
    ptol: float = validation.DEFAULT_PTOL,
    fire_params: FireParameters | None = None,
    max_iter: int = 1_000_000,
    plastic_floor: float = PLASTIC_FLOOR,
    confirm_substeps: int = 16,
    confirm: str = "located",
    defer_confirmation: bool = True,
    confirm_below: float = CONFIRM_BELOW,
    volume_guess: str = validation.DEFAULT_VOLUME_GUESS,
    minimizer: str = "newton",
    progress: Callable[[int, int], None] | None = None,
    observer: Callable[[int, Packing], None] | None = None,
    previous: Trace | None = None,
    save_every: int | None = None,
    on_save: Callable[[int, PressureShearResult], None] | None = None,
    on_candidate: Callable[[int, Packing, Packing], None] | None = None,
) -> PressureShearResult:
    """AQS shear at fixed pressure ``pressure`` in steps ``δγ`` up to ``γ_max`` (the strain
    increment from the input's strain) or for ``n_steps`` steps (module docstring).

    The input is first brought to the target pressure (:func:`minimize_enthalpy`).
    ``volume_guess``: the box side a step starts from (``barostat.box_side_guess``; ``elastic``:
    extrapolated across elastic steps only). A step that does not converge is taken once more
    afresh (:func:`~jamlab.spheres.barostat.minimize_step`; attribute ``n_steps_retried``), then,
    if it still fails, recorded with ``converged=False`` and the run goes on from it.
    ``observer(n, packing)`` (if given) sees every recorded minimum, row 0 included.

    Checkpoints and resume: every ``save_every`` steps (and not after the last) ``on_save(n,
    result)`` receives the run so far (its plastic flags provisional: they are judged on the whole
    run). ``previous``: the trace of such a result (with its group ``fixed_pressure``), continued
    from ``packing`` — its last minimum, not minimised again; the steps count from ``previous``'s
    row 0 and ``n_steps``/``gamma_max`` are those of the whole run. A step depends only on the last
    minimum and the last two box sides, so the continued run equals the uninterrupted one bit for
    bit (``tests/spheres/test_pressure_shear.py``).

    ``on_candidate(n, minimum before, minimum after)`` (if given) sees every step whose trapezoid
    residual exceeds half the candidates' floor, ``|r_n| > ½ plastic_floor · δγ²``: a superset of
    the steps that can end up plastic, whose verdicts are known only when the run is (e.g. to keep
    the minima of every step that may need an avalanche record).

    ``defer_confirmation`` (default): a candidate step to be redone is kept (its start minimum and
    the volume slope) and redone only if it can be plastic — after the run, when the plastic
    threshold of the whole run is known, those with ``|r_n|`` above it and both minima jammed; at a
    checkpoint, all kept so far (so a resumed run needs nothing that the trace does not hold). The
    flags are those of the immediate rule (``False``: every candidate redone when it happens, e.g.
    to study the verdicts themselves); only the steps' order of work differs.

    ``confirm_below`` (default 5): a candidate that released for certain more than ``confirm_below ·
    max(threshold, δγ²)`` (:func:`~jamlab.spheres.confirm.released_at_least`: ``−r_n − ½ δγ |G δγ −
    ΔΣ_n|``) is plastic without the confirmation — a kink releases nothing and the stress drop of a
    small event is accounted for; no candidate the confirmation rejected came near (``docs/aqs.md``,
    measured) — and with ``defer_confirmation`` it is not redone. ``math.inf`` confirms every
    candidate (the rule before). The stepping, and so every column but ``plastic`` and
    ``iterations`` (which counts the confirmation's), does not depend on it.
    """
    if not (validation.is_real(dgamma) and math.isfinite(dgamma) and dgamma > 0):
        raise ValueError(f"dgamma must be finite and > 0, got dgamma={dgamma!r}")
    dgamma = float(dgamma)
    if (gamma_max is None) == (n_steps is None):
        raise ValueError("give exactly one of gamma_max and n_steps")
    if n_steps is None:
        if not (math.isfinite(gamma_max) and gamma_max > dgamma):
            raise ValueError(f"need dgamma < gamma_max, got {dgamma!r}, {gamma_max!r}")
        total = int(round(gamma_max / dgamma))
    else:
        if not (validation.is_integer(n_steps) and n_steps >= 1):
            raise ValueError(f"n_steps must be an integer >= 1, got n_steps={n_steps!r}")
        total = int(n_steps)
    validation.save_every(save_every)
    if confirm not in CONFIRMS:
        raise ValueError(f"confirm must be one of {', '.join(CONFIRMS)}, got {confirm!r}")
    if not (validation.is_real(confirm_below) and confirm_below >= 1.0):
        raise ValueError(f"confirm_below must be >= 1 (math.inf: confirm every candidate), "
                         f"got confirm_below={confirm_below!r}")
    confirm_below = float(confirm_below)
    validation.volume_guess(volume_guess)
    for name, value in (("confirm", confirm), ("volume_guess", volume_guess)):
        was = None if previous is None else previous.attrs.get(name, RULES_BEFORE[name])
        if was is not None and was != value:
            raise ValueError(f"{name}={value!r} differs from the run being resumed ({was!r})")
    if minimizer not in MINIMIZERS:
        raise ValueError(f"minimizer must be one of {', '.join(MINIMIZERS)}, got {minimizer!r}")
    relaxer = NewtonRelaxer() if minimizer == "newton" else None
    if relaxer is not None and previous is not None:
        # a resumed trace is one run: its counters cover every step
        for k in RELAX_COUNTERS:
            relaxer.counters[k] = int(previous.attrs.get(k, 0))
    kw = dict(ftol=ftol, ptol=ptol, max_iter=max_iter, params=fire_params, relax=relaxer)
    slope = None  # dp/d ln L of the last step (Newton path only; plain FIRE makes no guesses)
    t0 = time.perf_counter()
    names = [k for k in PRESSURE_COLUMNS if k not in ("enthalpy_jump", "stress_jump", "plastic")]
    confirmed = np.zeros(total + 1, dtype=bool)
    held = np.zeros(total + 1)  # per row: the residual a kink-called candidate's piece held
    continued = np.zeros(total + 1, dtype=bool)
    pending: list = []  # candidates kept: (row, start minimum, slope, step, r, end minimum)
    if previous is None:
        gamma0 = packing.strain
        res, pushes = leave_saddle(minimize_enthalpy(packing, pressure, **kw), pressure, kw, True)
        counts = dict.fromkeys(CANDIDATE_COUNTS, 0) | {SADDLE_COUNT: pushes, RETRY_COUNT: 0}
        res, counts[POLISH_COUNT] = polish_recorded(res, kw)
        rows = {k: [] for k in names}
        append_row(rows, gamma0, record_row(res, ftol))
        cur = res.packing
        first = 1
        if observer is not None:
            observer(0, cur)
    else:
        rows, confirmed_before, held_before, counts = resumed_rows(previous, names)
        gamma0 = rows["gamma"][0]
        first = len(rows["gamma"])
        if first > total:
            raise ValueError(f"nothing to do: the trace already has {first - 1} >= {total} steps")
        confirmed[:first] = confirmed_before
        held[:first] = held_before
        cur = packing
    for n in range(first, total + 1):
        target = gamma0 + n * dgamma
        guess = None if n < 2 else box_side_guess(volume_guess, *(rows[k][-2:] for k in (
            "gamma", "enthalpy", "shear_stress", "box_length")), plastic_floor)
        departed_before = _departures(relaxer)
        res, retried = minimize_step(affine_shear(cur, target - cur.strain), cur, pressure, kw,
                                     guess, slope)
        counts[RETRY_COUNT] += retried
        row = record_row(res, ftol)  # tested where FIRE took part, or the flag rejects the minimum:
        res, pushes = leave_saddle(res, pressure, kw, res.iterations > 0 or not row["jammed"])
        counts[SADDLE_COUNT] += pushes
        continued[n] = relaxer is not None and _departures(relaxer) == departed_before
        if relaxer is not None and math.isfinite(res.slope):
            slope = res.slope
        row = record_row(res, ftol) if pushes else row
        res, polished = polish_recorded(res, kw, row["max_force"])  # the row's own evaluation
        counts[POLISH_COUNT] += polished
        row = record_row(res, ftol) if polished else row
        step = target - rows["gamma"][-1]
        r = trapezoid_residual(rows["enthalpy"][-1], rows["shear_stress"][-1],
                               row["enthalpy"], row["shear_stress"], step)
        if on_candidate is not None and abs(r) > 0.5 * plastic_floor * step**2:
            # the margin ½ covers the rounding between r_n here and the threshold's residual
            on_candidate(n, cur, res.packing)
        if confirm_substeps > 1:
            if abs(r) > plastic_floor * step**2:
                counts["n_candidates"] += 1
                if confirm != "chain" and continued[n]:
                    # Newton continued the branch through the step: a kink
                    counts["n_candidates_continued"] += 1
                else:
                    pending.append((n, cur, slope, step, r, res.packing))
        cur = res.packing
        append_row(rows, target, row)
        if pending and not defer_confirmation:
            _confirm(pending, rows, confirmed, held, pressure, kw, confirm_substeps, confirm,
                     counts, plastic_floor)
        if observer is not None:
            observer(n, cur)
        if progress is not None:
            progress(n, total)
        if save_every is not None and n % save_every == 0 and n < total:
            # a restart point: every kept candidate is redone now (a resumed run starts without
            # them), then the solver state (stored factor, slope) is dropped, as a run resumed
            # from this checkpoint starts without it
            _confirm(pending, rows, confirmed, held, pressure, kw, confirm_substeps, confirm,
                     counts, plastic_floor)
            slope = None
            if relaxer is not None:
                relaxer.reset()
            if on_save is not None:
                on_save(n, run_result(rows, confirmed[: n + 1], held[: n + 1],
                                      continued[: n + 1], cur, counts, t0, dgamma, total,
                                      gamma0, pressure, ptol, ftol,
                                      plastic_floor, confirm_substeps, confirm, packing,
                                      minimizer, relaxer, defer_confirmation, confirm_below,
                                      volume_guess))
    if pending:
        # the run's threshold is known now: redo only the kept candidates that can be plastic,
        # and of those only the ones that did not surely release more than confirm_below ·
        # max(threshold, δγ²) (released_at_least; run_result flags the others)
        can, sure = can_be_plastic(rows, dgamma, plastic_floor, confirm_below)
        counts["n_candidates_below_threshold"] += sum(not can[n] for n, *_ in pending)
        counts["n_candidates_sure"] += sum(bool(sure[n]) for n, *_ in pending)
        _confirm([c for c in pending if can[c[0]] and not sure[c[0]]], rows, confirmed, held,
                 pressure, kw, confirm_substeps, confirm, counts, plastic_floor)
    return run_result(rows, confirmed, held, continued, cur, counts, t0, dgamma, total, gamma0,
                      pressure, ptol, ftol, plastic_floor, confirm_substeps, confirm, packing,
                      minimizer, relaxer, defer_confirmation, confirm_below, volume_guess)


def _confirm(pending: list, rows: dict, confirmed: np.ndarray, held: np.ndarray,
             pressure: float, kw: dict, k: int, confirm: str, counts: dict,
             plastic_floor: float) -> None:
    """Redo each kept candidate ``(n, start minimum, slope, step, r, end minimum)`` in ``k``
    pieces (:func:`jump_in_chain`; with ``confirm="located"`` and the Newton relaxer first
    :func:`jump_located`): its verdict into ``confirmed[n]``; where the chain found no jump and
    its largest piece kept more than half the candidates' floor ``½ plastic_floor · δγ²``, that
    piece redone in sub-pieces (:func:`residual_held`) and the residual it holds into
    ``held[n]`` (:func:`~jamlab.spheres.pressure_rows.run_result` flags it when above the run's
    threshold); the iterations spent added to row ``n``; empties ``pending``."""
    relaxer = kw.get("relax")
    for n, start, slope, step, r, end in pending:
        # rows n − 1 and n are the start's and the end's own H and Σ (record_row evaluated them; r_n
        # was computed from them)
        v0, s0 = rows["enthalpy"][n - 1], rows["shear_stress"][n - 1]
        largest = LargestPiece()
        jump = None
        if confirm == "located" and isinstance(relaxer, NewtonRelaxer):
            spent: list[int] = []
            jump, _ = jump_located(
                _probe(pressure, kw, slope, relaxer, spent),
                _counted(_advance(pressure, kw, slope), spent), start, v0, s0, end,
                rows["enthalpy"][n], rows["shear_stress"][n], step, r, k, largest=largest)
            rows["iterations"][n] += sum(spent)
            if jump is not None:  # (False: the chain's pieces ran inside, none kept the bound)
                confirmed[n] = jump
                counts["n_candidates_located"] += int(jump)
        if jump is None:
            confirmed[n], extra = jump_in_chain(
                _advance(pressure, kw, slope), start, v0, s0, step, r, k,
                v_end=rows["enthalpy"][n], largest=largest)
            rows["iterations"][n] += extra
        if not confirmed[n] and abs(largest.residual) > 0.5 * plastic_floor * step**2:
            held[n], extra = residual_held(_advance(pressure, kw, slope), largest)
            rows["iterations"][n] += extra
    pending.clear()


def _counted(advance: Callable, spent: list[int]) -> Callable:
    """``advance`` with its iterations appended to ``spent``."""

    def piece(cur: Packing, dh: float):
        out = advance(cur, dh)
        spent.append(out[3])
        return out

    return piece


def _probe(pressure: float, kw: dict, slope: float | None, relaxer: NewtonRelaxer,
           spent: list[int]) -> Callable:
    """The probe of :func:`jump_located`: affine shear by ``dh`` (either sign), then
    :func:`minimize_enthalpy` with the relaxer's Newton alone (:meth:`NewtonRelaxer.newton_only`)
    and the minimum it was made from as ``parent``; ``(minimum, H, Σ)`` or ``None`` where
    Newton cannot reach a minimum (the branch of ``packing`` does not reach that strain).
    Iterations (FIRE polishing a caged rattler) are appended to ``spent``."""
    opts = {**kw, "relax": relaxer.newton_only}

    def probe(cur: Packing, dh: float):
        res = minimize_enthalpy(affine_shear(cur, dh), pressure, parent=cur, slope_guess=slope,
                                **opts)
        spent.append(res.iterations)
        if not res.converged:
            return None
        return res.packing, *enthalpy_and_stress(res.packing, pressure)

    return probe


def _departures(relaxer: NewtonRelaxer | None) -> int:
    """How often the Newton relaxer has departed from continuing the parent's branch so far:
    used FIRE (fallbacks and rattler polish), or settled rattlers that could not be freed one
    at a time (moved together, or a caged one put on the backbone for another Newton run).
    A step with any of these is not "continued": it is confirmed as a polished one was before
    the rattlers were settled without FIRE (``docs/aqs.md``, "Caged rattlers without FIRE":
    counted as continued, two steps in 8000 at N = 250 lost the flag the confirmation gives)."""
    if relaxer is None:
        return -1
    c = relaxer.counters
    return (c["n_fire_fallbacks"] + c["n_rattler_polish"] + c["n_rattler_rejoined"]
            + c["n_rattlers_moved_together"])
