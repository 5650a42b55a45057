"""Energy, forces, stress, pressure, Hessian and ``∂F/∂γ`` of soft spheres.

Conventions (``SPEC.md`` §3, §5); the pair law ``V(r) = (1 − r/σ_ij)^α`` comes from
:mod:`jamlab.spheres.pair` (the only place it is written), the state from
:mod:`jamlab.spheres.state`:

- ``E = Σ_{i<j} V(r_ij)`` (total, extensive); ``F_i = −∂E/∂r_i``.
- Shear stress (extensive) ``Σ = ∂E/∂γ`` at fixed reduced coordinates
  ``= Σ_{i<j} V'(r_ij) x_ij y_ij / r_ij``; intensive ``σ_xy = Σ / L^d``.
- Pressure ``p = −(1/(d L^d)) Σ_{i<j} V'(r_ij) r_ij``.
- Stress tensor (intensive) ``σ_ab = (1/L^d) Σ_{i<j} V'(r_ij) r_ij,a r_ij,b / r_ij``, so that
  ``σ_xy = Σ/L^d`` and ``p = −tr σ / d``.

Every separation is ``r_ij = r_i − r_j`` for the (unique, as ``L > 2 σ_max``) periodic image
closer than the cut-off; see :mod:`jamlab.spheres.box`. Contacts and rattlers:
:mod:`jamlab.spheres.contacts`. The names of those modules are re-exported here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from jamlab.spheres import kernels as K
from jamlab.spheres.contacts import RattlerResult, contacts, coordination, remove_rattlers
from jamlab.spheres.kernel_choice import threshold_for
from jamlab.spheres.neighbors import DEFAULT_SKIN, NeighborList, list_positions, spatial_order
from jamlab.spheres.state import Packing, affine_shear, random_packing

if TYPE_CHECKING:
    import scipy.sparse

__all__ = [
    "Packing",
    "NeighborList",
    "RattlerResult",
    "DEFAULT_SKIN",
    "random_packing",
    "energy",
    "forces",
    "energy_and_forces",
    "max_force",
    "shear_stress",
    "pressure",
    "stress_tensor",
    "contacts",
    "coordination",
    "remove_rattlers",
    "hessian",
    "dforce_dstrain",
    "affine_shear",
    "spatial_order",
    "Evaluation",
    "evaluate",
    "virial",
]


def energy(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """Total energy ``E = Σ_{i<j} V(r_ij)``."""
    pos, nl = list_positions(packing, neighbors)
    return float(K.energy(pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha))


def energy_and_forces(
    packing: Packing, neighbors: NeighborList | None = None
) -> tuple[float, np.ndarray]:
    """``(E, F)`` with ``F_i = −∂E/∂r_i = −Σ_j V'(r_ij) r_ij / r_ij`` (shape ``(N, d)``)."""
    pos, nl = list_positions(packing, neighbors)
    f = np.empty_like(pos)
    e = K.energy_forces_any(
        pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha, f,
        threshold_for(nl.nbr.size, pos.shape[1], nl.alpha),
    )
    return float(e), nl.unsorted(f)


@dataclass(frozen=True, eq=False)
class Evaluation:
    """Everything one pass over the pairs gives (see :func:`evaluate`)."""

    energy: float
    forces: np.ndarray
    shear_stress: float
    pressure: float
    stress_tensor: np.ndarray
    max_force: float
    n_contacts: int


def evaluate(packing: Packing, neighbors: NeighborList | None = None) -> Evaluation:
    """``E``, ``F``, ``Σ``, ``p``, ``σ_ab``, ``max_i |F_i|`` and ``N_c`` in one pass over pairs.

    With a :class:`NeighborList` kept across calls (e.g. in AQS), nothing is rebuilt unless the
    particles moved more than the skin allows.
    """
    pos, nl = list_positions(packing, neighbors)
    f = np.empty_like(pos)
    s = np.empty((packing.dim, packing.dim))
    e, n_c = K.energy_forces_virial(
        pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha, f, s
    )
    volume = packing.box.volume
    return Evaluation(
        energy=float(e),
        forces=nl.unsorted(f),
        shear_stress=float(s[0, 1]),
        pressure=float(-np.trace(s) / (packing.dim * volume)),
        stress_tensor=s / volume,
        max_force=float(K.max_force(f)),
        n_contacts=int(n_c),
    )


