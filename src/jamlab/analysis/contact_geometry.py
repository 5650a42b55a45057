"""Contacts, forces, gaps and bucklers of a packing, from positions alone (the geometry half of
:mod:`jamlab.analysis.criticality`, whose docstring states the conventions)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from jamlab.lees_edwards import reduced_strain, wrap

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

__all__ = ["PairList", "PackingObservables", "pairs_within", "pair_force", "backbone_mask",
           "bucklers", "packing_observables"]

# ------------------------------------------------------------------------------------------------
# pairs


@dataclass(frozen=True, eq=False)
class PairList:
    """Pairs ``i < j`` closer than a cut-off: separation vectors ``rij = r_i − r_j`` of the
    (unique) interacting image, distances ``r`` and ``σ_ij``."""

    i: IntArray
    j: IntArray
    rij: FloatArray
    r: FloatArray
    sigma: FloatArray


def _diameters(diameters: ArrayLike | None, n: int) -> FloatArray:
    if diameters is None:
        return np.ones(n)
    dia = np.asarray(diameters, dtype=np.float64)
    if dia.shape != (n,):
        raise ValueError(f"diameters must have shape ({n},), got {dia.shape}")
    if not (np.all(np.isfinite(dia)) and np.all(dia > 0)):
        raise ValueError("diameters must be finite and > 0")
    return dia


def _check_positions(positions: ArrayLike, box_length: float) -> FloatArray:
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] < 2 or pos.shape[0] < 2:
        raise ValueError(f"positions must have shape (N >= 2, d >= 2), got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError("positions must be finite")
    if not (math.isfinite(box_length) and box_length > 0):
        raise ValueError(f"box length must be finite and > 0, got {box_length!r}")
    return pos


def pairs_within(
    positions: ArrayLike,
    box_length: float,
    strain: float = 0.0,
    diameters: ArrayLike | None = None,
    h_max: float = 0.5,
) -> PairList:
    """Every pair ``i < j`` with ``r_ij < σ_ij (1 + h_max)`` in the Lees–Edwards box.

    Positions are wrapped into the primary cell of the sheared lattice (strain reduced to
    ``γ − round(γ)``), the ``3^d`` images ``n_x L e_x + n_y (γ L e_x + L e_y) + Σ_k n_k L e_k``,
    ``n ∈ {−1, 0, 1}^d``, are put in a k-d tree, and each particle is paired with every image
    within the cut-off. With ``|γ| ≤ 1/2`` and a cut-off below ``L/2`` these images contain every
    interacting one and each pair has a single interacting image (``ValueError`` otherwise).
    """
    pos = _check_positions(positions, box_length)
    n, d = pos.shape
    if not (math.isfinite(h_max) and h_max >= 0):
        raise ValueError(f"h_max must be finite and >= 0, got {h_max!r}")
    dia = _diameters(diameters, n)
    length = float(box_length)
    cutoff = float(dia.max()) * (1.0 + h_max)
    if not cutoff < length / 2:
        raise ValueError(
            f"cut-off max(D)(1 + h_max) = {cutoff:.4g} must be below L/2 = {length / 2:.4g}"
        )
    g = reduced_strain(float(strain))
    w = wrap(pos, length, float(strain))
    grid = np.array(np.meshgrid(*([(-1, 0, 1)] * d), indexing="ij")).reshape(d, -1).T
    shifts = grid * length
    shifts[:, 0] += grid[:, 1] * g * length
    images = (w[None, :, :] + shifts[:, None, :]).reshape(-1, d)
    found = cKDTree(w).sparse_distance_matrix(cKDTree(images), cutoff, output_type="ndarray")
    i = found["i"].astype(np.intp)
    k = found["j"].astype(np.intp)
    j = k % n
    keep = i < j
    i, j, k = i[keep], j[keep], k[keep]
    rij = w[i] - images[k]
    r = np.sqrt(np.einsum("ij,ij->i", rij, rij))
    sigma = 0.5 * (dia[i] + dia[j])
    inside = r < sigma * (1.0 + h_max)
    i, j, rij, r, sigma = i[inside], j[inside], rij[inside], r[inside], sigma[inside]
    if np.unique(i * n + j).size != i.size:
        raise ValueError("a pair interacts through two images: the box is too small")
    order = np.lexsort((j, i))
    return PairList(i[order], j[order], rij[order], r[order], sigma[order])


def pair_force(r: ArrayLike, sigma: ArrayLike, alpha: float = 2.0) -> FloatArray:
    """Contact force ``f = −V'(r) = α (1 − r/σ)^(α−1)/σ`` for ``r < σ`` (0 otherwise) of
    ``V(r) = (1 − r/σ)^α`` (:func:`jamlab.spheres.pair.contact_force`, where the law lives)."""
    from jamlab.spheres.pair import contact_force

    if not (math.isfinite(alpha) and alpha > 1):
        raise ValueError(f"pair exponent alpha must be > 1, got {alpha!r}")
    return contact_force(r, sigma, alpha)


def backbone_mask(n: int, i: ArrayLike, j: ArrayLike, dim: int) -> NDArray[np.bool_]:
    """Particles kept after removing, repeatedly, those with fewer than ``d + 1`` contacts among
    the kept ones (``SPEC.md`` §3); ``i, j`` are the contacts
    (:func:`jamlab.spheres.contacts.backbone_mask`)."""
    from jamlab.spheres.contacts import backbone_mask as remove_rattlers_from

    return remove_rattlers_from(np.asarray(i, dtype=np.intp), np.asarray(j, dtype=np.intp), n,
                                dim + 1)


def bucklers(
    n: int, i: ArrayLike, j: ArrayLike, force: ArrayLike, dim: int
) -> tuple[IntArray, NDArray[np.bool_]]:
    """Bucklers and localized contacts of a backbone whose contacts are ``(i, j)`` with forces
    ``force``: the particles with exactly ``d + 1`` contacts, and a mask over the contacts, True
    for the weakest contact of some buckler (ties: the first in the list)."""
    i = np.asarray(i, dtype=np.intp)
    j = np.asarray(j, dtype=np.intp)
    force = np.asarray(force, dtype=np.float64)
    count = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    buck = np.flatnonzero(count == dim + 1)
    localized = np.zeros(i.size, dtype=bool)
    if buck.size == 0 or i.size == 0:
        return buck, localized
    # per particle, the index of its weakest contact: sort (particle, force) and take the first
    ends = np.concatenate([i, j])
    idx = np.concatenate([np.arange(i.size), np.arange(i.size)])
    order = np.lexsort((idx, force[idx], ends))
    first = np.ones(order.size, dtype=bool)
    first[1:] = ends[order][1:] != ends[order][:-1]
    weakest = np.full(n, -1, dtype=np.intp)
    weakest[ends[order][first]] = idx[order][first]
    localized[weakest[buck]] = True
    return buck, localized


@dataclass(frozen=True, eq=False)
class PackingObservables:
    """Forces, gaps and bucklers of one packing.

    ``backbone``: mask of non-rattlers; ``contact_i, contact_j, force``: backbone contacts and their
    forces ``f = −V'(r)`` (absolute units); ``mean_force``: their mean; ``localized``: mask over
    those contacts (weakest contact of a buckler); ``buckler_ids``: the bucklers; ``gap_i, gap_j,
    gap``: non-contact pairs with ``0 < h ≤ h_max`` (both ends on the backbone unless
    ``include_rattlers``); ``n_all_contacts``: contacts of all particles, rattlers included.
    """

    n: int
    dim: int
    backbone: NDArray[np.bool_]
    contact_i: IntArray
    contact_j: IntArray
    force: FloatArray
    mean_force: float
    localized: NDArray[np.bool_]
    buckler_ids: IntArray
    gap_i: IntArray
    gap_j: IntArray
    gap: FloatArray
    h_max: float
    n_all_contacts: int

    @property
    def n_rattlers(self) -> int:
        return int(self.n - self.backbone.sum())

    @property
    def n_contacts(self) -> int:
        """Backbone contacts ``N_c'``."""
        return int(self.force.size)

    @property
    def isostatic_excess(self) -> int:
        """``N_c' − (d(N' − 1) + 1)``."""
        return self.n_contacts - (self.dim * (int(self.backbone.sum()) - 1) + 1)

    @property
    def scaled_force(self) -> FloatArray:
        """``f / ⟨f⟩`` over the backbone contacts."""
        return self.force / self.mean_force

    @property
    def extended_force(self) -> FloatArray:
        """``f / ⟨f⟩`` of the extended contacts."""
        return self.scaled_force[~self.localized]

    @property
    def localized_force(self) -> FloatArray:
        """``f / ⟨f⟩`` of the localized contacts."""
        return self.scaled_force[self.localized]


