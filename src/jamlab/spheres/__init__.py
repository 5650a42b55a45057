"""Soft spheres: Lees–Edwards box, cell lists, harmonic potential, FIRE, packings, AQS shear."""

from jamlab.spheres.box import Box, box_length_for, packing_fraction, sphere_volume
from jamlab.spheres.fire import FireParameters, MinimizeResult, minimize
from jamlab.spheres.io import read_lammps_positions, read_packing, write_packing
from jamlab.spheres.potential import (
    DEFAULT_SKIN,
    Evaluation,
    NeighborList,
    Packing,
    RattlerResult,
    affine_shear,
    contacts,
    coordination,
    dforce_dstrain,
    energy,
    energy_and_forces,
    evaluate,
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
    "Evaluation",
    "FireParameters",
    "MinimizeResult",
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
    "evaluate",
    "forces",
    "hessian",
    "max_force",
    "minimize",
    "packing_fraction",
    "pressure",
    "random_packing",
    "read_lammps_positions",
    "read_packing",
    "remove_rattlers",
    "shear_stress",
    "sphere_volume",
    "stress_tensor",
    "write_packing",
]

# AQS shear and its trace (issue 6)
from jamlab.spheres.aqs import ShearResult, shear  # noqa: E402
from jamlab.spheres.trace import Trace, read_trace, write_trace  # noqa: E402

__all__ += ["ShearResult", "Trace", "read_trace", "shear", "write_trace"]
from jamlab.spheres.packing import (  # noqa: E402
    JammingError,
    PreparedPacking,
    compress_to,
    coordination_curve,
    jam,
    prepare,
)

__all__ += [
    "JammingError",
    "PreparedPacking",
    "compress_to",
    "coordination_curve",
    "jam",
    "prepare",
]
