"""Verlet neighbour lists under Lees–Edwards shear (cell search:
:mod:`jamlab.spheres.kernels.geometry`).

A :class:`NeighborList` holds every pair closer than ``rc = σ_max + skin`` (``σ_max`` the largest
diameter) in a half list in CSR form, and the pair law of its packing (diameters in list order and
``α``) for the kernels.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from jamlab.spheres import kernels as K
from jamlab.spheres.box import Box
from jamlab.spheres.state import Packing

__all__ = ["DEFAULT_SKIN", "NeighborList", "spatial_order", "effective_skin", "list_positions"]

DEFAULT_SKIN = 0.2
"""Verlet skin (in units of the diameter 1): the list holds pairs closer than ``σ_max + skin``."""

RELAX_SKIN = 0.03
"""Skin of the lists of relaxations that start next to a minimum (AQS at constant volume and at
fixed pressure, the barostat, the Newton relaxer and their FIRE fallbacks): particles move
≲ 1e-2 per minimisation there (the largest rearrangement measured at jamming: 7e-3), so a thin
shell saves pair checks in every force evaluation while rebuilds stay rare (0.2 → 0.1, then
0.1 → 0.03: ``docs/aqs.md``, "Cheaper FIRE iterations" and "A thinner skin for the
relaxations"). ``jam`` and ``prepare`` keep :data:`DEFAULT_SKIN` (large moves while
compressing)."""


def effective_skin(length: float, skin: float, sigma_max: float = 1.0) -> float:
    """The skin actually used: a pair may have only one image within ``σ_max + skin``, which
    needs ``L > 2 (σ_max + skin)``."""
    return min(skin, 0.49 * (length - 2.0 * sigma_max))


def spatial_order(positions: np.ndarray, box: Box, cell: float = 1.0) -> np.ndarray:
    """Permutation listing particles along a Morton (Z-order) curve through cells of side
    >= ``cell`` in the sheared frame, so that neighbours are close in memory."""
    L = box.length
    g = box.reduced_strain
    s = np.array(positions, dtype=np.float64) / L
    s[:, 0] -= g * s[:, 1]
    s -= np.floor(s)
    dim = s.shape[1]
    m = max(1, int(L // cell))
    bits = max(1, int(m - 1).bit_length())
    bits = min(bits, 62 // dim)
    k = np.minimum((s * m).astype(np.int64), m - 1) >> max(0, (m - 1).bit_length() - bits)
    key = np.zeros(len(s), dtype=np.int64)
    for b in range(bits - 1, -1, -1):
        for a in range(dim - 1, -1, -1):
            key = (key << 1) | ((k[:, a] >> b) & 1)
    return np.argsort(key, kind="stable")


class NeighborList:
    """A Verlet list (pairs closer than ``σ_max + skin``) that follows positions and strain.

    Kept valid across affine strain steps: :meth:`update` moves the image shifts with the
    strain (from the build's, ``built_shift``: a function of the build and the strain alone, not
    of the strains visited in between) and rebuilds only when ``2 max_i |u_i| + |Δγ| rc ≥
    skin``, where ``u_i`` is the non-affine displacement since the last build (see
    :mod:`jamlab.spheres.kernels.geometry`).

    For memory locality the list works on the particles permuted by ``order`` (fixed at
    creation, :func:`spatial_order`): index ``k`` of the list is particle ``order[k]``. The
    functions of :mod:`jamlab.spheres.potential` translate back, so callers only see the original
    numbering. ``diameters`` (list order) and ``alpha`` are the packing's pair law in the
    kernels' form (:func:`jamlab.spheres.pair.kernel_law`: ``None`` for ``D = 1``, ``α = 2``).
    """

    def __init__(self, packing: Packing, skin: float = DEFAULT_SKIN) -> None:
        if not (math.isfinite(skin) and skin >= 0):
            raise ValueError(f"skin must be finite and >= 0, got skin={skin!r}")
        self.box = packing.box
        self.sigma_max = packing.sigma_max
        self.skin = effective_skin(packing.box.length, float(skin), self.sigma_max)
        self.n_builds = 0
        self.order = spatial_order(
            packing.positions, packing.box, max(1.0, self.sigma_max + self.skin)
        )
        self.inverse = np.empty_like(self.order)
        self.inverse[self.order] = np.arange(len(self.order))
        self.source_diameters = packing.diameters
        self.pair_alpha = packing.alpha
        # the pair law in the kernels' form (pair.kernel_law): None for D = 1 and for α = 2
        diam, self.alpha = packing.kernel_law
        self.diameters = None if diam is None else np.ascontiguousarray(diam[self.order])
        self.rebuild(self.sorted(packing.positions), packing.strain)

    def sorted(self, array: np.ndarray) -> np.ndarray:
        """Per-particle array in list order (``array[order]``), C-contiguous float64."""
        return np.ascontiguousarray(np.asarray(array, dtype=np.float64)[self.order])

    def unsorted(self, array: np.ndarray) -> np.ndarray:
        """Per-particle array from list order back to the original numbering."""
        return np.ascontiguousarray(array[self.inverse])

    @property
    def cutoff(self) -> float:
        """``rc = σ_max + skin``."""
        return self.sigma_max + self.skin

    def matches(self, packing: Packing) -> bool:
        """Whether the list was made for this box side, particle number and pair law."""
        return (
            self.box.length == packing.box.length
            and self.ref.shape == packing.positions.shape
            and self.pair_alpha == packing.alpha
            and (
                self.source_diameters is packing.diameters
                or np.array_equal(self.source_diameters, packing.diameters)
            )
        )

    def rebuild(self, positions: np.ndarray, strain: float) -> None:
        """Build the list anew from positions in list order at strain ``strain``."""
        pos = np.ascontiguousarray(positions, dtype=np.float64)
        self.start, self.nbr, self.shift, self.img_y = K.build_neighbor_list(
            pos, self.box.length, strain, self.cutoff
        )
        self.built_shift = self.shift.copy()
        self.ref = pos.copy()
        self.ref_strain = float(strain)
        self.strain = float(strain)
        self.n_builds += 1

    def budget(self, strain: float | None = None) -> float:
        """Skin left for non-affine motion: ``skin − |γ − γ_build| rc``."""
        s = self.strain if strain is None else strain
        return self.skin - abs(s - self.ref_strain) * self.cutoff

    def affine_reference(self) -> np.ndarray:
        """Build-time positions (list order) carried by the affine strain since the build,
        ``x += (γ − γ_build) y``."""
        ref = self.ref.copy()
        ref[:, 0] += (self.strain - self.ref_strain) * ref[:, 1]
        return ref

    def update(self, positions: np.ndarray, strain: float) -> bool:
        """Follow new positions (same particles, original numbering) at strain ``strain``;
        return True if the list was rebuilt."""
        if np.shape(positions) != self.ref.shape:
            raise ValueError(
                f"positions must have shape {self.ref.shape}, got {np.shape(positions)}"
            )
        pos = self.sorted(positions)
        dg = strain - self.ref_strain
        budget = self.skin - abs(dg) * self.cutoff
        if budget > 0 and 2.0 * K.max_nonaffine_displacement(pos, self.ref, dg) < budget:
            if strain != self.strain:
                K.shift_images(
                    self.shift, self.built_shift, self.img_y, strain - self.ref_strain,
                    self.box.length,
                )
                self.strain = float(strain)
            return False
        self.rebuild(pos, strain)
        return True

    def adopt(self, start, nbr, shift, img_y, ref, strain: float) -> None:
        """Take over a list built elsewhere (e.g. inside the compiled FIRE loop) from positions
        ``ref`` (list order) at strain ``strain``."""
        self.start, self.nbr, self.shift, self.img_y = start, nbr, shift, img_y
        self.built_shift = shift.copy()
        self.ref = ref
        self.ref_strain = self.strain = float(strain)
        self.n_builds += 1


_LAST_SKIN_FREE = threading.local()
"""This thread's last skin-free list of :func:`list_positions`, with the packing it was built for
(``.packing``, ``.list``)."""


def list_positions(
    packing: Packing, neighbors: NeighborList | None
) -> tuple[np.ndarray, NeighborList]:
    """Positions in list order and an up-to-date list (a skin-free one if ``neighbors`` is None).

    The skin-free list of the last packing asked for without a list is kept (one per thread)
    and given again for the same packing object while its positions and strain are the ones
    it was built from: :func:`~jamlab.spheres.potential.evaluate`, ``virial`` and
    :func:`~jamlab.spheres.contacts.contacts` of one minimum then share one build. That list is
    the one a fresh build would make (the build depends on the positions, the box and the pair
    law alone), so the results are the same bits. Such a list never leaves these functions'
    callers in ``jamlab.spheres``; do not update it.

    ``ValueError`` if ``neighbors`` belongs to another box, particle number or pair law.
    """
    if neighbors is None:
        last = getattr(_LAST_SKIN_FREE, "packing", None)
        if last is packing:
            nl = _LAST_SKIN_FREE.list
            pos = nl.sorted(packing.positions)
            if nl.strain == nl.ref_strain == packing.strain and np.array_equal(pos, nl.ref):
                return pos, nl
        nl = NeighborList(packing, skin=0.0)
        _LAST_SKIN_FREE.packing, _LAST_SKIN_FREE.list = packing, nl
        return nl.sorted(packing.positions), nl
    if not neighbors.matches(packing):
        raise ValueError("neighbour list belongs to a different box, particle number or pair law")
    neighbors.update(packing.positions, packing.strain)
    return neighbors.sorted(packing.positions), neighbors
