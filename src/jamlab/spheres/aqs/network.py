"""The contact network of a configuration: contact lists, pair keys, the backbone (rattlers
removed), the smooth network energy of a fixed contact set, and the affine shear to a strain."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from jamlab.spheres import kernels as K
from jamlab.spheres.contacts import backbone_mask as contacts_backbone_mask
from jamlab.spheres.neighbors import list_positions
from jamlab.spheres.potential import NeighborList, Packing


def contact_list(packing: Packing, nl: NeighborList) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs in contact ``(i, j, r_ij)`` (original numbering) in the neighbour list's order.

    The same set as :func:`~jamlab.spheres.potential.contacts` without its canonical sorting,
    which costs ten times the search itself; the pair block of the Hessian is even in
    ``r_ij``, and the rattler count does not depend on the order either.
    """
    pos, nl = list_positions(packing, nl)
    ci, cj, cd = K.contact_pairs(pos, nl.start, nl.nbr, nl.shift, nl.diameters)
    return nl.order[ci], nl.order[cj], cd


def pair_keys(ci: np.ndarray, cj: np.ndarray, n: int) -> np.ndarray:
    """Order-free key ``min(i, j)·N + max(i, j)`` of each pair."""
    return np.minimum(ci, cj) * n + np.maximum(ci, cj)


def backbone_mask(ci: np.ndarray, cj: np.ndarray, n: int, dim: int) -> np.ndarray:
    """Non-rattlers: repeatedly drop particles with fewer than ``dim + 1`` contacts among the
    kept ones (:func:`jamlab.spheres.contacts.backbone_mask`)."""
    return contacts_backbone_mask(ci, cj, n, dim + 1)


def find_backbone(packing: Packing, nl: NeighborList) -> np.ndarray:
    """:func:`backbone_mask` of the contacts of ``packing``."""
    ci, cj, _ = contact_list(packing, nl)
    return backbone_mask(ci, cj, packing.n, packing.dim)


def contact_keys(packing: Packing, nl: NeighborList) -> np.ndarray:
    """Sorted keys ``min(i, j)·N + max(i, j)`` of the contacts."""
    ci, cj, _ = contact_list(packing, nl)
    return np.sort(pair_keys(ci, cj, packing.n))


def affine_to(packing: Packing, strain: float) -> Packing:
    """``packing`` sheared affinely to ``strain``: ``x_i += (γ − γ_packing) y_i``."""
    pos = np.array(packing.positions)
    pos[:, 0] += (strain - packing.strain) * pos[:, 1]
    # an affine map keeps distinct particles distinct: no coincidence test (Packing)
    return replace(packing, positions=pos, box=packing.box.with_strain(strain),
                   check_coincidence=False)


def network_forces(packing: Packing, ci: np.ndarray, cj: np.ndarray) -> tuple[np.ndarray, ...]:
    """Forces of the contact network ``E_C = Σ_{c ∈ C} V(r_c)`` (every pair of ``C`` a spring
    of rest length ``σ_c``, in tension too: :func:`jamlab.spheres.pair.pair_terms`) and the pairs'
    separations and lengths."""
    pos = packing.positions
    dr = packing.box.minimum_image(pos[ci] - pos[cj])
    r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
    fp = K.pair_force_factors(r, ci, cj, *packing.kernel_law)[:, None] * dr  # force on i
    n, d = pos.shape
    f = np.empty((n, d))
    for a in range(d):
        f[:, a] = np.bincount(ci, fp[:, a], minlength=n) - np.bincount(cj, fp[:, a], minlength=n)
    return f, dr, r
