"""Jammed or not: is a minimum rigid, resolved to a force tolerance ``ftol``?

A minimum is **jammed** when all three hold (``SPEC.md`` §3, §6; derivation in ``docs/aqs.md``,
"At the jamming point"):

1. its rattler-free backbone (particles left after repeatedly removing those with fewer than
   ``d + 1`` contacts, :func:`~jamlab.spheres.potential.remove_rattlers`) is not empty;
2. the backbone is at least isostatic, ``N_c' ≥ d (N' − 1) + 1``: ``d(N' − 1)`` non-trivial
   degrees of freedom plus one for the box (a rigid packing in a fixed periodic box that carries a
   pressure needs one state of self-stress more than it has degrees of freedom; Goodrich, Liu and
   Nagel, PRL 109, 095704 (2012));
3. its pressure exceeds the resolution floor of a minimum converged to ``max_i |F_i| < ftol``,

       p_floor = c · ftol · N / L^d,    c = 10   (PRESSURE_FLOOR_FACTOR).

   Why: in a floppy (unjammed) state the contact forces carry no state of self-stress, so they are
   fixed by the residual net forces; every contact force is then of order ``ftol`` (exactly ``|F_i|
   < ftol`` for a particle with one contact, a few ``ftol`` along short chains) and the virial
   gives ``p = (1/(d L^d)) Σ_c f_c r_c ≲ N_c ftol / (d L^d)``. A floppy configuration has fewer
   than ``d N`` contacts (hypostatic), so ``p ≲ ftol N / L^d`` (``≈ 1.2 ftol`` at ``φ ≈ 0.64`` in
   3D); ``c = 10`` is the safety margin. Measured (``docs/aqs.md``): unjammed minima at ``ftol =
   1e-12`` have ``p ≤ 0.16 ftol N / L^d``. With ``ftol = 1e-12``, N/L^d ≈ 1.22: ``p_floor ≈
   1.2e-11`` (the value :func:`jamlab.spheres.packing.jam` uses, 1e-11 at ``p_target = 1e-7``).

The verdict is of a minimum: a configuration with ``max_i |F_i| ≥ ftol`` is not judged, it is
reported not jammed with the reason "not a minimum" (:func:`is_jammed`).

Condition 2 is a count, necessary for rigidity, not sufficient (a hyperstatic subcluster next to a
floppy one passes it); together with 3 it is what can be decided from one minimum without a
Hessian.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jamlab.spheres.potential import (
    NeighborList,
    Packing,
    max_force,
    pressure,
    remove_rattlers,
)

__all__ = [
    "JammedState",
    "PRESSURE_FLOOR_FACTOR",
    "is_jammed",
    "jammed_verdict",
    "pressure_floor",
]

PRESSURE_FLOOR_FACTOR = 10.0
"""Safety factor ``c`` in ``p_floor = c · ftol · N / L^d`` (see the module docstring)."""


def pressure_floor(n: int, dim: int, length: float, ftol: float) -> float:
    """``p_floor = c · ftol · N / L^d``: pressures below it are not resolved by a minimum
    converged to ``max_i |F_i| < ftol`` (``c`` = :data:`PRESSURE_FLOOR_FACTOR`)."""
    if not (math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    return PRESSURE_FLOOR_FACTOR * ftol * n / length**dim


@dataclass(frozen=True)
class JammedState:
    """Outcome of :func:`is_jammed`.

    ``jammed``: the three conditions hold; ``pressure``: ``p`` of the minimum; ``p_floor``: its
    resolution floor; ``n_backbone = N'``, ``n_contacts_backbone = N_c'``,
    ``n_contacts_iso = d(N' − 1) + 1`` (0 for an empty backbone), ``excess = N_c' − N_c,iso``;
    ``reason``: why not jammed (empty when jammed).
    """

    jammed: bool
    pressure: float
    p_floor: float
    n_backbone: int
    n_contacts_backbone: int
    n_contacts_iso: int
    excess: int
    reason: str

    def __bool__(self) -> bool:
        return self.jammed


def jammed_verdict(
    dim: int, n_backbone: int, n_contacts_backbone: int, pressure: float, p_floor: float
) -> str:
    """The rule from counts already at hand (e.g. the AQS driver's backbone): ``""`` when
    jammed, otherwise why not (empty backbone, hypostatic, pressure not above ``p_floor``)."""
    n_iso = dim * (n_backbone - 1) + 1 if n_backbone > 0 else 0
    excess = n_contacts_backbone - n_iso
    if n_backbone == 0:
        return "no backbone (every particle a rattler)"
    if excess < 0:
        return f"hypostatic backbone ({-excess} contacts short of d(N'-1)+1)"
    if not pressure > p_floor:
        return f"pressure {pressure:.3e} not above the resolution floor {p_floor:.3e}"
    return ""


def is_jammed(
    packing: Packing, ftol: float = 1e-12, neighbors: NeighborList | None = None
) -> JammedState:
    """Whether the minimum ``packing`` (converged to ``max_i |F_i| < ftol``) is jammed: non-empty
    backbone, ``N_c' ≥ d(N' − 1) + 1``, ``p > p_floor(ftol)`` (module docstring). A
    configuration that is not such a minimum (``max_i |F_i| ≥ ftol``) is not judged: it is
    reported not jammed, with the reason "not a minimum" (the counts are still filled)."""
    p_floor = pressure_floor(packing.n, packing.dim, packing.box.length, ftol)
    rr = remove_rattlers(packing, neighbors)
    p = pressure(packing, neighbors)
    n_kept = packing.n - rr.n_rattlers
    n_iso = packing.dim * (n_kept - 1) + 1 if n_kept > 0 else 0
    excess = rr.n_contacts_nr - n_iso
    fmax = max_force(packing, neighbors)
    if not fmax < ftol:
        reason = f"not a minimum (max|F_i| = {fmax:.3g} >= ftol = {ftol:g})"
    else:
        reason = jammed_verdict(packing.dim, n_kept, rr.n_contacts_nr, p, p_floor)
    return JammedState(
        jammed=not reason,
        pressure=float(p),
        p_floor=float(p_floor),
        n_backbone=int(n_kept),
        n_contacts_backbone=int(rr.n_contacts_nr),
        n_contacts_iso=int(n_iso),
        excess=int(excess),
        reason=reason,
    )