def packing_observables(
    positions: ArrayLike,
    box_length: float,
    strain: float = 0.0,
    diameters: ArrayLike | None = None,
    alpha: float = 2.0,
    h_max: float = 0.5,
    include_rattlers: bool = False,
    pairs: PairList | None = None,
) -> PackingObservables:
    """Contacts, backbone, forces, bucklers and gaps of one packing (module docstring).

    ``pairs``: a precomputed :class:`PairList` holding at least every pair with
    ``r < σ_ij (1 + h_max)`` (then positions only give ``N`` and ``d``).
    """
    pos = _check_positions(positions, box_length)
    n, d = pos.shape
    if pairs is None:
        pairs = pairs_within(pos, box_length, strain, diameters, h_max)
    h = pairs.r / pairs.sigma - 1.0
    contact = h < 0
    ci, cj = pairs.i[contact], pairs.j[contact]
    keep = backbone_mask(n, ci, cj, d)
    live = keep[ci] & keep[cj]
    bi, bj = ci[live], cj[live]
    force = pair_force(pairs.r[contact][live], pairs.sigma[contact][live], alpha)
    buck, localized = bucklers(n, bi, bj, force, d)
    gap_pair = ~contact & (h <= h_max)
    if not include_rattlers:
        gap_pair &= keep[pairs.i] & keep[pairs.j]
    return PackingObservables(
        n=n,
        dim=d,
        backbone=keep,
        contact_i=bi,
        contact_j=bj,
        force=force,
        mean_force=float(force.mean()) if force.size else math.nan,
        localized=localized,
        buckler_ids=buck,
        gap_i=pairs.i[gap_pair],
        gap_j=pairs.j[gap_pair],
        gap=h[gap_pair],
        h_max=float(h_max),
        n_all_contacts=int(contact.sum()),
    )


