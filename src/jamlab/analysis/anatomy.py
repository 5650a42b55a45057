"""Avalanche anatomy: what a plastic AQS step did to the configuration (pure functions on arrays).

Given the minima before and after a step (positions, box side ``L``, strains ``γ_b`` and
``γ_a``), the contact lists ``(i, j)`` of both, their backbone masks (rattlers removed) and,
optionally, the buckler mask before the step:

- the **non-affine displacement field** of the step, ``u_i = x_i^a − (x_i^b + (γ_a − γ_b) y_i^b
  e_x)`` reduced by the Lees–Edwards minimum image at ``γ_a`` (:func:`nonaffine_displacements`);
- the **event field** ``u^ev = u − u^el − t``: ``u`` without the linear elastic non-affine
  response of the minimum before, ``u^el = δγ K⁺ Ξ`` (:func:`elastic_response`), and without the
  uniform translation ``t`` (the backbone mean of ``u − u^el``, :func:`event_field`); the
  ``elastic_fraction`` ``Σ|u^el + t|² / Σ|u|²`` says how much was subtracted. Every number below
  is measured on ``u^ev``;
- the **participation ratio** ``PR = (Σ|u_i|²)² / (N Σ|u_i|⁴)`` (``u = u^ev``; ``1`` when every
  particle moves the same amount, ``1/N`` when one particle moves), and ``N_eff = PR·N``;
- the **largest displacement** ``max_i |u_i|``;
- the contacts **opened** (in the list before, not after) and **closed** (after, not before);
- whether it **involves only bucklers/rattlers** (:func:`only_bucklers_rattlers`);
- a **localized/extended** class (:func:`is_localized`);
- the **extent**: the principal radii of gyration of the event, the positions before the step
  weighted by ``|u_i|⁴`` (the weight of the denominator of ``PR``, so the particles that make
  ``N_eff``), and the axis of the smallest one (:func:`event_extent`). A compact event has
  three alike radii; a slip plane one small radius (its thickness) with the plane's normal as
  the thin axis, a box-spanning one two radii near the ``L/√12`` of a uniform spread.

**Rules.** *Buckler* (``SPEC.md`` §6): a backbone particle with exactly ``d + 1`` contacts with
backbone particles (:func:`buckler_mask`). *Only bucklers/rattlers*: at least one contact changed,
and every contact that opened or closed has an end that is a rattler (before or after the step)
or a buckler of the minimum before the step — a buckler flipping its weak contact, or a rattler
falling into or out of the cage, changes no contact between two ordinary backbone particles.
*Localized*: ``N_eff = PR·N ≤ n_eff_max`` (default :data:`N_EFF_LOCALIZED` = 10 particles). An
event with an elastic (Eshelby-like) far field ``|u| ∝ r^(1−d)`` has ``Σ|u|²`` and ``Σ|u|⁴``
dominated by the core, so its ``N_eff`` stays of order the core size whatever ``N``; an extended
(system-spanning) rearrangement has ``N_eff ∝ N``.

**Elastic response.** In a step ``δγ`` a minimum ``x`` with Hessian ``H`` and ``Ξ = ∂F/∂γ`` (at
fixed reduced coordinates) follows its branch as ``x(γ + δγ) = x + δγ y e_x + u^el + O(δγ²)``,
``H u^el = δγ Ξ`` (the forces ``F + δγ Ξ − H u^el`` vanish). ``H`` and ``Ξ`` are taken over the
contacts between backbone particles (rattlers removed: they carry no force at a minimum and
follow whatever the backbone does), solved with one backbone particle pinned (removing the
``d`` translations), then shifted to zero mean over the backbone; rattlers get ``u^el = 0``.
If the pinned backbone Hessian is not positive definite (the minimum before is not rigid:
floppy modes, e.g. an unjammed state at jamming) there is no linear response: ``u^el`` is NaN,
nothing is subtracted (``u^ev = u``) and ``elastic_fraction`` is NaN. A plastic event is what
the linear response does not predict, so ``u^ev`` is the event plus the ``O(δγ²)`` remainder
of the elastic step (and of the translation ``t``, which is no displacement of the packing).

The analysis package never imports ``jamlab.spheres``: the Lees–Edwards minimum image is
:func:`jamlab.lees_edwards.minimum_image`, the one that ``jamlab.spheres.box.Box`` uses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab.lees_edwards import minimum_image

__all__ = [
    "N_EFF_LOCALIZED",
    "EventAnatomy",
    "buckler_mask",
    "contact_changes",
    "elastic_response",
    "event_field",
    "event_anatomy",
    "event_extent",
    "is_localized",
    "isotropised_radii",
    "moved_particles",
    "nonaffine_displacements",
    "only_bucklers_rattlers",
    "orientation_tensor",
    "participation_ratio",
    "principal_axes",
]

N_EFF_LOCALIZED = 10.0
"""Default ``n_eff_max`` of :func:`is_localized`: an event with ``PR·N ≤ 10`` is localized."""


def nonaffine_displacements(
    before: ArrayLike,
    after: ArrayLike,
    length: float,
    strain_before: float,
    strain_after: float,
) -> NDArray[np.float64]:
    """Non-affine displacements ``u_i = x_i^a − (x_i^b + (γ_a − γ_b) y_i^b e_x)`` (minimum image
    at ``γ_a``), array ``(N, d)``. The affinely sheared ``x^b`` is a configuration of the box at
    ``γ_a``, so the difference is defined modulo that box's lattice; valid while ``|u_i| < L/2``."""
    xb = np.asarray(before, dtype=np.float64)
    xa = np.asarray(after, dtype=np.float64)
    if xb.shape != xa.shape or xb.ndim != 2 or xb.shape[1] < 2:
        raise ValueError(f"positions must be two (N, d) arrays, got {xb.shape} and {xa.shape}")
    affine = xb.copy()
    affine[:, 0] += (strain_after - strain_before) * xb[:, 1]
    return minimum_image(xa - affine, length, strain_after)


