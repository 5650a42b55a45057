"""Numba kernels of :mod:`jamlab.spheres`, grouped by the layer they serve.

- :mod:`~jamlab.spheres.kernels.geometry`: wrapping, minimum images, the Verlet neighbour list;
- :mod:`~jamlab.spheres.kernels.pairs`: energy, forces, virial, contacts, Hessian, ``∂F/∂γ``
  (pair law from :mod:`jamlab.spheres.pair`);
- :mod:`~jamlab.spheres.kernels.fire`: the compiled FIRE loop;
- :mod:`~jamlab.spheres.kernels.aqs`: the AQS fast path (backbone Hessian as CSR, the fused
  force/virial/contact-state pass, gathers).

Each kernel's docstring gives the formula it computes. The kernels take plain arrays and are
meant for the library's own layers and for tests; users call :mod:`jamlab.spheres.potential`.

On first import, the package's cached kernels are dropped if any kernel source changed since
they were compiled, before numba can load them (:mod:`~jamlab.spheres.kernels.cache`: numba
tracks only a kernel's own file).
"""

# first: importing cache drops stale cached kernels before any kernel module is loaded
from jamlab.spheres.kernels import cache  # noqa: F401  (isort: skip)
from jamlab.spheres.kernels.aqs import (
    backbone_hessian_csr,
    contact_changes,
    forces_virial_flags,
    gather_rows,
    moved,
    rows_max_norm,
)
from jamlab.spheres.kernels.fire import fire
from jamlab.spheres.kernels.geometry import (
    build_neighbor_list,
    max_nonaffine_displacement,
    reduce_strain,
    shift_images,
    wrap_positions,
)
from jamlab.spheres.kernels.pairs import (
    contact_pairs,
    dforce_dstrain,
    energy,
    energy_forces,
    energy_forces_2d,
    energy_forces_3d,
    energy_forces_any,
    energy_forces_virial,
    hessian_coo,
    max_force,
    pair_force_factors,
    pair_stiffness,
    virial_tensor,
)

__all__ = [
    "backbone_hessian_csr",
    "build_neighbor_list",
    "contact_changes",
    "contact_pairs",
    "dforce_dstrain",
    "energy",
    "energy_forces",
    "energy_forces_2d",
    "energy_forces_3d",
    "energy_forces_any",
    "energy_forces_virial",
    "fire",
    "forces_virial_flags",
    "gather_rows",
    "hessian_coo",
    "max_force",
    "max_nonaffine_displacement",
    "moved",
    "pair_force_factors",
    "pair_stiffness",
    "reduce_strain",
    "rows_max_norm",
    "shift_images",
    "virial_tensor",
    "wrap_positions",
]
