"""The rows of a fixed-pressure AQS trace (:mod:`jamlab.spheres.pressure_shear`) and the result
they make: the columns of one minimum (:func:`record_row`), the rows of a trace being continued
(:func:`resumed_rows`), and the run's :class:`PressureShearResult` with its plastic flags judged
on the rows (:func:`run_result`). The column names and their meaning are the module docstring of
:mod:`jamlab.spheres.pressure_shear`."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from jamlab.spheres.barostat import POLISH_COUNT
from jamlab.spheres.confirm import plastic_threshold
from jamlab.spheres.newton_relax import RELAX_COUNTERS
from jamlab.spheres.potential import Packing, evaluate, remove_rattlers
from jamlab.spheres.rigidity import is_jammed
from jamlab.spheres.trace import Trace, jump_columns

__all__ = ["CANDIDATE_COUNTS", "PRESSURE_COLUMNS", "RETRY_COUNT", "SADDLE_COUNT",
           "PressureShearResult", "append_row", "can_be_plastic", "minimizer_attribute",
           "record_row", "resumed_rows", "row_jumps", "run_result"]

SADDLE_COUNT = "n_saddles_left"  # trace attribute: pushes off saddles (barostat.leave_saddle)
RETRY_COUNT = "n_steps_retried"  # trace attribute: steps taken afresh (barostat.minimize_step)

CANDIDATE_COUNTS: tuple[str, ...] = ("n_candidates", "n_candidates_continued",
                                     "n_candidates_below_threshold", "n_candidates_located",
                                     "n_candidates_sure")
"""Trace attributes: candidate steps, those of them not redone because Newton continued,
(``defer_confirmation``) those not redone because they cannot be plastic (``|r_n|`` at or below
the run's final threshold, or an unjammed end), (``confirm="located"``) those decided a
jump by :func:`~jamlab.spheres.confirm.jump_located`, without a second whole chain, and
(``defer_confirmation``) those not redone because they released for certain more than
``confirm_below · max(threshold, δγ²)`` (a jump:
:func:`~jamlab.spheres.confirm.released_at_least`). Beside them (computed on the whole run, not
counted as it goes) ``n_candidates_continued_sure``: candidates Newton continued that are flagged
plastic all the same, having released that much for certain (``docs/aqs.md``, "Jumps Newton
continued through"; traces without it were made by code that called every one of them a kink)."""


def minimizer_attribute(minimizer: str) -> str:
    """The trace attribute ``minimizer`` of a fixed-pressure run with this inner minimiser."""
    return f"enthalpy-nested-{minimizer}"


PRESSURE_COLUMNS: tuple[str, ...] = (
    "gamma", "energy", "enthalpy", "shear_stress", "pressure", "phi", "box_length", "z", "z_nr",
    "jammed", "max_force", "iterations", "volume_steps", "converged", "enthalpy_jump",
    "stress_jump", "plastic",
)


@dataclass(frozen=True, eq=False)
class PressureShearResult:
    """Outcome of :func:`~jamlab.spheres.pressure_shear.shear_at_pressure`: ``columns`` (name →
    1-D array, rows ``0 … M``, see that module's docstring), the final ``packing``, run
    ``attrs``, ``threshold`` of the plastic flag, ``time`` (s)."""

    columns: dict[str, np.ndarray]
    packing: Packing
    attrs: dict = field(default_factory=dict)
    threshold: float = math.nan
    time: float = 0.0
    confirmed: np.ndarray | None = None  # per row: a redone candidate step confirmed as a jump
    continued: np.ndarray | None = None  # per row: every inner problem of the step was Newton's
    held: np.ndarray | None = None  # per row: the residual a kink-called candidate's piece held

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    @property
    def n_not_converged(self) -> int:
        return int(np.count_nonzero(~self.columns["converged"]))

    def trace(self) -> Trace:
        """The run as a :class:`~jamlab.spheres.trace.Trace` whose ``energy`` column is the
        enthalpy ``H`` (so its ``energy_jump`` is ``ΔH`` and the analysis tools apply as they
        are), with its ``jammed`` and ``phi`` columns; ``converged`` shows as ``max_force`` or
        the pressure; ``E``, ``box_length``, ``volume_steps``, ``converged`` and the flag
        confirmations are its group ``fixed_pressure`` (what a resumed run needs)."""
        c = self.columns
        return Trace(
            gamma=c["gamma"],
            energy=c["enthalpy"],
            shear_stress=c["shear_stress"],
            pressure=c["pressure"],
            z=c["z"],
            z_nr=c["z_nr"],
            max_force=c["max_force"],
            iterations=c["iterations"],
            energy_jump=c["enthalpy_jump"],
            stress_jump=c["stress_jump"],
            plastic=c["plastic"],
            jammed=c["jammed"],
            phi=c["phi"],
            attrs={**self.attrs, "energy_column": "enthalpy"},
            fixed_pressure={
                "energy": c["energy"],
                "box_length": c["box_length"],
                "volume_steps": c["volume_steps"],
                "converged": c["converged"],
                "confirmed": (np.zeros(c["gamma"].shape, dtype=bool) if self.confirmed is None
                              else self.confirmed),
                "held": np.zeros(c["gamma"].shape) if self.held is None else self.held,
            },
        )


def record_row(res, ftol: float) -> dict:
    """The trace row of the fixed-pressure minimum ``res`` (an ``EnthalpyResult``), every value
    evaluated afresh from its packing; ``converged`` as the row reads it (``max_force < ftol``)."""
    pk = res.packing
    ev = evaluate(pk)
    rr = remove_rattlers(pk)
    return {
        "energy": ev.energy,
        "enthalpy": ev.energy + res.target_pressure * pk.box.volume,
        "shear_stress": ev.shear_stress,
        "pressure": ev.pressure,
        "phi": pk.phi,
        "box_length": pk.box.length,
        "z": 2.0 * ev.n_contacts / pk.n,
        "z_nr": rr.z_nr,
        "jammed": is_jammed(pk, ftol).jammed,
        "max_force": ev.max_force,
        "iterations": res.iterations,
        "volume_steps": res.volume_steps,
        "converged": bool(res.converged and ev.max_force < ftol),  # as the trace reads it
    }


def row_jumps(rows: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(γ, ΔH_n, ΔΣ_n, jammed)`` of the rows (NaN jumps in row 0)."""
    g = np.asarray(rows["gamma"], dtype=np.float64)
    hj, sj = jump_columns(g, rows["enthalpy"], rows["shear_stress"])
    return g, hj, sj, np.asarray(rows["jammed"], dtype=np.bool_)


def can_be_plastic(rows: dict, dgamma: float, plastic_floor: float,
                   confirm_below: float) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the step passes the run's threshold, and it is a jump without confirmation
    (:func:`~jamlab.spheres.confirm.plastic_threshold`)."""
    g, hj, sj, jammed = row_jumps(rows)
    return plastic_threshold(hj, sj, g, jammed, dgamma, plastic_floor, confirm_below)[1:]


def append_row(rows: dict[str, list], gamma: float, row: dict) -> None:
    """Append the row of the minimum at strain ``gamma`` to the column lists ``rows``."""
    rows["gamma"].append(float(gamma))
    for k, v in row.items():
        rows[k].append(v)


def resumed_rows(previous: Trace,
                 names: list[str]) -> tuple[dict[str, list], np.ndarray, np.ndarray, dict]:
    """The rows, confirmations, held residuals (zero in a trace made before them) and candidate
    counts of a fixed-pressure trace being continued."""
    fp = previous.fixed_pressure
    if fp is None or previous.jammed is None or previous.phi is None:
        raise ValueError("the trace has no fixed-pressure columns (group fixed_pressure): it was "
                         "not written by a fixed-pressure run that can be resumed")
    source = {
        "gamma": previous.gamma, "energy": fp["energy"], "enthalpy": previous.energy,
        "shear_stress": previous.shear_stress, "pressure": previous.pressure, "phi": previous.phi,
        "box_length": fp["box_length"], "z": previous.z, "z_nr": previous.z_nr,
        "jammed": previous.jammed, "max_force": previous.max_force,
        "iterations": previous.iterations, "volume_steps": fp["volume_steps"],
        "converged": fp["converged"],
    }
    rows = {k: source[k].tolist() for k in names}
    kept = (*CANDIDATE_COUNTS, SADDLE_COUNT, RETRY_COUNT, POLISH_COUNT)
    counts = {k: int(previous.attrs.get(k, 0)) for k in kept}
    held = fp.get("held")
    held = np.zeros(len(rows["gamma"])) if held is None else np.asarray(held, dtype=np.float64)
    return rows, np.asarray(fp["confirmed"], dtype=bool), held, counts


def run_result(rows, confirmed, held, continued, cur, counts, t0, dgamma, total, gamma0, pressure,
               ptol, ftol, plastic_floor, confirm_substeps, confirm, packing, minimizer, relaxer,
               defer_confirmation, confirm_below, volume_guess) -> PressureShearResult:
    """The run so far as a :class:`PressureShearResult` (plastic flags judged on these rows)."""
    cols: dict[str, np.ndarray] = {}
    for k, v in rows.items():
        dtype = np.int64 if k in ("iterations", "volume_steps") else np.float64
        if k in ("jammed", "converged"):
            dtype = np.bool_
        cols[k] = np.asarray(v, dtype=dtype)
    confirmed = np.array(confirmed[: cols["gamma"].size], dtype=bool)
    held = np.array(held[: cols["gamma"].size], dtype=np.float64)
    g, hj, sj, jammed = row_jumps(rows)
    cols["enthalpy_jump"], cols["stress_jump"] = hj, sj
    threshold, plastic, sure = plastic_threshold(hj, sj, g, jammed, dgamma, plastic_floor,
                                                  confirm_below)
    # a candidate Newton continued is never redone, but one that released for certain more than
    # confirm_below units is a jump all the same (docs/aqs.md, "Jumps Newton continued through")
    continued_sure = sure & np.asarray(continued[: sure.size], dtype=bool) & (confirm_substeps > 1)
    # a candidate the chain called a kink whose largest piece held its residual in a sub-piece
    # above the threshold is a jump (confirm.residual_held; docs/aqs.md, "The chain's share
    # misses small jumps")
    by_held = plastic & ~confirmed & ~sure & (held > threshold) & (confirm_substeps > 1)
    if confirm_substeps > 1:
        plastic &= confirmed | sure | by_held
    cols["plastic"] = plastic
    attrs = {
        "protocol": "fixed-pressure",
        "pressure_target": float(pressure),
        "ptol": float(ptol),
        "dgamma": float(dgamma),
        "gamma_max": float(gamma0 + total * dgamma),
        "n_steps": int(total),
        "ftol": float(ftol),
        "minimizer": minimizer_attribute(minimizer),
        "N": int(packing.n),
        "dim": int(packing.dim),
        "seed": int(-1 if packing.seed is None else packing.seed),
        "plastic_threshold": float(threshold),
        "n_plastic": int(plastic.sum()),
        "confirm_substeps": int(confirm_substeps),
        "confirm": confirm,
        "volume_guess": volume_guess,
        "confirm_deferred": int(bool(defer_confirmation)),
        "confirm_below": float(confirm_below),
        **{k: int(v) for k, v in counts.items()},
        "n_candidates_continued_sure": int(continued_sure.sum()),
        "n_candidates_held": int(by_held.sum()),
        "n_unjammed": int(np.count_nonzero(~cols["jammed"])),
        "n_not_converged": int(np.count_nonzero(~cols["converged"])),
        # the Newton relaxer's counters, over the whole run (a resumed one starts from its trace's)
        **({k: int(relaxer.counters[k]) for k in RELAX_COUNTERS} if relaxer is not None else {}),
    }
    return PressureShearResult(
        columns={k: cols[k] for k in PRESSURE_COLUMNS},
        packing=cur,
        attrs=attrs,
        threshold=float(threshold),
        time=time.perf_counter() - t0,
        confirmed=confirmed,
        held=held,
        continued=np.array(continued[: cols["gamma"].size], dtype=bool),
    )