def participation_ratio(u: ArrayLike) -> float:
    """``PR = (Σ_i |u_i|²)² / (N Σ_i |u_i|⁴)`` of a displacement field ``(N, d)``; NaN if
    ``u = 0``."""
    u = np.asarray(u, dtype=np.float64)
    s2 = np.einsum("ij,ij->i", u, u)
    den = u.shape[0] * float(np.sum(s2 * s2))
    return float(np.sum(s2) ** 2 / den) if den > 0 else float("nan")


def _keys(i: ArrayLike, j: ArrayLike, n: int) -> NDArray[np.int64]:
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    return np.unique(np.minimum(i, j) * n + np.maximum(i, j))


def contact_changes(
    pairs_before: tuple[ArrayLike, ArrayLike], pairs_after: tuple[ArrayLike, ArrayLike], n: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(opened, closed)``: pairs ``(k, 2)`` (``i < j``, sorted) in contact before and not
    after, and after and not before."""
    kb = _keys(*pairs_before, n)
    ka = _keys(*pairs_after, n)
    opened = np.setdiff1d(kb, ka, assume_unique=True)
    closed = np.setdiff1d(ka, kb, assume_unique=True)
    return (
        np.stack([opened // n, opened % n], axis=1),
        np.stack([closed // n, closed % n], axis=1),
    )


def buckler_mask(ci: ArrayLike, cj: ArrayLike, backbone: ArrayLike, dim: int) -> NDArray[np.bool_]:
    """Bucklers (``SPEC.md`` §6): backbone particles with exactly ``d + 1`` contacts with
    backbone particles. ``ci, cj``: the contact list; ``backbone``: boolean mask ``(N,)``."""
    keep = np.asarray(backbone, dtype=bool)
    ci = np.asarray(ci, dtype=np.int64)
    cj = np.asarray(cj, dtype=np.int64)
    live = keep[ci] & keep[cj]
    z = np.bincount(ci[live], minlength=keep.size) + np.bincount(cj[live], minlength=keep.size)
    return keep & (z == dim + 1)


def only_bucklers_rattlers(
    opened: ArrayLike,
    closed: ArrayLike,
    backbone_before: ArrayLike,
    backbone_after: ArrayLike,
    bucklers_before: ArrayLike | None = None,
) -> bool:
    """True when at least one contact changed and every opened or closed pair has an end that is
    a rattler (before or after) or a buckler of the minimum before (module docstring)."""
    special = ~np.asarray(backbone_before, dtype=bool) | ~np.asarray(backbone_after, dtype=bool)
    if bucklers_before is not None:
        special = special | np.asarray(bucklers_before, dtype=bool)
    changed = np.concatenate(
        [
            np.asarray(opened, dtype=np.int64).reshape(-1, 2),
            np.asarray(closed, np.int64).reshape(-1, 2),
        ]
    )
    if changed.shape[0] == 0:
        return False
    return bool(np.all(special[changed[:, 0]] | special[changed[:, 1]]))


def is_localized(participation: float, n: int, n_eff_max: float = N_EFF_LOCALIZED) -> bool:
    """Localized when ``N_eff = PR·N ≤ n_eff_max`` (module docstring)."""
    return bool(participation * n <= n_eff_max)


def moved_particles(
    u: ArrayLike, threshold: float
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Indices (ascending) and displacement vectors of the particles with ``|u_i| > threshold``."""
    u = np.asarray(u, dtype=np.float64)
    idx = np.flatnonzero(np.sqrt(np.einsum("ij,ij->i", u, u)) > threshold)
    return idx.astype(np.int64), u[idx]


def event_extent(
    u: ArrayLike, positions: ArrayLike, length: float, strain: float, rounds: int = 3
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(radii, thin_axis)`` of a displacement field ``u`` ``(N, d)`` at ``positions`` (the
    minimum before the step; Lees–Edwards box of side ``length`` at ``strain``).

    With weights ``w_i = |u_i|⁴``: the centre ``c`` is the weighted mean of the minimum images
    ``r_i = x_i − c`` about the current centre (started at the heaviest particle, ``rounds``
    times), and the gyration tensor ``G = Σ w_i r_i r_iᵀ / Σ w_i``. ``radii``: the square roots
    of its eigenvalues, descending; ``thin_axis``: the unit eigenvector of the smallest, its
    largest component positive. Periodic: valid while the weight sits within ``L/2`` of the
    centre (a field spread over the box gives radii near ``L/√12``). ``u = 0``: NaN."""
    radii, axes = principal_axes(u, positions, length, strain, rounds)
    return radii, axes[-1]


def principal_axes(
    u: ArrayLike, positions: ArrayLike, length: float, strain: float, rounds: int = 3
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(radii, axes)`` of the gyration tensor of :func:`event_extent`: the radii descending
    and ``axes`` ``(d, d)``, row ``a`` the unit eigenvector of radius ``a`` (row 0 the long
    axis, the last the thin axis of :func:`event_extent`), each with its largest component
    positive. ``u = 0``: NaN."""
    centred = _centred(u, positions, length, strain, rounds)
    if centred is None:
        dim = np.shape(u)[1]
        return np.full(dim, np.nan), np.full((dim, dim), np.nan)
    r, w = centred
    lam, vec = np.linalg.eigh((r * w[:, None]).T @ r)
    axes = vec[:, ::-1].T.copy()
    for axis in axes:
        if axis[int(np.argmax(np.abs(axis)))] < 0:
            axis *= -1.0
    return np.sqrt(np.clip(lam[::-1], 0.0, None)), axes


def orientation_tensor(axes: ArrayLike) -> NDArray[np.float64]:
    """``Q = ⟨n nᵀ⟩ − I/d`` of unit vectors ``axes`` ``(k, d)`` (rows with a NaN left out):
    zero for directions uniform on the sphere, traceless, unchanged by ``n → −n``. NaN when no
    row is finite."""
    n = np.asarray(axes, dtype=np.float64)
    if n.ndim != 2:
        raise ValueError(f"axes must be (k, d), got shape {n.shape}")
    n = n[np.all(np.isfinite(n), axis=1)]
    dim = n.shape[1]
    if n.shape[0] == 0:
        return np.full((dim, dim), np.nan)
    return n.T @ n / n.shape[0] - np.eye(dim) / dim


def isotropised_radii(
    u: ArrayLike, positions: ArrayLike, length: float, strain: float, rng: np.random.Generator,
    rounds: int = 3,
) -> NDArray[np.float64]:
    """The radii of :func:`event_extent` after each particle's offset ``r_i`` from the centre is
    turned to a direction drawn uniformly at random (same ``|r_i|``, same weight): what the
    event's own weights and distances give with no preferred direction — the reference for the
    radii's ratios, with the anisotropy that a few dominant particles give by chance. NaN for
    ``u = 0``."""
    centred = _centred(u, positions, length, strain, rounds)
    if centred is None:
        return np.full(np.shape(u)[1], np.nan)
    r, w = centred
    v = rng.standard_normal(r.shape)
    v *= (np.sqrt(np.einsum("ij,ij->i", r, r)) / np.sqrt(np.einsum("ij,ij->i", v, v)))[:, None]
    return np.sqrt(np.clip(np.linalg.eigvalsh((v * w[:, None]).T @ v)[::-1], 0.0, None))


def _centred(
    u: ArrayLike, positions: ArrayLike, length: float, strain: float, rounds: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """``(r, w)``: the minimum images ``r_i = x_i − c`` about the weighted centre ``c`` and the
    normalised weights ``|u_i|⁴`` of :func:`event_extent`; ``None`` for ``u = 0``."""
    u = np.asarray(u, dtype=np.float64)
    x = np.asarray(positions, dtype=np.float64)
    if u.shape != x.shape or u.ndim != 2:
        raise ValueError(f"u and positions must have the same shape (N, d), got {u.shape} and "
                         f"{x.shape}")
    s2 = np.einsum("ij,ij->i", u, u)
    w = s2 * s2
    total = float(np.sum(w))
    if not total > 0:
        return None
    w = w / total
    centre = x[int(np.argmax(w))]
    for _ in range(max(1, int(rounds))):
        r = minimum_image(x - centre, length, strain)
        centre = centre + w @ r
    return minimum_image(x - centre, length, strain), w


def elastic_response(
    hessian: object, xi: ArrayLike, dgamma: float, backbone: ArrayLike
) -> NDArray[np.float64]:
    """The linear elastic non-affine response ``u^el = δγ K⁺ Ξ`` of a minimum (module
    docstring), array ``(N, d)``. ``hessian``: the ``dN × dN`` Hessian (SciPy sparse or dense,
    row ``d·i + a``) of the contacts between backbone particles; ``xi``: ``Ξ = ∂F/∂γ`` ``(N, d)``
    of the same contacts; ``backbone``: boolean mask ``(N,)``. Sparse LU (SuperLU, symmetric
    mode, no row pivoting) with the first backbone particle pinned; the signs of its pivots are
    those of the eigenvalues (Sylvester), so a pinned Hessian that is not positive definite
    gives NaN everywhere. Zero mean over the backbone; rattlers ``0``."""
    import scipy.sparse as sps  # here: SciPy's import costs every command's start-up
    import scipy.sparse.linalg as spla

    xi = np.asarray(xi, dtype=np.float64)
    keep = np.asarray(backbone, dtype=bool)
    n, dim = xi.shape
    if keep.shape != (n,):
        raise ValueError(f"backbone mask must have shape ({n},), got {keep.shape}")
    u = np.zeros((n, dim))
    idx = np.flatnonzero(keep)
    if idx.size < 2:
        return u
    free = idx[1:]
    dofs = (free[:, None] * dim + np.arange(dim)).ravel()
    k = sps.csr_matrix(hessian)[dofs][:, dofs].tocsc()
    try:
        lu = spla.splu(
            k,
            permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError:  # exactly singular
        return np.full((n, dim), np.nan)
    if not (np.array_equal(lu.perm_r, lu.perm_c) and np.all(lu.U.diagonal() > 0)):
        return np.full((n, dim), np.nan)
    u[free] = lu.solve(float(dgamma) * xi[free].ravel()).reshape(-1, dim)
    u[keep] -= u[keep].mean(axis=0)
    return u


def event_field(
    u: ArrayLike, elastic: ArrayLike, backbone: ArrayLike
) -> tuple[NDArray[np.float64], float]:
    """``(u^ev, elastic_fraction)``: ``u^ev = u − u^el − t`` with ``t`` the mean of ``u − u^el``
    over the ``backbone`` (the translation that fits best), ``elastic_fraction =
    Σ|u − u^ev|² / Σ|u|²``. A non-finite ``elastic`` (no linear response): ``(u, NaN)``."""
    u = np.asarray(u, dtype=np.float64)
    el = np.asarray(elastic, dtype=np.float64)
    keep = np.asarray(backbone, dtype=bool)
    if el.shape != u.shape:
        raise ValueError(f"elastic field must have shape {u.shape}, got {el.shape}")
    if not np.all(np.isfinite(el)):
        return u.copy(), float("nan")
    r = u - el
    if keep.any():
        r = r - r[keep].mean(axis=0)
    total = float(np.sum(u * u))
    sub = float(np.sum((u - r) ** 2))
    return r, (sub / total if total > 0 else float("nan"))


@dataclass(frozen=True, eq=False)
class EventAnatomy:
    """The anatomy of one event (module docstring): event field ``u`` ``(N, d)`` (``u^ev``;
    the raw non-affine field when no elastic response was given), ``raw`` (the non-affine
    field of the step), ``elastic_fraction``, ``participation`` ratio, ``max_displacement``,
    ``opened``/``closed`` pairs ``(k, 2)``, ``only_bucklers_rattlers``, ``localized``, the
    principal ``radii`` (descending) and ``thin_axis`` of :func:`event_extent`."""

    u: NDArray[np.float64]
    raw: NDArray[np.float64]
    elastic_fraction: float
    participation: float
    max_displacement: float
    opened: NDArray[np.int64]
    closed: NDArray[np.int64]
    only_bucklers_rattlers: bool
    localized: bool
    radii: NDArray[np.float64]
    thin_axis: NDArray[np.float64]

    @property
    def n_eff(self) -> float:
        """``PR·N``: the number of particles that effectively move."""
        return self.participation * self.u.shape[0]


def event_anatomy(
    before: ArrayLike,
    after: ArrayLike,
    length: float,
    strain_before: float,
    strain_after: float,
    pairs_before: tuple[ArrayLike, ArrayLike],
    pairs_after: tuple[ArrayLike, ArrayLike],
    backbone_before: ArrayLike,
    backbone_after: ArrayLike,
    bucklers_before: ArrayLike | None = None,
    n_eff_max: float = N_EFF_LOCALIZED,
    elastic: ArrayLike | None = None,
) -> EventAnatomy:
    """All the numbers of the module docstring for one step. ``bucklers_before=None``: computed
    from ``pairs_before`` and ``backbone_before`` (:func:`buckler_mask`). ``elastic``: ``u^el``
    of the minimum before (:func:`elastic_response`), subtracted by :func:`event_field`;
    ``None``: nothing subtracted (``u = raw``, ``elastic_fraction = 0``)."""
    raw = nonaffine_displacements(before, after, length, strain_before, strain_after)
    if elastic is None:
        u, fraction = raw, 0.0
    else:
        u, fraction = event_field(raw, elastic, backbone_before)
    n, dim = u.shape
    if bucklers_before is None:
        bucklers_before = buckler_mask(*pairs_before, backbone_before, dim)
    opened, closed = contact_changes(pairs_before, pairs_after, n)
    pr = participation_ratio(u)
    radii, axis = event_extent(u, before, length, strain_before)
    return EventAnatomy(
        u=u,
        raw=raw,
        elastic_fraction=fraction,
        participation=pr,
        max_displacement=float(np.sqrt(np.max(np.einsum("ij,ij->i", u, u)))),
        opened=opened,
        closed=closed,
        only_bucklers_rattlers=only_bucklers_rattlers(
            opened, closed, backbone_before, backbone_after, bucklers_before
        ),
        localized=is_localized(pr, n, n_eff_max),
        radii=radii,
        thin_axis=axis,
    )
