"""The state of a system of soft spheres: :class:`Packing` (positions, box, diameters, pair
exponent), size distributions, random packings and the affine shear.

Conventions (``SPEC.md`` §3, §5): Cartesian positions in the sheared frame of a Lees–Edwards box
(:mod:`jamlab.spheres.box`); per-particle diameters ``D_i`` (default 1); the pair law
``V(r) = (1 − r/σ_ij)^α``, ``σ_ij = (D_i + D_j)/2`` (:mod:`jamlab.spheres.pair`, default
``α = 2``); packing fraction ``φ = Σ_i v_d(D_i/2) / L^d``.

Size distributions (``sizes`` argument, ``jamlab … --sizes``):

- ``mono``: ``D = 1`` (the paper's system);
- ``bidisperse``: 50:50, ``D_small = 1``, ``D_large = 1.4`` (``SPEC.md`` §5; the first
  ``⌈N/2⌉`` particles are small);
- ``polydisperse[:w]``: ``D_i = 1 + √3 w (2 (i + ½)/N − 1)``, the ``N`` mid-point quantiles of the
  uniform distribution with mean 1 and relative standard deviation ``w`` (default 0.1;
  ``0 < w < 1/√3``): deterministic, mean exactly 1 up to rounding, no random draw.
"""

from __future__ import annotations

import math
from dataclasses import InitVar, dataclass, field, replace

import numpy as np

from jamlab import validation
from jamlab.spheres.box import Box, box_length_for, sphere_volume
from jamlab.spheres.pair import HARMONIC, check_alpha, kernel_law

__all__ = [
    "Packing",
    "SIZE_KINDS",
    "BIDISPERSE_RATIO",
    "POLYDISPERSE_WIDTH",
    "parse_sizes",
    "size_distribution",
    "solid_volume",
    "box_length_for_diameters",
    "random_packing",
    "affine_shear",
    "COINCIDENCE",
    "check_box_side",
    "coincident_pair",
]

SIZE_KINDS = ("mono", "bidisperse", "polydisperse")
BIDISPERSE_RATIO = 1.4
"""``D_large / D_small`` of the bidisperse mixture (``D_small = 1``)."""
POLYDISPERSE_WIDTH = 0.1
"""Default relative standard deviation of the polydisperse (uniform) diameters."""


def parse_sizes(sizes: str) -> tuple[str, float | None]:
    """``"mono" | "bidisperse" | "polydisperse[:w]"`` as ``(kind, width)``; ``ValueError`` else."""
    if not isinstance(sizes, str):
        raise ValueError(f"sizes must be a string, got sizes={sizes!r}")
    kind, sep, rest = sizes.strip().partition(":")
    if kind not in SIZE_KINDS:
        raise ValueError(
            f"sizes must be mono, bidisperse or polydisperse[:width], got sizes={sizes!r}"
        )
    if sep and not rest:
        raise ValueError(f"sizes={sizes!r}: a width must follow ':'")
    if kind != "polydisperse":
        if rest:
            raise ValueError(f"sizes={sizes!r}: only polydisperse takes a width")
        return kind, None
    if not rest:
        return kind, POLYDISPERSE_WIDTH
    try:
        w = float(rest)
    except ValueError:
        raise ValueError(f"sizes={sizes!r}: the width must be a number") from None
    if not (math.isfinite(w) and 0.0 < w < 1.0 / math.sqrt(3.0)):
        raise ValueError(f"sizes={sizes!r}: the width must be in (0, 1/sqrt(3)) = (0, 0.577)")
    return kind, w


