"""Minima at fixed box: FIRE relaxation with the parameters of the packing protocols, and the
affine rescaling to a packing fraction (``SPEC.md`` §3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from jamlab import validation
from jamlab.spheres.box import Box
from jamlab.spheres.fire import FireParameters, minimize, polish_reading
from jamlab.spheres.potential import max_force, pressure
from jamlab.spheres.state import Packing, box_length_for_diameters

__all__ = ["JAM_FIRE", "RelaxResult", "rescale", "relax", "compress_to"]



def rescale(packing: Packing, phi: float) -> Packing:
    """Affine rescale to packing fraction ``φ``: ``L' = (Σ_i v_d(D_i/2)/φ)^(1/d)``,
    ``r_i → r_i L'/L``.

    Reduced coordinates and strain are kept.
    """
    if not (validation.is_real(phi) and math.isfinite(phi) and phi > 0):
        raise ValueError(f"packing fraction must be finite and > 0, got phi={phi!r}")
    length = box_length_for_diameters(packing.diameters, packing.dim, float(phi))
    scale = length / packing.box.length
    return replace(
        packing,
        positions=packing.positions * scale,
        box=Box(length, packing.dim, packing.box.strain),
    )


JAM_FIRE = FireParameters()
"""FIRE parameters used here: the engine defaults, ``Δt_max = 0.3``. The largest pair stiffness is
``V'' = 2``, so the highest vibrational frequency of a packing is ``ω_max ≈ √(2·2z) ≈ 5–7`` and
semi-implicit Euler is stable only for ``Δt < 2/ω_max ≈ 0.3``; with ``Δt_max = 1`` (the engine
default until this was measured) FIRE oscillates and near jamming stalls (``docs/spheres.md``)."""


@dataclass(frozen=True, eq=False)
class RelaxResult:
    """Outcome of :func:`relax`: the minimum ``packing``, its total ``energy`` and ``pressure``,
    ``max_force = max_i |F_i|``, whether ``max_force < ftol`` (``converged``), FIRE ``iterations``
    and wall-clock ``time`` (s)."""

    packing: Packing
    energy: float
    pressure: float
    max_force: float
    converged: bool
    iterations: int
    time: float
    ftol: float


def relax(
    packing: Packing,
    ftol: float = 1e-12,
    max_iter: int = 1_000_000,
    params: FireParameters | None = None,
) -> RelaxResult:
    """Energy minimum at fixed box with FIRE (:func:`jamlab.spheres.fire.minimize`, parameters
    :data:`JAM_FIRE` unless given) until ``max_i |F_i| < ftol`` (a maximum over particles).

    Non-convergence is reported (``converged=False``), not raised. Converged means as a reader
    of the packing sees it: a minimum that FIRE accepted but that reads ``max_i |F_i| ≥ ftol``
    when evaluated afresh (rounding, :func:`jamlab.spheres.fire.polish_reading`) is relaxed
    further, and is not converged if it still reads so; ``max_force`` is then that reading.
    """
    params = params or JAM_FIRE
    r = minimize(packing, ftol=ftol, max_iter=max_iter, params=params)
    if r.converged:
        r = polish_reading(r, max_force(r.packing), max_iter, params)[0]
    return RelaxResult(
        packing=r.packing,
        energy=r.energy,
        pressure=pressure(r.packing),
        max_force=r.max_force,
        converged=r.converged,
        iterations=r.iterations,
        time=r.time,
        ftol=r.ftol,
    )


def compress_to(
    packing: Packing, phi: float, ftol: float = 1e-12, max_iter: int = 1_000_000
) -> RelaxResult:
    """The minimum at packing fraction ``φ`` reached from ``packing``: affine :func:`rescale` to
    ``φ`` (compression if ``φ`` is larger, decompression otherwise), then :func:`relax`."""
    return relax(rescale(packing, phi), ftol=ftol, max_iter=max_iter)

