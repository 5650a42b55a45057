"""Contacts, coordination and rattlers (``SPEC.md`` §3, §5).

Contacts are pairs with ``r_ij < σ_ij``; ``z = 2 N_c / N``. Rattlers: particles with fewer than
``d + 1`` contacts, removed repeatedly; ``z_nr = 2 N_c' / N'`` over the rest (the backbone).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamlab.spheres import kernels as K
from jamlab.spheres.neighbors import NeighborList, list_positions
from jamlab.spheres.state import Packing

__all__ = ["contacts", "coordination", "RattlerResult", "remove_rattlers", "backbone_mask"]


def contacts(
    packing: Packing, neighbors: NeighborList | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs in contact, ``r_ij < σ_ij``: ``(i, j, r_ij)`` with ``i < j``, ``r_ij = r_i − r_j``
    (minimum image), sorted by ``(i, j)``."""
    pos, nl = list_positions(packing, neighbors)
    ci, cj, cd = K.contact_pairs(pos, nl.start, nl.nbr, nl.shift, nl.diameters)
    i, j = nl.order[ci], nl.order[cj]
    swap = i > j
    i[swap], j[swap] = j[swap], i[swap]
    cd[swap] *= -1.0
    # the same contacts in the same order whatever the list's internal numbering
    sort = np.lexsort((j, i))
    return i[sort], j[sort], np.ascontiguousarray(cd[sort])


def coordination(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """``z = 2 N_c / N``."""
    i, _, _ = contacts(packing, neighbors)
    return 2.0 * len(i) / packing.n


@dataclass(frozen=True, eq=False)
class RattlerResult:
    """Outcome of rattler removal.

    ``mask[i]`` is True for particles kept (non-rattlers); ``z_nr = 2 N_c' / N'`` (0 if none
    remain); ``n_contacts_nr = N_c'`` is the number of contacts among kept particles.
    """

    mask: np.ndarray
    z_nr: float
    n_rattlers: int
    n_contacts_nr: int


def backbone_mask(ci: np.ndarray, cj: np.ndarray, n: int, min_contacts: int) -> np.ndarray:
    """Particles left after removing, repeatedly, those with fewer than ``min_contacts``
    contacts (contact list ``ci, cj``) among the kept ones."""
    keep = np.ones(n, dtype=bool)
    while True:
        live = keep[ci] & keep[cj]
        count = np.bincount(ci[live], minlength=n) + np.bincount(cj[live], minlength=n)
        drop = keep & (count < min_contacts)
        if not drop.any():
            return keep
        keep &= ~drop


def remove_rattlers(
    packing: Packing, neighbors: NeighborList | None = None, min_contacts: int | None = None
) -> RattlerResult:
    """Remove, repeatedly, particles with fewer than ``d + 1`` contacts (``min_contacts``).

    Removing a particle removes its contacts, which can make new rattlers; stops when every kept
    particle has at least ``min_contacts`` contacts with kept particles.
    """
    need = packing.dim + 1 if min_contacts is None else int(min_contacts)
    ci, cj, _ = contacts(packing, neighbors)
    n = packing.n
    keep = backbone_mask(ci, cj, n, need)
    live = keep[ci] & keep[cj]
    n_c = int(live.sum())
    n_kept = int(keep.sum())
    z_nr = 2.0 * n_c / n_kept if n_kept else 0.0
    return RattlerResult(mask=keep, z_nr=z_nr, n_rattlers=n - n_kept, n_contacts_nr=n_c)