def size_distribution(n: int, sizes: str = "mono") -> np.ndarray:
    """The diameters ``D_i`` of ``n`` particles for a size specification (module docstring)."""
    kind, w = parse_sizes(sizes)
    if kind == "mono":
        return np.ones(n)
    if kind == "bidisperse":
        d = np.ones(n)
        d[(n + 1) // 2 :] = BIDISPERSE_RATIO
        return d
    q = 2.0 * (np.arange(n) + 0.5) / n - 1.0
    return 1.0 + math.sqrt(3.0) * w * q


def solid_volume(diameters: np.ndarray, dim: int) -> float:
    """``Σ_i v_d(D_i/2)``; exactly ``N v_d(1/2)`` when every ``D_i = 1``."""
    d = np.asarray(diameters, dtype=np.float64)
    if np.all(d == 1.0):
        return d.size * sphere_volume(dim)
    return float(np.sum(sphere_volume(dim, 0.5 * d)))


def box_length_for_diameters(diameters: np.ndarray, dim: int, phi: float) -> float:
    """Side ``L = (Σ_i v_d(D_i/2) / φ)^(1/d)`` giving packing fraction ``φ``."""
    if not (math.isfinite(phi) and phi > 0):
        raise ValueError(f"packing fraction must be finite and > 0, got phi={phi!r}")
    return (solid_volume(diameters, dim) / phi) ** (1.0 / dim)


def _check_diameters(diameters, n: int) -> np.ndarray:
    if isinstance(diameters, np.ndarray) and diameters.dtype == np.float64 and (
        not diameters.flags.writeable and diameters.shape == (n,)
    ):
        return diameters  # already checked (a Packing's own, shared by replace())
    try:
        d = np.array(diameters, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"diameters must be a numeric array of length N: {exc}") from None
    if d.shape != (n,):
        raise ValueError(f"diameters must have shape ({n},), got {d.shape}")
    if not (np.all(np.isfinite(d)) and np.all(d > 0)):
        i = int(np.argmax(~(np.isfinite(d) & (d > 0))))
        raise ValueError(f"diameters must be finite and > 0, got diameters[{i}]={d[i]}")
    d.setflags(write=False)
    return d


COINCIDENCE = 2.0**-40
"""Two particles closer than ``COINCIDENCE · L`` (minimum image, ``≈ 9.1e-13 L``) coincide: the
direction of their pair force is undefined at ``r = 0`` and, below a few thousand rounding units
of a coordinate of size ``L``, made of rounding noise, so :class:`Packing` refuses them."""


def check_box_side(box: Box, diameters: np.ndarray) -> None:
    """``ValueError`` unless the box side exceeds ``2 max D`` (twice the cut-off), so that every
    pair interacts through at most one periodic image."""
    sigma_max = float(diameters.max())
    if not box.length > 2.0 * sigma_max:
        n, d = diameters.size, box.dim
        raise ValueError(
            f"box length must exceed 2 max(D) = {2.0 * sigma_max:.4g} (twice the cut-off) for "
            f"a unique interacting image, got L={box.length} (N={n}, d={d}, "
            f"phi={solid_volume(diameters, d) / box.volume:.4g}); use more particles"
        )


def coincident_pair(positions: np.ndarray, box: Box) -> tuple[int, int, float] | None:
    """A pair ``(i, j, r)``, ``i < j``, of particles closer than ``COINCIDENCE · L`` (minimum
    image) if there is one, else ``None``. ``O(N log N)``, no pair search.

    If no two particles are that close along ``y`` (sorted), there is none. Otherwise: in the
    reduced frame ``s = h⁻¹ r`` (wrapped into ``[0, 1)^d``) such a pair differs by less
    than ``(1 + |γ'|) COINCIDENCE ≤ 1.5 COINCIDENCE`` along every axis. The unit cube is cut into
    ``m^d`` cells (``m = 2^⌊62/d⌋`` at most ``2^20``) in ``d + 1`` grids offset by ``1/(d + 1)``
    of a cell: boundaries of all grids along one axis are ``1/(m (d + 1))`` apart, far more than
    the pair's separation, so along each axis the pair straddles a boundary of at most one grid,
    and in at least one grid it shares a cell. Particles sharing a cell (sorted cell keys) are
    compared by their minimum-image distance."""
    n, d = positions.shape
    length = box.length
    s = positions / length
    s[:, 0] -= box.reduced_strain * s[:, 1]
    s -= np.floor(s)
    limit = COINCIDENCE * length
    # quick pass: such a pair is within COINCIDENCE of each other along y (periodic)
    y = np.sort(s[:, 1])
    if np.diff(y).min() >= COINCIDENCE and y[0] + 1.0 - y[-1] >= COINCIDENCE:
        return None
    bits = min(20, 62 // d)
    m = 1 << bits
    # fine = ⌊s m (d + 1)⌋ >= 0; the cell of grid k along an axis is ⌊(fine + k)/(d + 1)⌋ mod m
    fine = (s * (m * (d + 1))).astype(np.int64)
    for k in range(d + 1):
        cells = ((fine + k) // (d + 1)) & (m - 1)
        key = cells[:, 0].copy()
        for a in range(1, d):
            key |= cells[:, a] << (bits * a)
        ranked = np.sort(key)
        if not np.any(ranked[1:] == ranked[:-1]):
            continue
        order = np.argsort(key, kind="stable")
        ranked = key[order]
        same = np.flatnonzero(ranked[1:] == ranked[:-1])
        # the groups of equal keys: compare every pair in a group
        for start in same[np.r_[True, np.diff(same) > 1]]:
            stop = start + 1
            while stop < n and ranked[stop] == ranked[start]:
                stop += 1
            group = np.sort(order[start:stop])
            for a in range(len(group) - 1):
                dr = box.minimum_image(positions[group[a + 1 :]] - positions[group[a]])
                r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
                close = np.flatnonzero(r < limit)
                if close.size:
                    b = close[0]
                    return int(group[a]), int(group[a + 1 + b]), float(r[b])
    return None


@dataclass(frozen=True, eq=False)
class Packing:
    """``N`` spheres in a Lees–Edwards box.

    ``positions`` are Cartesian, ``(N, d)``, in the sheared frame (any periodic representative;
    :meth:`wrapped` maps them into ``[0, L)^d``). ``diameters`` (``(N,)``, default all 1) and
    ``alpha`` (default 2) fix the pair law ``V = (1 − r/σ_ij)^α``. ``seed`` records where the
    configuration came from (``None`` if unknown). The box side must exceed twice the largest
    diameter so that every pair interacts through at most one periodic image.
    """

    positions: np.ndarray
    box: Box
    seed: int | None = field(default=None)
    diameters: np.ndarray | None = field(default=None)
    alpha: float = field(default=HARMONIC)
    # False only for positions computed from this packing's own (with_positions: a minimiser's
    # iterate): the coincidence test, O(N log N), is then skipped (~3 % of a fast AQS step)
    check_coincidence: InitVar[bool] = True

    def __post_init__(self, check_coincidence: bool) -> None:
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
        diam = _check_diameters(np.ones(n) if self.diameters is None else self.diameters, n)
        object.__setattr__(self, "diameters", diam)
        object.__setattr__(self, "alpha", check_alpha(self.alpha))
        check_box_side(self.box, diam)
        pair = coincident_pair(pos, self.box) if check_coincidence else None
        if pair is not None:
            i, j, r = pair
            raise ValueError(
                f"particles {i} and {j} coincide (minimum-image distance {r:.3g} < "
                f"{COINCIDENCE:.3g} L): the direction of their pair force is undefined"
            )
        if self.seed is not None:
            if not validation.is_integer(self.seed):
                raise ValueError(f"seed must be an integer or None, got seed={self.seed!r}")
            # every seed jamlab writes and reads is in [0, 2^64 - 1] (GSD, LAMMPS data, runs)
            object.__setattr__(self, "seed", validation.seed("seed", int(self.seed)))
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
        """Packing fraction ``φ = Σ_i v_d(D_i/2) / L^d``."""
        if self.monodisperse:
            return self.box.packing_fraction(self.n)
        return solid_volume(self.diameters, self.dim) / self.box.volume

    @property
    def strain(self) -> float:
        """Accumulated Lees–Edwards strain ``γ``."""
        return self.box.strain

    @property
    def monodisperse(self) -> bool:
        """Every ``D_i = 1``."""
        return bool(np.all(self.diameters == 1.0))

    @property
    def kernel_law(self) -> tuple[np.ndarray | None, float | None]:
        """The pair law as numba kernels take it (:func:`jamlab.spheres.pair.kernel_law`):
        ``None`` for all ``D = 1`` and for ``α = 2`` (compile-time specialisations)."""
        return kernel_law(self.diameters, self.alpha)

    @property
    def sigma_max(self) -> float:
        """The largest contact distance ``max σ_ij = max_i D_i``."""
        return float(self.diameters.max())

    def wrapped(self) -> Packing:
        """The same configuration with positions mapped into ``[0, L)^d``."""
        return replace(self, positions=self.box.wrap(self.positions))

    def with_positions(self, positions: np.ndarray) -> Packing:
        """Same box, seed and pair law, new positions (computed from these: every check but the
        coincidence test, which a relaxation of a repulsive pair law cannot fail)."""
        return replace(self, positions=positions, check_coincidence=False)


def random_packing(
    n: int, dim: int, phi: float, seed: int, sizes: str = "mono", alpha: float = HARMONIC
) -> Packing:
    """Uniformly random positions in ``[0, L)^d`` at packing fraction ``φ``, strain 0.

    ``L = (Σ_i v_d(D_i/2)/φ)^(1/d)`` with the diameters of ``sizes`` (module docstring); uses
    ``numpy.random.default_rng(seed)``.
    """
    if not (validation.is_integer(n) and n >= 2):
        raise ValueError(f"need at least 2 particles, got n={n!r}")
    if not (validation.is_real(phi) and math.isfinite(phi) and phi > 0):
        raise ValueError(f"packing fraction must be finite and > 0, got phi={phi!r}")
    diam = size_distribution(int(n), sizes)
    if np.all(diam == 1.0):
        length = box_length_for(int(n), dim, float(phi))
    else:
        length = box_length_for_diameters(diam, dim, float(phi))
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, length, size=(int(n), dim))
    return Packing(pos, Box(length, dim, 0.0), seed=int(seed), diameters=diam, alpha=alpha)


def affine_shear(packing: Packing, dgamma: float) -> Packing:
    """Affine simple shear: ``x_i += δγ y_i`` and ``γ += δγ`` (reduced coordinates fixed)."""
    pos = np.array(packing.positions)
    pos[:, 0] += dgamma * pos[:, 1]
    # an affine map keeps distinct particles distinct: no coincidence test (Packing)
    return replace(packing, positions=pos, box=packing.box.with_strain(packing.strain + dgamma),
                   check_coincidence=False)