def forces(packing: Packing, neighbors: NeighborList | None = None) -> np.ndarray:
    """``F_i = −∂E/∂r_i``, shape ``(N, d)``."""
    return energy_and_forces(packing, neighbors)[1]


def max_force(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """Largest per-particle force ``max_i |F_i|``."""
    return float(K.max_force(forces(packing, neighbors)))


def virial(packing: Packing, neighbors: NeighborList | None = None) -> np.ndarray:
    """Extensive ``S_ab = Σ_{i<j} V'(r_ij) r_ij,a r_ij,b / r_ij`` (``d × d``)."""
    pos, nl = list_positions(packing, neighbors)
    return K.virial_tensor(pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha)


def shear_stress(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """Extensive ``Σ = ∂E/∂γ = Σ_{i<j} V'(r_ij) x_ij y_ij / r_ij``."""
    return float(virial(packing, neighbors)[0, 1])


def pressure(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """``p = −(1/(d L^d)) Σ_{i<j} V'(r_ij) r_ij``."""
    s = virial(packing, neighbors)
    return float(-np.trace(s) / (packing.dim * packing.box.volume))


def stress_tensor(packing: Packing, neighbors: NeighborList | None = None) -> np.ndarray:
    """Intensive ``σ_ab = (1/L^d) Σ_{i<j} V'(r_ij) r_ij,a r_ij,b / r_ij`` (``d × d``).

    ``σ_xy = Σ / L^d`` and ``p = −tr σ / d``.
    """
    return virial(packing, neighbors) / packing.box.volume


def _contacts_within(
    packing: Packing, neighbors: NeighborList | None, backbone: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The contacts of ``packing``; with a mask ``backbone``, only those with both ends in it."""
    ci, cj, cd = contacts(packing, neighbors)
    if backbone is None:
        return ci, cj, cd
    keep = np.asarray(backbone, dtype=bool)
    if keep.shape != (packing.n,):
        raise ValueError(f"backbone mask must have shape ({packing.n},), got {keep.shape}")
    live = keep[ci] & keep[cj]
    return ci[live], cj[live], np.ascontiguousarray(cd[live])


def hessian(
    packing: Packing, neighbors: NeighborList | None = None, backbone: np.ndarray | None = None
) -> scipy.sparse.csr_matrix:
    """Sparse Hessian ``H_{ia,jb} = ∂²E/∂r_ia ∂r_jb`` (``dN × dN``, row ``d·i + a``), CSR.

    Pair block ``B = V''(r) n nᵀ + (V'(r)/r)(1 − n nᵀ)``: ``H_ii = Σ_j B_ij``, ``H_ij = −B_ij``.
    ``backbone`` (boolean mask ``(N,)``): only the contacts between two of its particles.
    """
    import scipy.sparse  # here, not at the top: SciPy's import costs every command's start-up

    ci, cj, cd = _contacts_within(packing, neighbors, backbone)
    rows, cols, vals = K.hessian_coo(ci, cj, cd, *packing.kernel_law)
    size = packing.n * packing.dim
    return scipy.sparse.coo_matrix((vals, (rows, cols)), shape=(size, size)).tocsr()


def dforce_dstrain(
    packing: Packing, neighbors: NeighborList | None = None, backbone: np.ndarray | None = None
) -> np.ndarray:
    """``Ξ_i = ∂F_i/∂γ`` under affine shear at fixed reduced coordinates, shape ``(N, d)``.

    ``Ξ_i = −Σ_j B_ij e_x y_ij``. With the Hessian ``H``, the non-affine response of a minimum is
    ``H du/dγ = Ξ`` (linear response) and ``dΣ/dγ = ∂²E/∂γ² − Ξ·H⁻¹Ξ``. ``backbone``: as in
    :func:`hessian`.
    """
    ci, cj, cd = _contacts_within(packing, neighbors, backbone)
    return K.dforce_dstrain(packing.n, ci, cj, cd, *packing.kernel_law)
