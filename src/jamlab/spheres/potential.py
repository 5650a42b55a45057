"""Harmonic soft spheres: packings, neighbour lists, energy, forces, stress, contacts, Hessian.

Conventions (``SPEC.md`` §3), diameter 1, unit energy:

- ``V(r) = (1 − r)²`` for ``r < 1``, else 0; ``E = Σ_{i<j} V(r_ij)`` (total, extensive).
- ``F_i = −∂E/∂r_i``.
- Shear stress (extensive) ``Σ = ∂E/∂γ`` at fixed reduced coordinates
  ``= Σ_{i<j} V'(r_ij) x_ij y_ij / r_ij``; intensive ``σ_xy = Σ / L^d``.
- Pressure ``p = −(1/(d L^d)) Σ_{i<j} V'(r_ij) r_ij``.
- Stress tensor (intensive) ``σ_ab = (1/L^d) Σ_{i<j} V'(r_ij) r_ij,a r_ij,b / r_ij``, so that
  ``σ_xy = Σ/L^d`` and ``p = −tr σ / d``.
- Contacts: pairs with ``r_ij < 1``; ``z = 2 N_c / N``. Rattlers: particles with fewer than
  ``d + 1`` contacts, removed repeatedly; ``z_nr = 2 N_c' / N'`` over the rest.

Every separation is ``r_ij = r_i − r_j`` for the (unique, as ``L > 2``) periodic image closer than
the cut-off; see :mod:`jamlab.spheres.box`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse

from jamlab.spheres import _kernels as K
from jamlab.spheres.box import Box, box_length_for

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
    "Evaluation",
    "evaluate",
]

DEFAULT_SKIN = 0.2
"""Verlet skin (diameters): the list holds pairs closer than ``1 + skin``."""


@dataclass(frozen=True, eq=False)
class Packing:
    """``N`` spheres of diameter 1 in a Lees–Edwards box.

    ``positions`` are Cartesian, ``(N, d)``, in the sheared frame (any periodic representative;
    :meth:`wrapped` maps them into ``[0, L)^d``). ``seed`` records where the configuration came
    from (``None`` if unknown). The box side must exceed 2 (twice the cut-off) so that every pair
    interacts through at most one periodic image.
    """

    positions: np.ndarray
    box: Box
    seed: int | None = field(default=None)

    def __post_init__(self) -> None:
        if not isinstance(self.box, Box):
            raise ValueError(f"box must be a jamlab.spheres.Box, got {type(self.box).__name__}")
        try:
            pos = np.array(self.positions, dtype=np.float64, order="C", copy=True)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"positions must be a numeric (N, d) array: {exc}") from None
        d = self.box.dim
        if pos.ndim != 2 or pos.shape[1] != d:
            raise ValueError(f"positions must have shape (N, {d}) for a {d}-d box, got {pos.shape}")
        n = pos.shape[0]
        if n < 2:
            raise ValueError(f"need at least 2 particles, got N={n}")
        bad = ~np.isfinite(pos)
        if bad.any():
            i, a = np.argwhere(bad)[0]
            raise ValueError(f"positions must be finite, got positions[{i}, {a}]={pos[i, a]}")
        if not self.box.length > 2.0:
            raise ValueError(
                f"box length must exceed 2 (twice the cut-off) for a unique interacting image, "
                f"got L={self.box.length} (N={n}, d={d}, phi={self.box.packing_fraction(n):.4g});"
                f" use more particles"
            )
        if self.seed is not None:
            if not isinstance(self.seed, int | np.integer) or isinstance(self.seed, bool):
                raise ValueError(f"seed must be an integer or None, got seed={self.seed!r}")
            object.__setattr__(self, "seed", int(self.seed))
        pos.setflags(write=False)
        object.__setattr__(self, "positions", pos)

    @property
    def n(self) -> int:
        """Number of particles ``N``."""
        return int(self.positions.shape[0])

    @property
    def dim(self) -> int:
        """Dimension ``d``."""
        return self.box.dim

    @property
    def phi(self) -> float:
        """Packing fraction ``φ = N v_d(1/2) / L^d``."""
        return self.box.packing_fraction(self.n)

    @property
    def strain(self) -> float:
        """Accumulated Lees–Edwards strain ``γ``."""
        return self.box.strain

    def wrapped(self) -> Packing:
        """The same configuration with positions mapped into ``[0, L)^d``."""
        return replace(self, positions=self.box.wrap(self.positions))

    def with_positions(self, positions: np.ndarray) -> Packing:
        """Same box and seed, new positions."""
        return replace(self, positions=positions)


def random_packing(n: int, dim: int, phi: float, seed: int) -> Packing:
    """Uniformly random positions in ``[0, L)^d`` with ``L = (N v_d(1/2)/φ)^(1/d)``, strain 0.

    Uses ``numpy.random.default_rng(seed)``.
    """
    if not (isinstance(n, int | np.integer) and n >= 2):
        raise ValueError(f"need at least 2 particles, got n={n!r}")
    if not (isinstance(phi, int | float | np.floating) and math.isfinite(phi) and phi > 0):
        raise ValueError(f"packing fraction must be finite and > 0, got phi={phi!r}")
    length = box_length_for(int(n), dim, float(phi))
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, length, size=(int(n), dim))
    return Packing(pos, Box(length, dim, 0.0), seed=int(seed))


def affine_shear(packing: Packing, dgamma: float) -> Packing:
    """Affine simple shear: ``x_i += δγ y_i`` and ``γ += δγ`` (reduced coordinates fixed)."""
    pos = np.array(packing.positions)
    pos[:, 0] += dgamma * pos[:, 1]
    return replace(packing, positions=pos, box=packing.box.with_strain(packing.strain + dgamma))


def _effective_skin(length: float, skin: float) -> float:
    # a pair may have only one image within 1 + skin, which needs L > 2 (1 + skin)
    return min(skin, 0.49 * (length - 2.0))


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
    """A Verlet list (pairs closer than ``1 + skin``) that follows positions and strain.

    Kept valid across affine strain steps: :meth:`update` moves the stored image shifts with the
    strain and rebuilds only when ``2 max_i |u_i| + |Δγ| (1 + skin) ≥ skin``, where ``u_i`` is the
    non-affine displacement since the last build (see :mod:`jamlab.spheres._kernels`).

    For memory locality the list works on the particles permuted by ``order`` (fixed at
    creation, :func:`spatial_order`): index ``k`` of the list is particle ``order[k]``. The
    functions of this module translate back, so callers only see the original numbering.
    """

    def __init__(self, packing: Packing, skin: float = DEFAULT_SKIN) -> None:
        if not (math.isfinite(skin) and skin >= 0):
            raise ValueError(f"skin must be finite and >= 0, got skin={skin!r}")
        self.box = packing.box
        self.skin = _effective_skin(packing.box.length, float(skin))
        self.n_builds = 0
        self.order = spatial_order(packing.positions, packing.box, max(1.0, 1.0 + self.skin))
        self.inverse = np.empty_like(self.order)
        self.inverse[self.order] = np.arange(len(self.order))
        self._build(self.sorted(packing.positions), packing.strain)

    def sorted(self, array: np.ndarray) -> np.ndarray:
        """Per-particle array in list order (``array[order]``), C-contiguous float64."""
        return np.ascontiguousarray(np.asarray(array, dtype=np.float64)[self.order])

    def unsorted(self, array: np.ndarray) -> np.ndarray:
        """Per-particle array from list order back to the original numbering."""
        return np.ascontiguousarray(array[self.inverse])

    @property
    def cutoff(self) -> float:
        """``rc = 1 + skin``."""
        return 1.0 + self.skin

    def _build(self, positions: np.ndarray, strain: float) -> None:
        pos = np.ascontiguousarray(positions, dtype=np.float64)
        self.start, self.nbr, self.shift, self.img_y = K.build_neighbor_list(
            pos, self.box.length, strain, self.cutoff
        )
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
                K.shift_images(self.shift, self.img_y, strain - self.strain, self.box.length)
                self.strain = float(strain)
            return False
        self._build(pos, strain)
        return True

    def _adopt(self, start, nbr, shift, img_y, ref, strain: float) -> None:
        self.start, self.nbr, self.shift, self.img_y = start, nbr, shift, img_y
        self.ref = ref
        self.ref_strain = self.strain = float(strain)
        self.n_builds += 1


def _neighbors(packing: Packing, neighbors: NeighborList | None) -> tuple[np.ndarray, NeighborList]:
    """Positions in list order and an up-to-date list."""
    if neighbors is None:
        nl = NeighborList(packing, skin=0.0)
        return nl.sorted(packing.positions), nl
    if neighbors.box.length != packing.box.length or neighbors.ref.shape != packing.positions.shape:
        raise ValueError("neighbour list belongs to a different box or particle number")
    neighbors.update(packing.positions, packing.strain)
    return neighbors.sorted(packing.positions), neighbors


def energy(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """Total energy ``E = Σ_{i<j} (1 − r_ij)² θ(1 − r_ij)``."""
    pos, nl = _neighbors(packing, neighbors)
    return float(K.energy(pos, nl.start, nl.nbr, nl.shift))


def energy_and_forces(
    packing: Packing, neighbors: NeighborList | None = None
) -> tuple[float, np.ndarray]:
    """``(E, F)`` with ``F_i = −∂E/∂r_i = Σ_j 2(1 − r_ij) r_ij / r_ij`` (shape ``(N, d)``)."""
    pos, nl = _neighbors(packing, neighbors)
    f = np.empty_like(pos)
    e = K.energy_forces_any(pos, nl.start, nl.nbr, nl.shift, f)
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
    pos, nl = _neighbors(packing, neighbors)
    f = np.empty_like(pos)
    s = np.empty((packing.dim, packing.dim))
    e, n_c = K.energy_forces_virial(pos, nl.start, nl.nbr, nl.shift, f, s)
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


def _virial(packing: Packing, neighbors: NeighborList | None) -> np.ndarray:
    pos, nl = _neighbors(packing, neighbors)
    return K.virial_tensor(pos, nl.start, nl.nbr, nl.shift)


def shear_stress(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """Extensive ``Σ = ∂E/∂γ = Σ_{i<j} V'(r_ij) x_ij y_ij / r_ij``, ``V'(r) = −2(1 − r)``."""
    return float(_virial(packing, neighbors)[0, 1])


def pressure(packing: Packing, neighbors: NeighborList | None = None) -> float:
    """``p = −(1/(d L^d)) Σ_{i<j} V'(r_ij) r_ij``."""
    s = _virial(packing, neighbors)
    return float(-np.trace(s) / (packing.dim * packing.box.volume))


