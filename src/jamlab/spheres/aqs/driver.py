"""The AQS driver: :func:`shear` steps the strain and hands each step to a strategy of
:class:`~jamlab.spheres.aqs.steps.Stepper` (the lean step, the branch continuation, FIRE; the
method: :mod:`jamlab.spheres.aqs`)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jamlab import validation
from jamlab.spheres.aqs.anatomy import MOVED_THRESHOLD, AvalancheRecorder
from jamlab.spheres.aqs.checkpoint import checkpoint_paths, save_checkpoint
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.aqs.record import (
    ROW_KEYS,
    append_row,
    invocations,
    jamlab_version,
    make_trace,
    observe,
    resumed_rows,
)
from jamlab.spheres.aqs.saddle import descend
from jamlab.spheres.aqs.steps import Step, Stepper
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.neighbors import RELAX_SKIN
from jamlab.spheres.potential import NeighborList, Packing
from jamlab.spheres.trace import Trace

__all__ = ["MINIMIZERS", "ShearResult", "checkpoint_paths", "n_steps_for", "shear"]

MINIMIZERS = ("linear", "fire")


@dataclass(frozen=True, eq=False)
class ShearResult:
    """Outcome of :func:`shear`: the ``trace``, the final minimum ``packing`` and counters.

    ``n_fallback``: steps where continuation failed and FIRE carried the step; ``n_substepped``:
    steps the fast path had to subdivide; ``n_cleanup``: steps where FIRE relaxed rattler forces
    after Newton; ``n_not_converged``: recorded minima with ``max_force ≥ ftol``; ``time``: wall
    clock seconds of the stepping loop.
    """

    trace: Trace
    packing: Packing
    n_fallback: int
    n_substepped: int
    n_cleanup: int
    n_not_converged: int
    time: float

    @classmethod
    def of_trace(cls, trace: Trace, packing: Packing) -> ShearResult:
        """The result of a finished run rebuilt from its saved ``trace`` and last ``packing`` (a
        run whose process ended after writing its final trace): the counters are the trace's
        (they cover the whole run, a resumed one too); ``time`` is 0, it was not measured."""
        if trace.attrs.get("protocol") == "fixed-pressure":
            # the fixed-pressure result has no continuation counters; its convergence is the
            # force and the pressure, recorded in the attribute
            counts, bad = (0, 0, 0), int(trace.attrs["n_not_converged"])
        else:
            counts = tuple(int(trace.attrs.get(k, 0))
                           for k in ("n_fallback", "n_substepped", "n_cleanup"))
            bad = int(np.count_nonzero(trace.max_force >= float(trace.attrs["ftol"])))
        return cls(trace, packing, *counts, n_not_converged=bad, time=0.0)


def n_steps_for(dgamma: float, gamma_max: float, gamma0: float = 0.0) -> int:
    """``M = round(γ_max / δγ)`` strain steps from ``γ_0``; validated by
    :func:`jamlab.validation.strain_steps` (``0 < δγ < γ_max``, at most ``MAX_STEPS`` steps,
    ``δγ`` resolved at strain ``|γ_0| + γ_max``)."""
    return validation.strain_steps(dgamma, gamma_max, gamma0)


def shear(
    packing: Packing,
    dgamma: float,
    gamma_max: float | None = None,
    *,
    n_steps: int | None = None,
    minimizer: str = "linear",
    ftol: float = 1e-12,
    classify: bool = True,
    params: AQSParameters | None = None,
    fire_params: FireParameters | None = None,
    save_every: int | None = None,
    out: str | Path | None = None,
    previous: Trace | None = None,
    source: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    after_step: Callable[[Packing, Packing, Step], None] | None = None,
    on_plastic: Callable[[int, Packing, Packing], None] | None = None,
    keep_avalanches: bool = False,
    avalanche_threshold: float | None = None,
    pressure: float | None = None,
    ptol: float = validation.DEFAULT_PTOL,
    confirm: str = "located",
    confirm_below: float | None = None,
    volume_guess: str | None = None,
) -> ShearResult:
    """AQS shear of ``packing`` in steps ``δγ`` up to ``γ_max`` (or for ``n_steps`` steps).

    Strains are ``γ_n = γ_0 + n δγ`` (no accumulated rounding), ``γ_0`` the strain of the input
    (or of row 0 of ``previous``). The input is first minimised with FIRE if its largest force is
    ``≥ ftol``. ``minimizer``: ``"linear"`` (linear response + chord Newton, FIRE fallback) or
    ``"fire"`` (plain FIRE every step; ``classify=False`` skips the continuation test and leaves
    ``plastic`` all False). See the module docstring for the elastic/plastic rule.

    ``out``: trace file to write (atomically) at the end and every ``save_every`` steps, together
    with the configuration (:func:`checkpoint_paths`). ``previous``: a trace to continue (resume);
    ``packing`` must then be the configuration at ``previous.gamma[-1]``.

    ``after_step(previous minimum, new minimum, step)``: called after every strain step (``step``
    a :class:`~jamlab.spheres.aqs.steps.Step`, ``step.plastic`` its verdict; constant volume
    only: at fixed pressure the verdicts exist only at the end of the run, and it is refused).
    ``on_plastic(row, minimum before, minimum after)``: called for every step flagged plastic,
    in order — at constant volume as the step ends, at fixed pressure once the run's verdicts
    are known (the minima of the steps that may be plastic are then kept in memory, as for
    ``keep_avalanches``, and such a run cannot be resumed); ``row`` is the step's trace row.
    ``keep_avalanches``: the trace gets the group ``avalanches`` (one row per plastic step, the
    anatomy of :mod:`jamlab.spheres.aqs.anatomy`; displacements above ``avalanche_threshold``,
    default :data:`~jamlab.spheres.aqs.anatomy.MOVED_THRESHOLD`); it is written with every
    checkpoint and the final trace, so a resumed run keeps the rows before it. At fixed
    pressure the minima of the steps that may be plastic are kept in memory until the verdicts
    are known, the dilation of each step is part of its affine map, and a run with it cannot be
    resumed.
    ``pressure``: shear at this fixed pressure instead of at constant volume
    (:func:`jamlab.spheres.pressure_shear.shear_at_pressure`: positions and box side relaxed to
    ``max|F_i| < ftol`` and ``|p − p_t| ≤ max(ptol·p_t, p_floor)``; the trace's ``energy`` column
    is the enthalpy, ``phi`` is ``φ(γ)``; ``minimizer`` picks the inner minimiser, ``params``
    does not apply). ``confirm``: which candidate plastic steps a fixed-pressure run redoes in
    pieces (:data:`jamlab.spheres.pressure_shear.CONFIRMS`), and ``confirm_below`` how many times
    ``max(threshold, δγ²)`` a candidate must surely have released to be a jump without being
    redone (``None``: the default :data:`~jamlab.spheres.pressure_shear.CONFIRM_BELOW`;
    ``math.inf``: every candidate redone). ``volume_guess``: where a fixed-pressure step starts
    its box side (:data:`jamlab.validation.VOLUME_GUESSES`; ``None``: ``"elastic"``). Every trace
    has the ``jammed`` column.

    Parameters
    ----------
    packing : Packing
        The start (any pair law); minimised first if ``max|F_i| ≥ ftol``.
    dgamma : float
        The strain step ``δγ > 0``.
    gamma_max, n_steps : float or int
        Give exactly one: the final strain or the number of steps.
    minimizer, ftol, classify, params, fire_params
        The step method and its tolerances (see above and :class:`AQSParameters`).
    save_every, out, previous, source, progress, after_step, on_plastic, keep_avalanches, \
