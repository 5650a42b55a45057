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

# AQS shear and its trace (issue 6), packings: imported on first use (PEP 562), so that a command
# that needs neither (``jamlab inspect``) does not import SciPy's sparse solvers
_LAZY = {
    "ShearResult": "jamlab.spheres.aqs",
    "shear": "jamlab.spheres.aqs",
    "Trace": "jamlab.spheres.trace",
    "read_trace": "jamlab.spheres.trace",
    "write_trace": "jamlab.spheres.trace",
    "JammingError": "jamlab.spheres.packing",
    "PreparedPacking": "jamlab.spheres.packing",
    "compress_to": "jamlab.spheres.packing",
    "coordination_curve": "jamlab.spheres.packing",
    "jam": "jamlab.spheres.packing",
    "jam_at_pressure": "jamlab.spheres.packing",
    "prepare": "jamlab.spheres.packing",
}
__all__ += list(_LAZY)


def __getattr__(name: str):
    from jamlab import lazy

    return lazy.attribute(__name__, globals(), _LAZY, name)


def __dir__() -> list[str]:
    from jamlab import lazy

    return lazy.names(globals(), __all__)
