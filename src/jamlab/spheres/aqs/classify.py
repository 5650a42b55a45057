"""Classification: whether two minima at the same strain are one (:func:`same_minimum`)."""

from __future__ import annotations

import numpy as np

from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.potential import NeighborList, Packing, energy_and_forces


def same_minimum(a: Packing, b: Packing, nl: NeighborList, params: AQSParameters) -> bool:
    """Whether two minima at the same strain are one: energies equal within
    ``energy_match · max(1, |E|)`` and backbone-free positions within ``match_tol`` after
    removing the mean displacement.

    Positions alone are not enough near jamming: along modes of stiffness ``λ`` a minimiser
    stopped at ``max|F| < ftol`` is off by ``ftol/λ`` (1e-5 at ``λ = 1e-7``), while its energy
    is off by only ``ftol²/λ``.
    """
    ea = energy_and_forces(a, nl)[0]
    eb = energy_and_forces(b, nl)[0]
    if abs(ea - eb) > params.energy_match * max(1.0, abs(ea)):
        return False
    dr = a.box.minimum_image(a.positions - b.positions)
    dr -= dr.mean(axis=0)
    return bool(np.max(np.abs(dr)) < params.match_tol)
