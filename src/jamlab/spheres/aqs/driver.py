"""The AQS driver: :func:`shear` steps the strain and hands each step to the fast path, the
branch continuation or FIRE (the method: :mod:`jamlab.spheres.aqs`)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jamlab.spheres.aqs.checkpoint import checkpoint_paths, jamlab_version, save_checkpoint
from jamlab.spheres.aqs.classify import same_minimum
from jamlab.spheres.aqs.continuation import Branch, continue_network
from jamlab.spheres.aqs.lean import consistent_flags, lean_step
from jamlab.spheres.aqs.linalg import factorise
from jamlab.spheres.aqs.network import affine_to, contact_keys
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.aqs.predictor import BranchPath, Secants
from jamlab.spheres.aqs.record import ROW_KEYS, append_row, make_trace, observe
from jamlab.spheres.fire import FireParameters, minimize
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


def n_steps_for(dgamma: float, gamma_max: float) -> int:
    """``M = round(γ_max / δγ)`` strain steps; validates ``0 < δγ < γ_max``."""
    if not (isinstance(dgamma, int | float) and math.isfinite(dgamma) and dgamma > 0):
        raise ValueError(f"dgamma must be finite and > 0, got dgamma={dgamma!r}")
    if not (isinstance(gamma_max, int | float) and math.isfinite(gamma_max)):
        raise ValueError(f"gamma_max must be finite, got gamma_max={gamma_max!r}")
    if not gamma_max > dgamma:
        raise ValueError(f"need dgamma < gamma_max, got dgamma={dgamma!r}, gamma_max={gamma_max!r}")
    return int(round(gamma_max / dgamma))


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
    """
    if minimizer not in MINIMIZERS:
        raise ValueError(f"minimizer must be one of {MINIMIZERS}, got minimizer={minimizer!r}")
    if not (isinstance(ftol, int | float) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    if (gamma_max is None) == (n_steps is None):
        raise ValueError("give exactly one of gamma_max and n_steps")
    if n_steps is None:
        total = n_steps_for(dgamma, gamma_max)
    else:
        if not (isinstance(dgamma, int | float) and math.isfinite(dgamma) and dgamma > 0):
            raise ValueError(f"dgamma must be finite and > 0, got dgamma={dgamma!r}")
        if not (isinstance(n_steps, int) and n_steps >= 1):
            raise ValueError(f"n_steps must be an integer >= 1, got n_steps={n_steps!r}")
        total = n_steps
    if save_every is not None and not (isinstance(save_every, int) and save_every >= 1):
        raise ValueError(f"save_every must be an integer >= 1, got save_every={save_every!r}")
    if save_every is not None and out is None:
        raise ValueError("save_every needs an output path (out=...)")
    params = AQSParameters() if params is None else params
    fire_params = FireParameters() if fire_params is None else fire_params

    nl = NeighborList(packing)
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
        append_row(rows, cur.strain, row, start_iterations, False)
        first = 1
    else:
        gamma0 = float(previous.gamma[0])
        if not math.isclose(packing.strain, float(previous.gamma[-1]), rel_tol=0, abs_tol=1e-15):
            raise ValueError(
                f"configuration strain {packing.strain} does not match the trace's last strain "
                f"{previous.gamma[-1]}"
            )
        for k in ROW_KEYS:
            rows[k] = list(getattr(previous, k))
        cur = packing
        _, backbone = observe(cur, nl)
        first = previous.n_steps + 1
    if first > total:
        raise ValueError(f"nothing to do: the trace already has {first - 1} >= {total} steps")

    attrs = {
        "dgamma": float(dgamma),
        "gamma_max": float(gamma0 + total * dgamma),
        "n_steps": int(total),
        "ftol": float(ftol),
        "minimizer": minimizer,
        "N": int(packing.n),
        "dim": int(packing.dim),
        "phi": float(packing.phi),
        "box_length": float(packing.box.length),
        "seed": int(-1 if packing.seed is None else packing.seed),
        "jamlab_version": jamlab_version(),
        "source": "" if source is None else str(source),
    }
    counters = {
        "n_fallback": 0,
        "n_substepped": 0,
        "n_cleanup": 0,
        "n_factorisations": 1,
        "n_lean": 0,
    }
    fac = factorise(cur, nl, backbone)
    age = 0
    predictor: np.ndarray | None = None
    path = BranchPath(params.path_depth, params.path_degree, params.path_floor)
    secants = Secants(params.secant_depth) if params.secant_depth else None
    prev = {"gamma": rows["gamma"][-1], **{k: rows[k][-1] for k in ROW_KEYS if k != "gamma"}}
    cur_keys = contact_keys(cur, nl) if minimizer == "linear" else None
    flags, flags_build = (
        consistent_flags(cur, nl, fac, params) if minimizer == "linear" else (None, -1)
    )
    t0 = time.perf_counter()
    for n in range(first, total + 1):
        target = gamma0 + n * dgamma
        affine = affine_to(cur, target)
        iterations = 0
        plastic = False
        branch: Branch | None = None
        observed: tuple[Packing, dict[str, float], np.ndarray] | None = None
        lean = lean_change = None
        if minimizer == "linear" and flags is not None and nl.n_builds != flags_build:
            flags, flags_build = consistent_flags(cur, nl, fac, params)
        if fac.free.size == 0:
            # no rigid backbone (unjammed): E ≈ 0, nothing can jump; FIRE just removes overlaps
            res = minimize(affine, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            new, iterations = res.packing, res.iterations
        elif (
            minimizer == "linear"
            and flags is not None
            and nl.n_builds == flags_build
            and (
                lean := lean_step(
                    cur, target, predictor, nl, fac, flags, prev, ftol, params, secants, affine
                )
            )
        ):
            new, lean_row, iterations, lean_change = lean
            observed = (new, lean_row, backbone)
            counters["n_lean"] += 1
            if lean_change is not None:
                flags = lean_change[0]
        elif minimizer == "linear":
            branch = continue_network(cur, fac, target, nl, ftol, params, predictor=predictor)
            if branch.packing is not None and branch.substeps == 1:
                # a contact opening or closing inside the step makes E(γ) a kink, not a parabola
                observed = (branch.packing, *observe(branch.packing, nl))
                r = (
                    observed[1]["energy"]
                    - rows["energy"][-1]
                    - 0.5
                    * (target - rows["gamma"][-1])
                    * (rows["shear_stress"][-1] + observed[1]["shear_stress"])
                )
                if abs(r) > params.energy_tol * dgamma**2:
                    counters["n_factorisations"] += branch.refactorised
                    iterations += branch.iterations
                    branch = continue_network(
                        cur, branch.factor, target, nl, ftol, params, first_substep=0.125
                    )
            iterations += branch.iterations
            counters["n_factorisations"] += branch.refactorised
            new = branch.packing
            if new is not None and branch.substeps > 1:
                counters["n_substepped"] += 1
            if new is None:
                counters["n_fallback"] += 1
                plastic = True
                res = minimize(affine, ftol, params.max_fire_iter, fire_params, neighbors=nl)
                new, iterations = res.packing, iterations + res.iterations
        else:
            res = minimize(affine, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            new, iterations = res.packing, res.iterations
            if classify:
                branch = continue_network(cur, fac, target, nl, ftol, params)
                counters["n_factorisations"] += branch.refactorised
                continued = branch.packing
                if continued is not None and observe(continued, nl)[0]["max_force"] >= ftol:
                    # the continuation holds rattlers where the affine step put them; relax
                    # them as the fast path does before recording, or their overlaps alone
                    # make the energies differ
                    continued = minimize(
                        continued, ftol, params.max_fire_iter, fire_params, neighbors=nl
                    ).packing
                plastic = continued is None or not same_minimum(new, continued, nl, params)
        if observed is not None and observed[0] is new:
            row, backbone = observed[1], observed[2]
        else:
            row, backbone = observe(new, nl)
        cleaned = False
        if row["max_force"] >= ftol:
            # Newton relaxed the backbone with rattlers held; let FIRE relax the rest
            counters["n_cleanup"] += 1
            cleaned = True
            res = minimize(new, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            new, iterations = res.packing, iterations + res.iterations
            row, backbone = observe(new, nl)
        append_row(rows, target, row, iterations, plastic)
        predictor = None
        kinked = True
        old_keys = cur_keys
        if minimizer == "linear" and lean is None:
            # did a contact open or close in this step? then u(γ) has a kink inside it
            cur_keys = contact_keys(new, nl)
            kinked = old_keys is None or not np.array_equal(cur_keys, old_keys)
        elif minimizer == "linear":
            kinked = lean_change is not None
            if kinked:
                cur_keys = lean_change[1]
        if minimizer == "linear" and not plastic and not cleaned:
            u = new.box.minimum_image(new.positions - affine.positions)
            path.add(u, row["max_force"], kinked)
            predictor = path.predict()
        else:
            path.reset()
        cur = new
        age += 1
        if branch is not None and branch.factor is not None and not plastic:
            if branch.refactorised:
                age = 0
            fac = branch.factor
        stale = (
            plastic
            or (cleaned and minimizer == "linear")
            or fac.lu is None
            or not np.array_equal(fac.backbone, backbone)
            or age >= params.refactor_every
            or (branch is not None and branch.cg_iterations > params.stale_cg)
        )
        if stale and n < total:  # (after the last step nothing would use it)
            # the previous preconditioner is useless after an avalanche, and the regular
            # refactorisation re-checks positive definiteness exactly (LDLᵀ pivots)
            fac = factorise(cur, nl, backbone)
            counters["n_factorisations"] += 1
            age = 0
        prev = {"gamma": target, **row}
        if minimizer == "linear" and (lean is None or stale):
            # contacts of the new minimum, per neighbour-list slot, for the next lean step
            flags, flags_build = consistent_flags(cur, nl, fac, params)
        if progress is not None:
            progress(n, total)
        if out is not None and save_every is not None and n % save_every == 0 and n < total:
            save_checkpoint(out, rows, attrs, counters, cur, n, snapshot=True)
    elapsed = time.perf_counter() - t0
    trace = make_trace(rows, attrs, counters)
    if out is not None:
        save_checkpoint(out, rows, attrs, counters, cur, total, snapshot=save_every is not None)
    return ShearResult(
        trace=trace,
        packing=cur,
        n_fallback=counters["n_fallback"],
        n_substepped=counters["n_substepped"],
        n_cleanup=counters["n_cleanup"],
        n_not_converged=int(np.count_nonzero(trace.max_force >= ftol)),
        time=elapsed,
    )
