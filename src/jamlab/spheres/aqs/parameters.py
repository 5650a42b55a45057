"""Parameters of the AQS fast path and of the step classification (:class:`AQSParameters`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from jamlab import validation


@dataclass(frozen=True)
class AQSParameters:
    """Tolerances of the fast path and of the classification (method: :mod:`jamlab.spheres.aqs`).

    ``max_newton``: Newton iterations per (sub)step; ``max_chord``, ``chord_contraction``: chord
    steps of the lean step with the stored factorisation, each required to cut the force by
    that factor; ``contraction``: required reduction factor of ``max |F_b|`` per iteration;
    ``linear_basin``: allowed Newton correction relative to the linear prediction;
    ``min_substep``: smallest substep as a fraction of ``δγ`` before the branch is declared
    ended; ``energy_tol``: a one-substep step whose trapezoid residual
    ``|ΔE − ½ δγ ΔΣ|`` exceeds ``energy_tol · δγ²`` (energy units; a contact change inside the
    step gives ``≲ ΔG L^d δγ²/8``) is redone in 8 substeps as a safety check; ``match_tol``,
    ``energy_match``: largest displacement and relative energy difference between FIRE's minimum
    and the continued branch for them to count as the same minimum
    (:func:`~jamlab.spheres.aqs.classify.same_minimum`);
    ``max_fire_iter``: FIRE iteration cap. ``refactor_every``: steps after which the backbone
    Hessian is factorised afresh in any case; ``refactor_missed``: an elastic step the lean
    step did not take (the continuation took it) refreshes a factor at least that many steps
    old (an aged, corrected factor contracts the chord step by
    0.03–0.25 instead of ≈ 1e-3 and keeps handing steps to the continuation: ``docs/aqs.md``).
    ``event_tol``: a contact crossing closer than ``event_tol · δγ`` to the current point is
    switched there; ``max_events``: contact
    switches per step (and ten times as many Newton solves) before the branch is declared
    ended (FIRE then takes the step; a single pair switched back and forth ends it sooner,
    :data:`~jamlab.spheres.aqs.continuation.CHATTER_SWITCHES`).
    ``floppy``: how a step from an unjammed minimum is taken — ``"fire"`` (the step's usual
    strategies, FIRE where they end) or ``"project"`` (first the overlap-free configuration
    nearest to the affine start, :mod:`jamlab.spheres.aqs.projection`; the usual strategies
    where there is none). A protocol choice for the floppy steps (``docs/aqs.md``).
    """

    max_newton: int = 30
    max_chord: int = 8
    chord_contraction: float = 0.2
    max_strikes: int = 3
    max_cg: int = 60
    max_corrections: int = 48
    refactor_every: int = 250
    refactor_missed: int = 20
    stale_cg: int = 24
    contraction: float = 0.5
    linear_basin: float = 1.0
    min_substep: float = 1.0 / 1024
    energy_tol: float = 100.0
    match_tol: float = 1e-3
    energy_match: float = 1e-13
    max_fire_iter: int = 2_000_000
    max_lean_changes: int = 2
    secant_depth: int = 16
    secant_reach: float = 10.0
    path_depth: int = 16
    path_degree: int = 4
    path_floor: float = 1e-14
    event_tol: float = 1e-3
    max_events: int = 1000
    floppy: str = "fire"

    def __post_init__(self) -> None:
        validation.floppy(self.floppy)
        for f in fields(self):
            v = getattr(self, f.name)
            if f.type == "int":
                least = 1 if f.name in _AT_LEAST_ONE else 0
                if not (validation.is_integer(v) and v >= least):
                    raise ValueError(f"{f.name} must be an integer >= {least}, got {v!r}")
                object.__setattr__(self, f.name, int(v))
            elif f.type == "float":
                if not (validation.is_real(v) and math.isfinite(v)):
                    raise ValueError(f"{f.name} must be a finite number, got {v!r}")
                object.__setattr__(self, f.name, float(v))
        for name in ("contraction", "min_substep"):
            v = getattr(self, name)
            if not 0 < v < 1:
                raise ValueError(f"{name} must be in (0, 1), got {v!r}")
        for name in ("chord_contraction", "linear_basin", "secant_reach", "energy_tol",
                     "match_tol", "energy_match", "event_tol"):
            v = getattr(self, name)
            if not v > 0:
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if not self.path_floor >= 0:
            raise ValueError(f"path_floor must be finite and >= 0, got {self.path_floor!r}")


_AT_LEAST_ONE = frozenset({"max_newton", "refactor_every", "refactor_missed"})
"""The counts that must be >= 1; every other integer parameter may be 0 (none of them)."""