avalanche_threshold, pressure, ptol, confirm, confirm_below, volume_guess
        Checkpoints, resume, bookkeeping and options (see above).

    Returns
    -------
    ShearResult
        ``trace`` (:class:`~jamlab.spheres.trace.Trace`: ``γ, E, Σ, p, z, z_nr, max|F|``,
        iterations, ``ΔE``, ``ΔΣ``, ``plastic``, ``jammed`` per row), the final ``packing`` and
        counters.

    Examples
    --------
    >>> import numpy as np
    >>> from jamlab.spheres import prepare, shear
    >>> start = prepare(64, 3, 0.8, seed=1).packing       # an UNSAT packing, φ = 0.8
    >>> tr = shear(start, 1e-4, n_steps=50).trace
    >>> tr.n_steps, round(float(tr.gamma[-1]), 12), bool(tr.jammed.all())
    (50, 0.005, True)
    >>> bool((tr.max_force < 1e-12).all()), int(tr.plastic.sum())
    (True, 0)

    Along an elastic branch ``Σ = dE/dγ``: the trapezoid rule holds far below ``|ΔE|``.

    >>> de = np.diff(tr.energy)
    >>> trapezoid = 0.5 * np.diff(tr.gamma) * (tr.shear_stress[1:] + tr.shear_stress[:-1])
    >>> bool(np.abs(de - trapezoid).max() < 1e-3 * np.abs(de).min())
    True
    """
    if previous is not None and previous.avalanches is not None and not keep_avalanches:
        # the resumed trace would be written without them: the records would be lost
        raise ValueError("the run being resumed kept avalanche records: resume it with "
                         "keep_avalanches (--keep-avalanches), or not at all")
    if (previous is not None and previous.avalanches is None and keep_avalanches
            and pressure is None):
        # the table would start at the resumption: the earlier plastic steps without records,
        # and nothing in the file to say so
        raise ValueError("the run being resumed kept no avalanche records: its earlier plastic "
                         "steps would have none; resume it without keep_avalanches "
                         "(--keep-avalanches), or run it anew")
    if previous is not None and previous.avalanches is not None:
        kept = float(previous.avalanches.get("attrs", {}).get("threshold", MOVED_THRESHOLD))
        asked = MOVED_THRESHOLD if avalanche_threshold is None else float(avalanche_threshold)
        if asked != kept:
            # one threshold labels the whole table: its earlier rows used the recorded one
            raise ValueError(f"avalanche_threshold={asked!r} differs from the run being resumed "
                             f"({kept!r}); resume it with the same --avalanche-threshold")
    if avalanche_threshold is not None and not keep_avalanches:
        raise ValueError("avalanche_threshold applies to keep_avalanches (--keep-avalanches): "
                         "give it too")
    if pressure is None and volume_guess is not None:
        raise ValueError("volume_guess applies to fixed-pressure shear only: give pressure too")
    if pressure is not None:
        if minimizer not in MINIMIZERS:
            raise ValueError(f"minimizer must be one of {MINIMIZERS}, got minimizer={minimizer!r}")
        if after_step is not None:
            raise ValueError("after_step is not available at fixed pressure: the plastic verdicts "
                             "are judged on the whole run, after its last step")
        if params is not None or not classify:
            raise ValueError("params and classify=False apply to constant-volume shear only, not "
                             "with pressure")
        return _shear_at_pressure(
            minimizer,
            packing,
            dgamma,
            gamma_max,
            n_steps,
            pressure,
            ptol,
            ftol,
            fire_params,
            save_every,
            out,
            previous,
            source,
            progress,
            confirm,
            confirm_below,
            keep_avalanches,
            avalanche_threshold,
            on_plastic,
            validation.DEFAULT_VOLUME_GUESS if volume_guess is None else volume_guess,
        )
    if minimizer not in MINIMIZERS:
        raise ValueError(f"minimizer must be one of {MINIMIZERS}, got minimizer={minimizer!r}")
    total, dgamma, ftol = _run_length(
        packing, dgamma, gamma_max, n_steps, ftol, save_every, out, previous
    )
    params = AQSParameters() if params is None else params
    fire_params = FireParameters() if fire_params is None else fire_params
    if previous is not None and previous.attrs.get("floppy", "fire") != params.floppy:
        raise ValueError(f"floppy={params.floppy!r} differs from the run being resumed "
                         f"({previous.attrs.get('floppy', 'fire')!r})")

    nl = NeighborList(packing, skin=RELAX_SKIN)
    rows: dict[str, list] = {k: [] for k in ROW_KEYS}
    if previous is None:
        gamma0 = packing.strain
        start_iterations = 0
        cur = packing
        row, backbone = observe(cur, nl)
        if row["max_force"] >= ftol:
            res = minimize(cur, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            cur, start_iterations = res.packing, res.iterations
            row, backbone = observe(cur, nl)
        # a saddle is not a minimum to start from (saddle.py); its factorisation is the stepper's
        cur, row, backbone, start_factor, descent_iterations, made = descend(
            cur, row, backbone, nl, ftol, params.max_fire_iter, fire_params
        )
        start_iterations += descent_iterations
        append_row(rows, cur.strain, row, start_iterations, False)
        first = 1
    else:
        gamma0 = float(previous.gamma[0])
        cur = packing
        last_row, backbone = observe(cur, nl)
        rows = resumed_rows(previous, last_row)
        first = previous.n_steps + 1
    if first > total:
        raise ValueError(f"nothing to do: the trace already has {first - 1} >= {total} steps")

    attrs = {
        "dgamma": float(dgamma),
        "gamma_max": float(gamma0 + total * dgamma),
        "n_steps": int(total),
        "ftol": float(ftol),
        "minimizer": minimizer,
        "floppy": params.floppy,
        "N": int(packing.n),
        "dim": int(packing.dim),
        "phi": float(packing.phi),
        "box_length": float(packing.box.length),
        "alpha": float(packing.alpha),
        "monodisperse": bool(packing.monodisperse),
        "seed": int(-1 if packing.seed is None else packing.seed),
        "jamlab_version": jamlab_version(),
        "source": "" if source is None else str(source),
        "save_every": int(0 if save_every is None else save_every),
        "provenance": invocations(previous),
    }
    counters = {
        "n_fallback": 0,
        "n_substepped": 0,
        "n_cleanup": 0,
        "n_factorisations": 1 if previous is not None else made,
        "n_lean": 0,
    }
    if previous is not None:
        # a resumed trace is one run: its counters cover every step, not only the resumed ones
        for key in counters:
            counters[key] += int(previous.attrs.get(key, 0))

    def restart(cur: Packing) -> tuple[Packing, NeighborList, Stepper]:
        # the solver state (neighbour list, factorisation, predictor, contact flags) derived
        # from the configuration and the last row alone, as a resumed run derives it
        cur = Packing(
            np.array(cur.positions), cur.box, seed=cur.seed, diameters=cur.diameters,
            alpha=cur.alpha,
        )  # fmt: skip
        nl = NeighborList(cur, skin=RELAX_SKIN)
        _, backbone = observe(cur, nl)
        prev = {"gamma": rows["gamma"][-1], **{k: rows[k][-1] for k in ROW_KEYS if k != "gamma"}}
        stepper = Stepper(
            cur, backbone, prev, nl, dgamma, ftol, minimizer, classify, params, fire_params,
            counters,
        )  # fmt: skip
        return cur, nl, stepper

    if previous is None:
        prev = {"gamma": rows["gamma"][-1], **{k: rows[k][-1] for k in ROW_KEYS if k != "gamma"}}
        stepper = Stepper(
            cur, backbone, prev, nl, dgamma, ftol, minimizer, classify, params, fire_params,
            counters, fac=start_factor,
        )  # fmt: skip
    else:
        cur, nl, stepper = restart(cur)
    hooks = [] if after_step is None else [after_step]
    recorder = None
    if keep_avalanches:
        recorder = AvalancheRecorder(
            first,
            MOVED_THRESHOLD if avalanche_threshold is None else avalanche_threshold,
            previous=None if previous is None else previous.avalanches,
        )
        hooks.append(recorder)

    def with_records(trace: Trace) -> Trace:
        # the avalanche rows so far: in every checkpoint too, so that a resumed run keeps them
        if recorder is None:
            return trace
        return trace.with_avalanches(
            recorder.table(trace.energy_jump, trace.stress_jump, packing.dim)
        )

    t0 = time.perf_counter()
    for n in range(first, total + 1):
        target = gamma0 + n * dgamma
        step = stepper.take(cur, target)
        before = cur
        cur, row, backbone, iterations, cleaned = stepper.settle(step)
        for hook in hooks:
            hook(before, cur, step)
        if on_plastic is not None and step.plastic:
            on_plastic(n, before, cur)
        append_row(rows, target, row, iterations, step.plastic)
        restart_here = out is not None and save_every is not None and n % save_every == 0 \
            and n < total
        # at a restart point the stepper's state is rebuilt below, as a resumed run builds it: a
        # factorisation made for the next step here would be thrown away (and counted, which a
        # run resumed from this checkpoint does not)
        stepper.advance(step, cur, row, backbone, cleaned, target, last=n == total or restart_here)
        if progress is not None:
            progress(n, total)
        if restart_here:
            save_checkpoint(out, with_records(make_trace(rows, attrs, counters)), cur, n,
                            snapshot=True)  # fmt: skip
            # a restart point: from here on the run is what `--resume` from this checkpoint
            # computes, bit for bit (docs/aqs.md, "Checkpoints and resume")
            counters["n_factorisations"] += 1
            cur, nl, stepper = restart(cur)
    elapsed = time.perf_counter() - t0
    trace = with_records(make_trace(rows, attrs, counters))
    if out is not None:
        # the final trace (with the avalanches, if kept) and its last minimum
        save_checkpoint(out, trace, cur, total, snapshot=save_every is not None)
    return ShearResult(
        trace=trace,
        packing=cur,
        n_fallback=counters["n_fallback"],
        n_substepped=counters["n_substepped"],
        n_cleanup=counters["n_cleanup"],
        n_not_converged=int(np.count_nonzero(trace.max_force >= ftol)),
        time=elapsed,
    )


def _run_length(
    packing, dgamma, gamma_max, n_steps, ftol, save_every, out, previous
) -> tuple[int, float, float]:
    """The number of strain steps of a run, and ``δγ`` and ``ftol`` as Python floats (a numpy
    ``float32`` argument is computed with in float64), after checking what both protocols take
    alike: ``ftol``, exactly one of ``gamma_max``/``n_steps`` (``δγ`` resolvable at the strain),
    ``save_every`` (with an output path), and for a resumed run a configuration at the strain
    of the trace's last row."""
    if not (validation.is_real(ftol) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    if (gamma_max is None) == (n_steps is None):
        raise ValueError("give exactly one of gamma_max and n_steps")
    start_strain = packing.strain if previous is None else float(previous.gamma[0])
    if n_steps is None:
        total = n_steps_for(dgamma, gamma_max, start_strain)
    else:
        if not validation.is_integer(n_steps):
            raise ValueError(f"n_steps must be an integer >= 1, got n_steps={n_steps!r}")
        total = validation.integer("n_steps", n_steps, minimum=1, maximum=validation.MAX_STEPS)
        validation.strain_steps(dgamma, (total + 0.5) * dgamma, start_strain)
    validation.save_every(save_every, out, needs_out=True)
    if previous is not None and not math.isclose(
        packing.strain, float(previous.gamma[-1]), rel_tol=0, abs_tol=1e-15
    ):
        raise ValueError(
            f"configuration strain {packing.strain} does not match the trace's last strain "
            f"{previous.gamma[-1]}"
        )
    return total, float(dgamma), float(ftol)


def _shear_at_pressure(
    minimizer,
    packing,
    dgamma,
    gamma_max,
    n_steps,
    pressure,
    ptol,
    ftol,
    fire_params,
    save_every,
    out,
    previous,
    source,
    progress,
    confirm,
    confirm_below,
    keep_avalanches,
    avalanche_threshold,
    on_plastic,
    volume_guess,
) -> ShearResult:
    """The fixed-pressure protocol behind :func:`shear` (its docstring): ``minimizer``
    ``linear`` is the Newton inner minimiser at fixed pressure (``newton``), ``fire`` plain
    FIRE. ``keep_avalanches`` or ``on_plastic``: the minima of every step that may end up
    plastic are kept in memory during the run (``on_candidate`` of :func:`shear_at_pressure`);
    once the verdicts are known the avalanche rows of the steps flagged plastic are measured on
    them and ``on_plastic`` sees them."""
    from jamlab.spheres.pressure_shear import CONFIRM_BELOW, FROM_AQS_OPTION, shear_at_pressure

    pressure = validation.positive("pressure", pressure)
    ptol = validation.positive("ptol", ptol)
    total, dgamma, ftol = _run_length(
        packing, dgamma, gamma_max, n_steps, ftol, save_every, out, previous
    )
    if previous is not None and previous.attrs.get("protocol") != "fixed-pressure":
        raise ValueError("the trace to resume is not a fixed-pressure run")
    recorder = AvalancheRecorder(
        1, MOVED_THRESHOLD if avalanche_threshold is None else avalanche_threshold
    ) if keep_avalanches else None
    # what sees each plastic step's minima once the verdicts are known: (row, before, after)
    plastic_hooks = [] if recorder is None else [recorder.record]
    if on_plastic is not None:
        plastic_hooks.append(on_plastic)
    if plastic_hooks and previous is not None:
        raise ValueError("keep_avalanches and on_plastic cannot resume a fixed-pressure run: "
                         "the plastic flags of its earlier steps are judged again on the whole "
                         "run and their minima are not stored; run it uninterrupted")
    kept: dict[int, tuple[Packing, Packing]] = {}

    def keep(n: int, before: Packing, after: Packing) -> None:
        kept[n] = (before, after)
    extra_attrs = {
        "alpha": float(packing.alpha),
        "monodisperse": bool(packing.monodisperse),
        "jamlab_version": jamlab_version(),
        "source": "" if source is None else str(source),
        "save_every": int(0 if save_every is None else save_every),
        "provenance": invocations(previous),
        # the input's box side (row 0 is already at the target pressure), for resume checks
        "input_box_length": float(packing.box.length if previous is None
                                  else previous.attrs["input_box_length"]),
    }

    def finished(result) -> Trace:
        trace = result.trace()
        trace.attrs.update({
            "phi": float(result.columns["phi"][0]),
            "box_length": float(result.columns["box_length"][0]),
            **extra_attrs,
        })
        return trace

    def save(n: int, result) -> None:
        save_checkpoint(out, finished(result), result.packing, n, snapshot=True)

    res = shear_at_pressure(
        packing,
        dgamma,
        pressure=pressure,
        n_steps=total,
        ftol=ftol,
        ptol=ptol,
        fire_params=fire_params,
        minimizer=FROM_AQS_OPTION[minimizer],
        confirm=confirm,
        confirm_below=CONFIRM_BELOW if confirm_below is None else confirm_below,
        volume_guess=volume_guess,
        progress=progress,
        previous=previous,
        save_every=save_every,
        on_save=save if out is not None else None,
        on_candidate=keep if plastic_hooks else None,
    )
    trace = finished(res)
    for n in np.flatnonzero(trace.plastic) if plastic_hooks else ():
        if int(n) not in kept:  # on_candidate's floor is a necessary condition of the flag
            raise RuntimeError(f"step {int(n)} is plastic but its minima were not kept")
        for hook in plastic_hooks:
            hook(int(n), *kept[int(n)])
    if recorder is not None:
        trace = trace.with_avalanches(
            recorder.table(trace.energy_jump, trace.stress_jump, packing.dim)
        )
    if out is not None:
        save_checkpoint(out, trace, res.packing, total, snapshot=save_every is not None)
    return ShearResult(
        trace=trace,
        packing=res.packing,
        n_fallback=0,
        n_substepped=0,
        n_cleanup=0,
        n_not_converged=res.n_not_converged,
        time=res.time,
    )
