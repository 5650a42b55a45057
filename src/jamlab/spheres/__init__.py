"""Soft spheres: Lees–Edwards box, cell lists, harmonic potential, FIRE, packings, AQS shear."""

from jamlab.spheres.box import Box, box_length_for, packing_fraction, sphere_volume
from jamlab.spheres.potential import (
    DEFAULT_SKIN,
    NeighborList,
    Packing,
    RattlerResult,
    affine_shear,
    contacts,
    coordination,
    dforce_dstrain,
    energy,
    energy_and_forces,
    forces,
    hessian,
    max_force,
    pressure,
    random_packing,
    remove_rattlers,
    shear_stress,
    stress_tensor,
)

__all__ = [
    "Box",
    "DEFAULT_SKIN",
    "NeighborList",
    "Packing",
    "RattlerResult",
    "affine_shear",
    "box_length_for",
    "contacts",
    "coordination",
    "dforce_dstrain",
    "energy",
    "energy_and_forces",
    "forces",
    "hessian",
    "max_force",
    "packing_fraction",
    "pressure",
    "random_packing",
    "remove_rattlers",
    "shear_stress",
    "sphere_volume",
    "stress_tensor",
]

# AQS shear and its trace (issue 6)
from jamlab.spheres.aqs import ShearResult, shear  # noqa: E402
from jamlab.spheres.trace import Trace, read_trace, write_trace  # noqa: E402

__all__ += ["ShearResult", "Trace", "read_trace", "shear", "write_trace"]