def stress_tensor(packing: Packing, neighbors: NeighborList | None = None) -> np.ndarray:
    """Intensive ``σ_ab = (1/L^d) Σ_{i<j} V'(r_ij) r_ij,a r_ij,b / r_ij`` (``d × d``).

    ``σ_xy = Σ / L^d`` and ``p = −tr σ / d``.
    """
    return _virial(packing, neighbors) / packing.box.volume


def contacts(
    packing: Packing, neighbors: NeighborList | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs in contact, ``r_ij < 1``: ``(i, j, r_ij)`` with ``i < j``, ``r_ij = r_i − r_j``
    (minimum image), sorted by ``(i, j)``."""
    pos, nl = _neighbors(packing, neighbors)
    ci, cj, cd = K.contact_pairs(pos, nl.start, nl.nbr, nl.shift)
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
    keep = np.ones(n, dtype=bool)
    while True:
        live = keep[ci] & keep[cj]
        count = np.bincount(ci[live], minlength=n) + np.bincount(cj[live], minlength=n)
        drop = keep & (count < need)
        if not drop.any():
            break
        keep &= ~drop
    live = keep[ci] & keep[cj]
    n_c = int(live.sum())
    n_kept = int(keep.sum())
    z_nr = 2.0 * n_c / n_kept if n_kept else 0.0
    return RattlerResult(mask=keep, z_nr=z_nr, n_rattlers=n - n_kept, n_contacts_nr=n_c)


def hessian(packing: Packing, neighbors: NeighborList | None = None) -> scipy.sparse.csr_matrix:
    """Sparse Hessian ``H_{ia,jb} = ∂²E/∂r_ia ∂r_jb`` (``dN × dN``, row ``d·i + a``), CSR.

    Pair block ``B = V''(r) n nᵀ + (V'(r)/r)(1 − n nᵀ)``, ``V'' = 2``: ``H_ii = Σ_j B_ij``,
    ``H_ij = −B_ij``.
    """
    ci, cj, cd = contacts(packing, neighbors)
    rows, cols, vals = K.hessian_coo(ci, cj, cd)
    size = packing.n * packing.dim
    return scipy.sparse.coo_matrix((vals, (rows, cols)), shape=(size, size)).tocsr()


def dforce_dstrain(packing: Packing, neighbors: NeighborList | None = None) -> np.ndarray:
    """``Ξ_i = ∂F_i/∂γ`` under affine shear at fixed reduced coordinates, shape ``(N, d)``.

    ``Ξ_i = −Σ_j B_ij e_x y_ij``. With the Hessian ``H``, the non-affine response of a minimum is
    ``H du/dγ = Ξ`` (linear response) and ``dΣ/dγ = ∂²E/∂γ² − Ξ·H⁻¹Ξ``.
    """
    ci, cj, cd = contacts(packing, neighbors)
    return K.dforce_dstrain(packing.n, ci, cj, cd)
