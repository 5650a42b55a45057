"""Soft spheres: Lees–Edwards box, state (diameters, pair law), neighbour lists, potential,
contacts, FIRE, packings, AQS shear.

Layers (each module imports only from the ones above it): ``box`` → ``pair`` → ``state`` →
``neighbors`` → ``contacts`` → ``potential`` → ``fire`` → ``relax`` → ``describe`` →
``jam_search`` → ``compression`` → ``packing``; ``io`` and ``trace`` (files); ``aqs`` (shear).
"""

from jamlab.spheres.box import Box, box_length_for, packing_fraction, sphere_volume
from jamlab.spheres.contacts import RattlerResult, contacts, coordination, remove_rattlers
from jamlab.spheres.fire import FireParameters, MinimizeResult, minimize
from jamlab.spheres.io import read_lammps_positions, read_packing, write_packing
from jamlab.spheres.neighbors import DEFAULT_SKIN, NeighborList
from jamlab.spheres.pair import HARMONIC, HERTZIAN
from jamlab.spheres.potential import (
    Evaluation,
    dforce_dstrain,
    energy,
    energy_and_forces,
    evaluate,
    forces,
    hessian,
    max_force,
    pressure,
    shear_stress,
    stress_tensor,
)
from jamlab.spheres.state import (
    Packing,
    affine_shear,
    parse_sizes,
    random_packing,
    size_distribution,
)

__all__ = [
    "Box",
    "DEFAULT_SKIN",
    "Evaluation",
    "FireParameters",
    "HARMONIC",
    "HERTZIAN",
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
    "parse_sizes",
    "pressure",
    "random_packing",
    "read_lammps_positions",
    "read_packing",
    "remove_rattlers",
    "shear_stress",
    "size_distribution",
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
    jam_at_pressure,
    prepare,
)

__all__ += [
    "JammingError",
    "PreparedPacking",
    "compress_to",
    "coordination_curve",
    "jam",
    "jam_at_pressure",
    "prepare",
]
