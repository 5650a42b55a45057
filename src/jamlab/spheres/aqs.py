"""Athermal quasi-static (AQS) simple shear with linear-response elastic steps.

Protocol (``SPEC.md`` §3): from a minimum at strain ``γ_n``, shear affinely ``x_i += δγ y_i``,
``γ_{n+1} = γ_n + δγ``, and minimise the energy at fixed strain. Recorded per step: see
:mod:`jamlab.spheres.trace`.

Fast elastic steps (``minimizer="linear"``). Let ``H`` be the Hessian at the minimum ``x_n``
restricted to the *backbone* (rattlers removed, :func:`~jamlab.spheres.potential.remove_rattlers`)
with one backbone particle pinned (removing the ``d`` global translations), ``K = H[b,b]``,
factorised with SuperLU in symmetric mode (no row pivoting, METIS nested-dissection order), so
that ``K = L D Lᵀ`` and the pivots ``D`` have the signs of the eigenvalues of ``K`` (Sylvester's
law of inertia): all pivots ``> 0`` ⇔ ``K`` positive definite. The factorisation is reused over
many steps; contacts that open or close since are added to it as rank-one (Woodbury)
corrections (:class:`_Factor`), and it is redone after plastic steps, backbone changes, failures
and periodically (``docs/aqs.md``). The step is the chord-Newton iteration

    x⁰ = x_n + δγ y e_x (affine),      x^{k+1} = x^k + K⁻¹ F_b(x^k),

whose first iterate is the linear-response prediction ``u = K⁻¹ F_b(x⁰) ≈ δγ K⁻¹ Ξ``
(``Ξ = ∂F/∂γ``, :func:`~jamlab.spheres.potential.dforce_dstrain`), iterated until
``max_i |F_i| < ftol`` on the backbone. Rattlers are held at their affinely moved positions during
the Newton solve; if their (contact) forces then exceed ``ftol`` FIRE relaxes the whole system from
there (it only moves rattlers in practice). The step is accepted as *elastic* when

1. the (damped) Newton iteration converges within ``max_newton`` iterations, every iteration
   lowering ``max |F_b|`` and, from the second on, at most ``max_strikes`` of them reducing it
   by less than the factor ``contraction`` (0.5);
2. it stays in the linear-response basin: the Newton corrections after the first step add up to
   at most ``linear_basin`` (0.5) times the linear prediction ``max_i |u_i|``;
3. the backbone Hessian at the new minimum is positive definite (all LDLᵀ pivots ``> 0``).

The common step is taken by :func:`_lean_step`: the same chord iteration in the neighbour
list's order with one fused kernel per iterate (forces, virial, contact state per list slot),
a weighted least-squares predictor over the minima of the current smooth piece of the branch
(:class:`_Path`) and a multisecant correction from the recent chord steps before each solve
(:class:`_Secants`); anything unusual hands the step to the general continuation below, so the
classification does not depend on which path took it.

If any test fails, the step goes to the general continuation of the branch ``x(γ)``
(``AQSParameters.continuation``). The default, ``"network"`` (:func:`_continue_network`), is
event-driven: between contact changes the branch is the minimum of the smooth energy of the
current contact network (every backbone contact a harmonic spring, in tension too), followed by
Newton; a substep whose end shows a contact of the set in tension or a new overlap between
backbone particles is cut back to the first crossing (linear interpolation of the overlaps in
``γ``), the set is switched there at zero force, the backbone recomputed (a particle left with
``d`` contacts is a rattler: all its forces vanished together) and positive definiteness
re-tested (refactorisation, or inertia additivity of the rank-one changes). Rattlers are ghosts
on the way and are moved out of their overlaps at the end. ``"substep"``
(:func:`_continue_branch`, the only one before the fourth session) halves the step
(``δγ/2, δγ/4, …``, doubling again after each success) with a fresh factorisation each time; near
jamming it is slow and its verdicts are wrong on some steps (``docs/aqs.md``). If the branch can
be continued to ``γ_{n+1}`` the step is elastic and the continued minimum is recorded; if it
cannot (the Hessian loses positive definiteness, at an event or inside a smooth piece, or Newton
fails even at substeps below ``δγ · min_substep``), the branch of ``x_n`` ends inside the step:
the step is *plastic* and FIRE minimises from the affinely sheared ``x_n``, carrying the
avalanche.

With ``minimizer="fire"`` every step is plain FIRE from the affinely sheared ``x_n``; the same
continuation (when ``classify=True``) then decides whether FIRE's minimum is the continuation of
``x_n`` (same energy and positions, :func:`_same_minimum`).

``plastic[n]`` is therefore: *the recorded minimum at γ_n is not the continuation of the minimum
at γ_{n-1}* — the branch ended, or (plain FIRE only) FIRE left a branch that continues. This does
not look at the sign of ``ΔE``; see ``docs/aqs.md``. A minimum without a backbone (every
particle a rattler: unjammed, ``E ≈ 0``) has no branch to end; its steps are plain FIRE and
elastic.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pymetis
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from jamlab.spheres import _aqs_kernels as AK
from jamlab.spheres import _kernels as K
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.neighbors import list_positions
from jamlab.spheres.pair import pair_sigmas
from jamlab.spheres.potential import (
    NeighborList,
    Packing,
    energy_and_forces,
    evaluate,
)
from jamlab.spheres.trace import TRACE_COLUMNS, Trace, write_trace

__all__ = [
    "AQSParameters",
    "ShearResult",
    "shear",
    "checkpoint_paths",
    "n_steps_for",
]

MINIMIZERS = ("linear", "fire")


@dataclass(frozen=True)
class AQSParameters:
    """Tolerances of the fast path and of the classification (see the module docstring).

    ``max_newton``: Newton iterations per (sub)step; ``max_chord``, ``chord_contraction``: chord
    steps with the stored factorisation tried first, each required to cut the force by that
    factor; ``contraction``: required reduction
    factor of ``max |F_b|`` per iteration; ``linear_basin``: allowed Newton correction relative to
    the linear prediction; ``min_substep``: smallest substep as a fraction of ``δγ`` before the
    branch is declared ended; ``energy_tol``: a one-substep step whose trapezoid residual
    ``|ΔE − ½ δγ ΔΣ|`` exceeds ``energy_tol · δγ²`` (energy units; a contact change inside the
    step gives ``≲ ΔG L^d δγ²/8``) is redone in 8 substeps as a safety check; ``match_tol``,
    ``energy_match``: largest displacement and relative energy difference between FIRE's minimum
    and the continued branch for them to count as the same minimum (:func:`_same_minimum`);
    ``max_fire_iter``: FIRE iteration cap. ``continuation``: ``"network"`` (event-driven, the
    default) or ``"substep"`` (the earlier natural continuation); ``event_tol``: a contact
    crossing closer than ``event_tol · δγ`` to the current point is switched there;
    ``max_events``: contact switches per step before the step is handed to the substep
    continuation.
    """

    max_newton: int = 30
    max_chord: int = 8
    chord_contraction: float = 0.2
    max_strikes: int = 3
    max_cg: int = 60
    max_corrections: int = 48
    refactor_every: int = 250
    stale_cg: int = 24
    contraction: float = 0.5
    linear_basin: float = 1.0
    min_substep: float = 1.0 / 1024
    energy_tol: float = 100.0
    match_tol: float = 1e-3
    energy_match: float = 1e-13
    max_fire_iter: int = 2_000_000
    max_lean_changes: int = 2
    secant_depth: int = 16
    secant_reach: float = 10.0
    path_depth: int = 16
    path_degree: int = 4
    path_floor: float = 1e-14
    continuation: str = "network"
    event_tol: float = 1e-3
    max_events: int = 1000

    def __post_init__(self) -> None:
        if not (isinstance(self.max_newton, int) and self.max_newton >= 1):
            raise ValueError(f"max_newton must be an integer >= 1, got {self.max_newton!r}")
        for name in ("contraction", "linear_basin", "min_substep"):
            v = getattr(self, name)
            if not (0 < v < 1 or (name == "linear_basin" and v > 0)):
                raise ValueError(f"{name} must be in (0, 1), got {v!r}")
        if self.continuation not in ("network", "substep"):
            raise ValueError(
                f"continuation must be 'network' or 'substep', got {self.continuation!r}"
            )
        for name in ("energy_tol", "match_tol", "energy_match", "event_tol"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")


@dataclass(frozen=True, eq=False)
class ShearResult:
    """Outcome of :func:`shear`: the ``trace``, the final minimum ``packing`` and counters.

    ``n_fallback``: steps where continuation failed and FIRE carried the step; ``n_substepped``:
    steps the fast path had to subdivide; ``n_cleanup``: steps where FIRE relaxed rattler forces
    after Newton; ``n_not_converged``: recorded minima with ``max_force ≥ ftol``; ``time``: wall
    clock seconds of the stepping loop.
    """

    trace: Trace
    packing: Packing
    n_fallback: int
    n_substepped: int
    n_cleanup: int
    n_not_converged: int
    time: float


# ------------------------------------------------------------------------------------------------
# linear algebra on the backbone


@dataclass(eq=False)
class _Factor:
    """Factorised pinned backbone Hessian ``M = K(x₀)`` at one configuration ``x₀``, and the
    low-rank corrections for the contacts that opened or closed since (:meth:`update`).

    A contact that closes adds ``2 n nᵀ`` to the pair block of ``K`` (its tangential part
    ``(V'/r)(1 − n nᵀ)`` vanishes at ``r = 1``), one that opens removes it. With ``U`` the
    columns ``b_c`` (``+n`` on particle ``i``, ``−n`` on ``j``, held particles left out) and
    ``S = diag(±2)``, the preconditioner is ``P = M + U S Uᵀ`` and (Woodbury)
    ``P⁻¹ = M⁻¹ − W C⁻¹ Wᵀ``, ``W = M⁻¹U``, ``C = S⁻¹ + UᵀW``; each new column of ``W`` costs
    one triangular solve, cached per contact. ``P`` is positive definite iff the number of
    positive eigenvalues of ``C`` equals the number of closed contacts (Haynsworth inertia
    additivity on ``[[M, U], [Uᵀ, −S⁻¹]]``, ``M`` positive definite): an exact test of the
    corrected matrix; where it fails the corrections are dropped and ``M`` alone preconditions
    (the iteration's own tests and a fresh factorisation then decide).
    """

    backbone: np.ndarray  # bool mask of backbone particles (incl. the pinned one)
    free: np.ndarray  # particle indices of the free backbone particles
    free_index: np.ndarray  # row block in K of each particle, -1 if held (pinned, rattler)
    lu: object | None
    positive_definite: bool
    fresh: bool = True  # factorised at the current minimum (not yet used for a step)
    keys0: np.ndarray | None = None  # sorted keys min(i,j)·N + max(i,j) at factorisation
    normals0: np.ndarray | None = None  # their separations r_ij at factorisation
    row0: np.ndarray | None = None  # keys0[row0[i]:row0[i+1]]: the pairs (i, j > i)
    corr_keys: np.ndarray | None = None  # keys of the corrected contacts (signed: + closed)
    w: np.ndarray | None = None  # W = M⁻¹U, one column per correction
    c_inv: np.ndarray | None = None  # C⁻¹
    corrected_pd: bool = True
    cache: dict | None = None  # signed key -> (dof indices, values, column of W)
    free_sorted: np.ndarray | None = None  # ``free`` in the neighbour list's order
    diameters: np.ndarray | None = None  # the pair law of the factorised packing
    alpha: float = 2.0

    def solve(self, r: np.ndarray) -> np.ndarray:
        """``P⁻¹ r`` (``M⁻¹ r`` without corrections)."""
        x = self.lu.solve(r)
        if self.w is not None:
            x -= self.w @ (self.c_inv @ (self.w.T @ r))
        return x

    def update(self, ci: np.ndarray, cj: np.ndarray, cd: np.ndarray, max_rank: int) -> None:
        """Set the corrections for the contact list ``(ci, cj, r_ij)`` of the current point.

        Without corrections (plain ``M``) when more than ``max_rank`` contacts changed or when
        ``P`` is not positive definite (``corrected_pd`` False): the iteration then runs with
        ``M`` alone, as before corrections existed, and its own tests decide."""
        n = self.free_index.size
        d = cd.shape[1]
        closed, where, opened = AK.contact_changes(self.keys0, self.row0, ci, cj, n)
        # only contacts touching a free particle enter K
        touch = (self.free_index[closed // n] >= 0) | (self.free_index[closed % n] >= 0)
        closed, where = closed[touch], where[touch]
        opened = opened[(self.free_index[opened // n] >= 0) | (self.free_index[opened % n] >= 0)]
        signed = np.concatenate([closed + 1, -(opened + 1)])
        if self.corr_keys is not None and np.array_equal(signed, self.corr_keys):
            return
        self.corr_keys, self.w, self.c_inv, self.corrected_pd = signed, None, None, True
        if signed.size == 0 or signed.size > max_rank or self.alpha != 2.0:
            # (α ≠ 2: the stiffness V''(σ⁻) of a contact at zero overlap is 0 for α > 2 —
            # nothing to correct — and infinite for α < 2; M alone preconditions)
            return
        cache = self.cache if self.cache is not None else {}
        self.cache = cache
        cols, idxs, vals = [], [], []
        for key in signed.tolist():
            if key not in cache:
                k = abs(key) - 1
                i, j = divmod(k, n)
                if key > 0:
                    v = cd[where[np.searchsorted(closed, k)]]
                else:  # an opened contact: its last separation is not in the list; use the
                    v = self.normals0[np.searchsorted(self.keys0, k)]  # one at x₀
                v = v / np.sqrt(v @ v)
                idx, val = [], []
                for particle, sign in ((i, 1.0), (j, -1.0)):
                    f = self.free_index[particle]
                    if f >= 0:
                        idx.extend(range(d * f, d * f + d))
                        val.extend((sign * v).tolist())
                idx_a, val_a = np.array(idx, dtype=np.int64), np.array(val)
                b = np.zeros(self.free.size * d)
                b[idx_a] = val_a
                cache[key] = (idx_a, val_a, self.lu.solve(b))
            idx_a, val_a, col = cache[key]
            cols.append(col)
            idxs.append(idx_a)
            vals.append(val_a)
        w = np.column_stack(cols)
        # S⁻¹ = diag(±1/V''(σ⁻)) with V''(σ⁻) = 2/σ_ij² for the harmonic law
        pairs = np.abs(signed) - 1
        sig = pair_sigmas(self.diameters, pairs // n, pairs % n)
        c = np.diag(np.where(signed > 0, 1.0, -1.0) * (0.5 * sig * sig))
        for a in range(signed.size):
            c[a, :] += vals[a] @ w[idxs[a], :]
        c = 0.5 * (c + c.T)
        eig = np.linalg.eigvalsh(c)
        self.corrected_pd = bool(
            np.count_nonzero(eig > 0) == np.count_nonzero(signed > 0)
            and np.min(np.abs(eig)) > 1e-12 * np.max(np.abs(eig))
        )
        if self.corrected_pd:
            self.w, self.c_inv = w, np.linalg.inv(c)


def _free_set(backbone: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    idx = np.flatnonzero(backbone)
    free = idx[1:]  # pin the first backbone particle: removes the d global translations
    free_index = np.full(backbone.shape[0], -1, dtype=np.int64)
    free_index[free] = np.arange(free.size)
    return free, free_index


def _contact_list(
    packing: Packing, nl: NeighborList
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs in contact ``(i, j, r_ij)`` (original numbering) in the neighbour list's order.

    The same set as :func:`~jamlab.spheres.potential.contacts` without its canonical sorting,
    which costs ten times the search itself; the pair block of the Hessian is even in
    ``r_ij``, and the rattler count does not depend on the order either.
    """
    pos, nl = list_positions(packing, nl)
    ci, cj, cd = K.contact_pairs(pos, nl.start, nl.nbr, nl.shift, nl.diameters)
    return nl.order[ci], nl.order[cj], cd


def _pair_keys(ci: np.ndarray, cj: np.ndarray, n: int) -> np.ndarray:
    """Order-free key ``min(i, j)·N + max(i, j)`` of each pair."""
    return np.minimum(ci, cj) * n + np.maximum(ci, cj)


def _backbone_mask(ci: np.ndarray, cj: np.ndarray, n: int, dim: int) -> np.ndarray:
    """Non-rattlers: repeatedly drop particles with fewer than ``dim + 1`` contacts among the
    kept ones (as :func:`~jamlab.spheres.potential.remove_rattlers`)."""
    keep = np.ones(n, dtype=bool)
    while True:
        live = keep[ci] & keep[cj]
        count = np.bincount(ci[live], minlength=n) + np.bincount(cj[live], minlength=n)
        drop = keep & (count < dim + 1)
        if not drop.any():
            return keep
        keep &= ~drop


def _backbone(packing: Packing, nl: NeighborList) -> np.ndarray:
    ci, cj, _ = _contact_list(packing, nl)
    return _backbone_mask(ci, cj, packing.n, packing.dim)


def _backbone_matrix(
    packing: Packing, nl: NeighborList, fac: _Factor, contacts: tuple | None = None
) -> sps.csr_matrix:
    ci, cj, cd = _contact_list(packing, nl) if contacts is None else contacts
    data, indices, indptr = AK.backbone_hessian_csr(
        ci, cj, cd, packing.diameters, packing.alpha, fac.free_index, fac.free.size
    )
    size = fac.free.size * packing.dim
    return sps.csr_matrix((data, indices, indptr), shape=(size, size))


_ND_MIN_FREE = 400  # fewer free particles: SuperLU's minimum-degree order (as fast there)


def _nested_dissection(free: np.ndarray, ci: np.ndarray, cj: np.ndarray, n: int) -> np.ndarray:
    """The free particles reordered by METIS nested dissection of their contact graph
    (``pymetis``; deterministic). On this graph it leaves ~20 % less fill in the factor than
    SuperLU's minimum-degree orderings and factorises ~1.6× faster (docs/aqs.md)."""
    if free.size < _ND_MIN_FREE:
        return free
    local = np.full(n, -1, dtype=np.int64)
    local[free] = np.arange(free.size)
    a, b = local[ci], local[cj]
    both = (a >= 0) & (b >= 0)
    if not both.any():
        return free
    a, b = a[both], b[both]
    graph = sps.csr_matrix(
        (np.ones(2 * a.size), (np.concatenate([a, b]), np.concatenate([b, a]))),
        shape=(free.size, free.size),
    )
    adjacency = pymetis.CSRAdjacency(
        adj_starts=graph.indptr.astype(np.int32), adjacent=graph.indices.astype(np.int32)
    )
    # METIS: row i of the permuted matrix is row perm[i] of the original
    perm, _ = pymetis.nested_dissection(adjacency=adjacency)
    return free[np.asarray(perm, dtype=np.int64)]


def _factorise(
    packing: Packing, nl: NeighborList, backbone: np.ndarray, contacts: tuple | None = None
) -> _Factor:
    """Factorise the backbone Hessian with one particle pinned; test positive definiteness.

    The free particles are numbered in a nested-dissection order of their contact graph
    (:func:`_nested_dissection`), so ``K`` is assembled already permuted and SuperLU runs in its
    natural order. With ``diag_pivot_thresh=0`` SuperLU does no row pivoting on a symmetric
    matrix, giving ``K = L U`` with ``U = D Lᵀ``; the inertia of ``K`` is the signs of
    ``diag(U)`` (Sylvester). Any row pivoting (``perm_r ≠ perm_c``) or a zero pivot is treated
    as "not positive definite".
    """
    free, free_index = _free_set(backbone)
    fac = _Factor(backbone, free, free_index, None, False)
    fac.diameters, fac.alpha = packing.diameters, packing.alpha
    if free.size == 0:
        return fac
    ci, cj, cd = _contact_list(packing, nl) if contacts is None else contacts
    fac.free = _nested_dissection(free, ci, cj, packing.n)
    fac.free_index[fac.free] = np.arange(fac.free.size)
    k = _backbone_matrix(packing, nl, fac, (ci, cj, cd))
    keys = _pair_keys(ci, cj, packing.n)  # ci > cj after a re-sort
    order = np.argsort(keys)
    fac.keys0 = keys[order]
    fac.row0 = np.searchsorted(fac.keys0, np.arange(packing.n + 1) * packing.n)
    fac.normals0 = cd[order]
    # K is symmetric, so its CSR arrays read as CSC are K itself: no conversion
    kc = sps.csc_matrix((k.data, k.indices, k.indptr), shape=k.shape)
    try:
        lu = spla.splu(
            kc,
            permc_spec="NATURAL" if fac.free.size >= _ND_MIN_FREE else "MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError:  # exactly singular
        return fac
    pivots = lu.U.diagonal()
    fac.lu = lu
    fac.positive_definite = bool(np.array_equal(lu.perm_r, lu.perm_c) and np.all(pivots > 0))
    return fac


def _max_norm(f: np.ndarray) -> float:
    return float(np.sqrt(np.max(np.einsum("ij,ij->i", f, f)))) if f.size else 0.0


def _pcg(
    k: sps.csr_matrix, b: np.ndarray, precond: Callable, atol: float, maxiter: int, d: int
) -> tuple[np.ndarray, bool, int]:
    """Preconditioned conjugate gradients for ``K x = b``, ``M⁻¹ = precond`` (a nearby ``K⁻¹``).

    Stops when the largest per-particle residual ``max_i |(b − Kx)_i| < atol``. Returns
    ``(x, ok, iterations)``; ``ok`` is False on negative curvature ``pᵀKp ≤ 0`` (``K`` not
    positive definite on the Krylov space) or no convergence within ``maxiter``.
    """
    x = np.zeros_like(b)
    r = b.copy()
    z = precond(r)
    p = z.copy()
    rz = float(r @ z)
    for it in range(maxiter + 1):
        if _max_norm(r.reshape(-1, d)) < atol:
            return x, True, it
        if it == maxiter:
            break
        kp = k @ p
        curvature = float(p @ kp)
        if not curvature > 0:
            return x, False, it
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * kp
        z = precond(r)
        rz_new = float(r @ z)
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, False, maxiter


@dataclass(frozen=True, eq=False)
class _Newton:
    packing: Packing
    ok: bool
    iterations: int
    cg_iterations: int


def _newton(
    start: Packing, nl: NeighborList, fac: _Factor, ftol: float, params: AQSParameters
) -> _Newton:
    """Damped Newton ``x ← x + α K(x)⁻¹ F_b(x)`` on the free backbone until ``max |F_b| < ftol``.

    Each solve is PCG preconditioned with the factorisation ``fac``; ``α ∈ {1, ½, ¼, ⅛}`` is the
    first that lowers ``max |F_b|`` (a contact that opens or closes makes the Hessian jump and the
    full step overshoot; the damping stops the iteration from cycling between contact sets).
    Fails (tests: module docstring) when no ``α`` lowers the force, when more than
    ``max_strikes`` iterations from the second on do not contract by ``contraction``, when the
    corrections leave the linear-response basin, on negative curvature, or after
    ``max_newton`` iterations.
    """
    pos = np.array(start.positions)
    free = fac.free
    d = start.dim
    linear = 0.0
    correction = np.zeros((free.size, d))
    cg_total = 0
    strikes = 0
    current = start.with_positions(pos)
    f = energy_and_forces(current, nl)[1][free]
    fmax = _max_norm(f)
    prev = math.inf
    # cheap first: chord steps x ← x + M⁻¹ F_b with the stored factorisation M ≈ K; accepted only
    # while each contracts the force by the factor chord_contraction (M⁻¹K ≈ 1 on the excited
    # modes, i.e. the branch is as stable as where M was taken), else full Newton below
    chord_pos, chord_f, chord_fmax = pos, f, fmax
    for chord in range(params.max_chord):
        if chord_fmax < ftol:
            return _Newton(start.with_positions(chord_pos), True, chord, 0)
        # the preconditioner follows the contacts that opened or closed since it was factorised
        fac.update(*_contact_list(start.with_positions(chord_pos), nl), params.max_corrections)
        trial_pos = chord_pos.copy()
        trial_pos[free] += fac.solve(chord_f.ravel()).reshape(free.size, d)
        trial_f = energy_and_forces(start.with_positions(trial_pos), nl)[1][free]
        trial_fmax = _max_norm(trial_f)
        if not trial_fmax < params.chord_contraction * chord_fmax:
            if trial_fmax < ftol and trial_fmax < params.contraction * chord_fmax:
                # converged, though M⁻¹K is only roughly 1 here (a contact changed in the step)
                return _Newton(start.with_positions(trial_pos), True, chord + 1, 0)
            break
        chord_pos, chord_f, chord_fmax = trial_pos, trial_f, trial_fmax
    else:
        if chord_fmax < ftol:
            return _Newton(start.with_positions(chord_pos), True, params.max_chord, 0)
    for it in range(params.max_newton + 1):
        if fmax < ftol:
            return _Newton(current, True, it, cg_total)
        if it == params.max_newton:
            break
        if it >= 2 and fmax > params.contraction * prev:
            strikes += 1
            if strikes > params.max_strikes:
                break
        prev = fmax
        contacts = _contact_list(current, nl)
        k = _backbone_matrix(current, nl, fac, contacts)
        fac.update(*contacts, params.max_corrections)
        # the next force check decides; 0.25 ftol leaves room for the O(dx²) remainder
        atol = max(0.25 * ftol, 1e-9 * fmax)
        dx, ok, cg_its = _pcg(k, f.ravel(), fac.solve, atol, params.max_cg, d)
        cg_total += cg_its
        if not ok:
            break
        dx = dx.reshape(free.size, d)
        accepted = False
        for alpha in (1.0, 0.5, 0.25, 0.125):
            trial_pos = pos.copy()
            trial_pos[free] += alpha * dx
            trial = start.with_positions(trial_pos)
            f_trial = energy_and_forces(trial, nl)[1][free]
            f_trial_max = _max_norm(f_trial)
            if f_trial_max < fmax:
                accepted = True
                break
        if not accepted:
            break
        if it == 0:
            linear = float(np.max(np.abs(alpha * dx)))
        else:
            correction += alpha * dx
            # far from the linear prediction: not in the linear-response basin of this branch
            if float(np.max(np.abs(correction))) > params.linear_basin * linear + 1e-12:
                break
        pos, current, f, fmax = trial_pos, trial, f_trial, f_trial_max
    return _Newton(current, False, it, cg_total)


class _Path:
    """The minima of the current smooth piece of the branch, for the predictor of the next step.

    Holds (at most ``depth``) cumulative non-affine displacements ``z_k`` of the minima since the
    piece began (a plastic step or a contact change) and their residual forces ``noise_k``. The
    predicted non-affine displacement of the next step is ``ẑ(+1) − z₀`` with ``ẑ`` the
    polynomial of degree ``≤ degree`` fitted to the ``z_k`` by least squares weighted with
    ``1/max(noise_k, floor)²``, in the step index: the fit averages the residual noise of the
    minima instead of amplifying it as exact interpolation does (``4, −6, 4, −1`` for a cubic
    through four points), and minima recorded with larger residuals count less. After a
    contact change the first prediction is the step that contained it (``straddle``).
    Stored as a ring buffer: one matrix-vector product per prediction.
    """

    def __init__(self, depth: int, degree: int, floor: float) -> None:
        self.depth, self.degree, self.floor = depth, degree, floor
        self.buf: np.ndarray | None = None
        self.noise = np.zeros(depth)
        self.head = -1
        self.count = 0
        self.straddle: np.ndarray | None = None

    def reset(self) -> None:
        self.count, self.straddle = 0, None

    def add(self, u: np.ndarray, noise: float, kinked: bool) -> None:
        flat = u.ravel()
        self.shape = u.shape
        if self.buf is None or self.buf.shape[1] != flat.size:
            self.buf, self.count = np.zeros((self.depth, flat.size)), 0
        if kinked or self.count == 0:
            self.head, self.count = 0, 1
            self.buf[0] = 0.0
            self.noise[0] = noise
            self.straddle = u if kinked else None
            return
        new = (self.head + 1) % self.depth
        np.add(self.buf[self.head], flat, out=self.buf[new])
        self.head = new
        self.noise[new] = noise
        self.count = min(self.count + 1, self.depth)
        self.straddle = None

    def predict(self) -> np.ndarray | None:
        m = self.count
        if m == 0:
            return None
        if m == 1:
            return self.straddle
        degree = min(self.degree, m - 1)
        idx = (self.head - np.arange(m)) % self.depth  # newest first
        t = -np.arange(m, dtype=np.float64) / (m - 1)  # steps scaled to [-1, 0]: conditioning
        v = np.vander(t, degree + 1, increasing=True)
        sw = 1.0 / np.maximum(self.noise[idx], self.floor)
        # coefficients c with ẑ(t₊) = Σ c_k z_k for the weighted fit (Σ c_k = 1), by QR of
        # √W V = Q R: c = √W Q R⁻ᵀ e(t₊), e(t₊) the monomials at the next step t₊ = 1/(m−1)
        q, r = np.linalg.qr(sw[:, None] * v)
        e = (1.0 / (m - 1)) ** np.arange(degree + 1)
        c = sw * (q @ np.linalg.solve(r.T, e))
        full = np.zeros(self.depth)
        full[idx] = c
        full[self.head] -= 1.0  # ẑ(+1) − z₀
        return (full @ self.buf).reshape(self.shape)


class _Secants:
    """Recent chord steps ``s_k = P⁻¹ r_k`` and the force changes ``y_k = r_k − r'_k ≈ K s_k``
    they produced (free coordinates, neighbour-list order), for a correction without a solve:
    a residual ``r`` close to their span is removed by ``dx = S a``, ``a = argmin ‖r − Y a‖``
    (a multisecant step); the force at the corrected point decides whether it is kept. Ring
    buffers with the Gram matrix ``YᵀY`` kept up to date."""

    def __init__(self, depth: int) -> None:
        self.depth = depth
        self.s: np.ndarray | None = None
        self.y: np.ndarray | None = None
        self.gram = np.zeros((depth, depth))
        self.head = -1
        self.count = 0

    def clear(self) -> None:
        self.count = 0

    def push(self, s: np.ndarray, y: np.ndarray) -> None:
        s, y = s.ravel(), y.ravel()
        if self.s is None or self.s.shape[1] != s.size:
            self.s, self.y = np.zeros((self.depth, s.size)), np.zeros((self.depth, s.size))
            self.count = 0
        self.head = (self.head + 1) % self.depth
        self.s[self.head] = s
        self.y[self.head] = y
        self.count = min(self.count + 1, self.depth)
        row = self.y @ y  # (rows not filled yet are never read)
        self.gram[self.head, :] = row
        self.gram[:, self.head] = row

    def correction(self, r: np.ndarray) -> np.ndarray | None:
        m = self.count
        if m == 0:
            return None
        idx = (self.head - np.arange(m)) % self.depth
        b = (self.y @ r.ravel())[idx]
        g = self.gram[np.ix_(idx, idx)]
        try:
            a = np.linalg.solve(g + 1e-14 * np.trace(g) * np.eye(m), b)
        except np.linalg.LinAlgError:
            return None
        full = np.zeros(self.depth)
        full[idx] = a
        return (full @ self.s).reshape(r.shape)


def _contact_keys(packing: Packing, nl: NeighborList) -> np.ndarray:
    """Sorted keys ``min(i, j)·N + max(i, j)`` of the contacts."""
    ci, cj, _ = _contact_list(packing, nl)
    return np.sort(_pair_keys(ci, cj, packing.n))


def _consistent_flags(
    packing: Packing, nl: NeighborList, fac: _Factor, params: AQSParameters
) -> tuple[np.ndarray | None, int]:
    """Contact state of every neighbour-list slot at the minimum ``packing`` and the list's build
    number, once ``fac`` has been corrected for the contacts changed since its factorisation;
    ``(None, -1)`` when the corrected factor does not hold them (too many changes, or the
    corrected matrix not positive definite) or there is nothing to factorise."""
    if fac.lu is None or fac.free.size == 0:
        return None, -1
    fac.update(*_contact_list(packing, nl), params.max_corrections)
    if fac.corr_keys is not None and fac.corr_keys.size and fac.w is None:
        return None, -1
    pos = nl.sorted(packing.positions)
    d = pos.shape[1]
    flags = np.empty(nl.nbr.size, dtype=np.uint8)
    AK.forces_virial_flags(
        pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha,
        np.empty_like(pos), np.empty((d, d)), flags, True,
    )
    return flags, nl.n_builds


def _lean_step(
    cur: Packing,
    target: float,
    predictor: np.ndarray | None,
    nl: NeighborList,
    fac: _Factor,
    flags: np.ndarray,
    prev: dict[str, float],
    ftol: float,
    params: AQSParameters,
    secants: _Secants | None = None,
    affine: Packing | None = None,
) -> tuple[Packing, dict[str, float], int, tuple | None] | None:
    """The common elastic step in as few passes over the pairs as possible, or ``None``.

    The chord iteration of :func:`_newton` (each step cutting ``max|F_b|`` by
    ``chord_contraction``, by ``contraction`` once a contact has changed in the step; at most
    ``max_chord`` steps), run in the neighbour list's particle
    order with one fused kernel per iterate (forces, virial and the contact state of every list
    slot, compared with ``flags``: the contacts of the minimum ``cur``, with which ``fac`` and
    its corrections are consistent). When a contact opens or closes at an iterate, the
    correction of ``fac`` is updated there (as :func:`_newton` does) and the iteration goes on,
    provided the backbone stays the same and the corrected factor is positive definite (at most
    ``max_lean_changes`` times per step). A neighbour-list rebuild, a force left on a rattler,
    a trapezoid residual above ``energy_tol δγ²``, a chord step that does not contract, or a
    change of the backbone returns ``None``, and the general continuation
    (:func:`_continue`) takes the step instead.

    Returns ``(minimum, row, chord steps, change)``; ``change`` is ``None`` when the contact
    set is that of ``cur``, else ``(flags, contact keys)`` of the new contact set.
    """
    if affine is None:
        affine = _affine_to(cur, target)
    pos = affine.positions if predictor is None else affine.positions + predictor
    builds = nl.n_builds
    nl.update(pos, target)
    if nl.n_builds != builds:
        return None
    if fac.free_sorted is None:
        fac.free_sorted = nl.inverse[fac.free]
    free_s = fac.free_sorted
    n = cur.n
    d = pos.shape[1]
    z_nr = prev["z_nr"]
    change = None
    n_changes = 0

    def adopt(ps: np.ndarray) -> bool:
        # contacts opened or closed at this iterate: correct the factor for them
        nonlocal flags, change, z_nr, n_changes
        n_changes += 1
        if n_changes > params.max_lean_changes:
            return False
        ci, cj, cd = _contact_list(affine.with_positions(nl.unsorted(ps)), nl)
        if nl.n_builds != builds:
            return False
        keep = _backbone_mask(ci, cj, n, d)
        if not np.array_equal(keep, fac.backbone):
            return False
        fac.update(ci, cj, cd, params.max_corrections)
        if fac.corr_keys is not None and fac.corr_keys.size and fac.w is None:
            return False
        flags = np.empty_like(flags)
        AK.forces_virial_flags(
            ps, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha,
            np.empty_like(ps), np.empty((d, d)), flags, True,
        )
        n_kept = int(keep.sum())
        z_nr = 2.0 * int((keep[ci] & keep[cj]).sum()) / n_kept
        change = (flags, np.sort(_pair_keys(ci, cj, n)))
        return True

    def at(x: np.ndarray) -> tuple[tuple, int]:
        # one pass: (x, F, S, E, N_c, F on the free particles, its max) and the contact changes
        fx = np.empty_like(x)
        sx = np.empty((d, d))
        ex, ncx, ch = AK.forces_virial_flags(
            x, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha, fx, sx, flags, False
        )
        return (x, fx, sx, ex, ncx, AK.gather_rows(fx, free_s), AK.rows_max_norm(fx, free_s)), ch

    state, changed = at(nl.sorted(pos))
    if changed and not adopt(state[0]):
        return None
    its = 0
    while not state[6] < ftol:
        ps, fb, fmax = state[0], state[5], state[6]
        if (
            secants is not None
            and fmax < params.secant_reach * ftol
            and (dx := secants.correction(fb)) is not None
        ):
            # first without a solve: the part of the residual the recent chord steps explain
            trial, changed = at(AK.moved(ps, free_s, dx))
            if not changed and trial[6] < params.contraction * fmax:
                state = trial
                if trial[6] < ftol:
                    break
                ps, fb, fmax = state[0], state[5], state[6]
        if its == params.max_chord:
            return None
        dx = fac.solve(fb.ravel()).reshape(free_s.size, d)
        trial, changed = at(AK.moved(ps, free_s, dx))
        its += 1
        tmax = trial[6]
        # after a contact change in this step the rank-one correction is exact only at zero
        # overlap and the new contact stiffens as it closes: contraction by `contraction` then
        required = params.contraction if n_changes else params.chord_contraction
        if not (tmax < required * fmax or (tmax < ftol and tmax < params.contraction * fmax)):
            return None
        if changed and not adopt(trial[0]):
            return None
        if secants is not None:
            secants.push(dx, fb - trial[5])
        state = trial
    ps, f, s, e, n_c = state[:5]
    # the list must still hold every pair at the final positions (NeighborList.update's test)
    dg = target - nl.ref_strain
    if not 2.0 * K.max_nonaffine_displacement(ps, nl.ref, dg) < nl.skin - abs(dg) * nl.cutoff:
        return None
    positions = nl.unsorted(ps)
    max_force = float(K.max_force(f))
    if not max_force < ftol:  # a rattler (or the pinned particle) to relax: general path
        return None
    row = {
        "energy": float(e),
        "shear_stress": float(s[0, 1]),
        "pressure": float(-np.trace(s) / (d * cur.box.volume)),
        "z": 2.0 * n_c / n,
        "z_nr": z_nr,
        "max_force": max_force,
    }
    r = row["energy"] - prev["energy"] - 0.5 * (target - prev["gamma"]) * (
        prev["shear_stress"] + row["shear_stress"]
    )
    if abs(r) > params.energy_tol * (target - prev["gamma"]) ** 2:
        return None
    fac.fresh = False
    return affine.with_positions(positions), row, its, change


def _affine_to(packing: Packing, strain: float) -> Packing:
    pos = np.array(packing.positions)
    pos[:, 0] += (strain - packing.strain) * pos[:, 1]
    return replace(packing, positions=pos, box=packing.box.with_strain(strain))


@dataclass(frozen=True, eq=False)
class _Branch:
    packing: Packing | None  # None: the branch ends inside the step
    factor: _Factor | None
    iterations: int
    cg_iterations: int
    substeps: int
    refactorised: int
    events: int = 0  # contact-set switches (event-driven continuation)


def _continue_branch(
    start: Packing,
    fac: _Factor,
    strain: float,
    nl: NeighborList,
    ftol: float,
    params: AQSParameters,
    first_substep: float = 1.0,
    predictor: np.ndarray | None = None,
) -> _Branch:
    """Follow the minimum ``start`` to ``strain`` by natural continuation (module docstring).

    A failed (sub)step with a factorisation from an earlier configuration is retried after
    refactorising at the current point; with a fresh one the substep is halved. The branch ends
    when the fresh factorisation is not positive definite or the substep falls below
    ``min_substep``.
    """
    its = cg = substeps = refac = 0
    g0 = start.strain
    total = strain - g0
    cur = start
    t = 0.0
    s = first_substep
    while t < 1.0:
        if fac.lu is None or not fac.positive_definite:
            if fac.fresh:
                return _Branch(None, None, its, cg, substeps, refac)
            fac = _factorise(cur, nl, _backbone(cur, nl))
            refac += 1
            continue
        last = s >= 1.0 - t
        t_new = 1.0 if last else t + s
        target = strain if last else g0 + t_new * total
        trial = _affine_to(cur, target)
        if predictor is not None and t == 0.0 and last:
            # extrapolated non-affine displacement of the previous elastic steps
            trial = trial.with_positions(trial.positions + predictor)
        res = _newton(trial, nl, fac, ftol, params)
        its += res.iterations
        cg += res.cg_iterations
        if res.ok:
            cur, t = res.packing, t_new
            substeps += 1
            s = min(2.0 * s, 1.0)
            fac.fresh = False
            if t >= 1.0:
                break  # the caller compares the backbone at the end of the step
            backbone = _backbone(cur, nl)
            if not np.array_equal(backbone, fac.backbone):
                fac = _factorise(cur, nl, backbone)
                refac += 1
            continue
        if not fac.fresh:
            fac = _factorise(cur, nl, _backbone(cur, nl))
            refac += 1
            continue
        s *= 0.5
        if s < params.min_substep:
            return _Branch(None, None, its, cg, substeps, refac)
    return _Branch(cur, fac, its, cg, substeps, refac)


# ------------------------------------------------------------------------------------------------
# event-driven continuation on the contact network


def _network_forces(packing: Packing, ci: np.ndarray, cj: np.ndarray) -> tuple[np.ndarray, ...]:
    """Forces of the contact network ``E_C = Σ_{c ∈ C} (1 − r_c)²`` (every pair of ``C`` a
    harmonic spring of rest length 1, in tension too) and the pairs' separations and lengths."""
    pos = packing.positions
    dr = packing.box.minimum_image(pos[ci] - pos[cj])
    r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
    fp = K.pair_force_factors(r, ci, cj, packing.diameters, packing.alpha)[:, None] * dr  # on i
    n, d = pos.shape
    f = np.empty((n, d))
    for a in range(d):
        f[:, a] = np.bincount(ci, fp[:, a], minlength=n) - np.bincount(cj, fp[:, a], minlength=n)
    return f, dr, r


def _network_newton(
    start: Packing,
    ci: np.ndarray,
    cj: np.ndarray,
    fac: _Factor,
    ftol: float,
    params: AQSParameters,
) -> tuple[Packing | None, int, int]:
    """Newton on the smooth network energy ``E_C`` from ``start`` (affinely sheared), each solve
    PCG preconditioned by ``fac``, with the damping, contraction and linear-basin tests of
    :func:`_newton`. Returns ``(minimum or None, iterations, CG iterations)``."""
    free, d = fac.free, start.dim
    pos = np.array(start.positions)
    cur = start
    f, dr, _ = _network_forces(cur, ci, cj)
    fb = f[free]
    fmax = _max_norm(fb)
    linear = 0.0
    correction = np.zeros((free.size, d))
    cg_total = strikes = 0
    prev = math.inf
    for it in range(params.max_newton + 1):
        if fmax < ftol:
            return cur, it, cg_total
        if it == params.max_newton:
            break
        if it >= 2 and fmax > params.contraction * prev:
            strikes += 1
            if strikes > params.max_strikes:
                break
        prev = fmax
        data, indices, indptr = AK.backbone_hessian_csr(
            ci, cj, dr, start.diameters, start.alpha, fac.free_index, free.size
        )
        size = free.size * d
        k = sps.csr_matrix((data, indices, indptr), shape=(size, size))
        atol = max(0.25 * ftol, 1e-9 * fmax)
        dx, ok, cg_its = _pcg(k, fb.ravel(), fac.solve, atol, params.max_cg, d)
        cg_total += cg_its
        if not ok:
            break
        dx = dx.reshape(free.size, d)
        for alpha in (1.0, 0.5, 0.25, 0.125):
            trial_pos = pos.copy()
            trial_pos[free] += alpha * dx
            trial = start.with_positions(trial_pos)
            f_t, dr_t, _ = _network_forces(trial, ci, cj)
            fmax_t = _max_norm(f_t[free])
            if fmax_t < fmax:
                break
        else:
            break
        if it == 0:
            linear = float(np.max(np.abs(alpha * dx)))
        else:
            correction += alpha * dx
            if float(np.max(np.abs(correction))) > params.linear_basin * linear + 1e-12:
                break
        pos, cur, fb, dr, fmax = trial_pos, trial, f_t[free], dr_t, fmax_t
    return None, it, cg_total


def _switch_keeps_pd(
    cur: Packing,
    ci: np.ndarray,
    cj: np.ndarray,
    fac: _Factor,
    pi: np.ndarray,
    pj: np.ndarray,
    signs: np.ndarray,
    params: AQSParameters,
) -> tuple[bool, int]:
    """Whether ``K' = K + U S Uᵀ`` is positive definite, ``K`` the network Hessian of the pairs
    ``(ci, cj)`` at ``cur``, ``U`` the columns ``b`` (``+n`` on ``i``, ``−n`` on ``j``, free
    particles only) of the switched pairs ``(pi, pj)``, ``S = diag(2 · signs / σ²)`` (the
    harmonic contact stiffness at zero overlap; the caller uses this only for ``α = 2``).

    With ``K`` positive definite (PCG meeting no negative curvature), ``K'`` is iff the
    capacitance ``C = S⁻¹ + Uᵀ K⁻¹ U`` has as many positive eigenvalues as pairs added (Haynsworth
    inertia additivity, as in :class:`_Factor`); ``K⁻¹ U`` by PCG preconditioned by ``fac`` to a
    relative residual ``1e-12``. Returns ``(positive definite, CG iterations)``."""
    d = cur.dim
    free_index, n_free = fac.free_index, fac.free.size
    _, dr, _ = _network_forces(cur, ci, cj)
    data, indices, indptr = AK.backbone_hessian_csr(
        ci, cj, dr, cur.diameters, cur.alpha, free_index, n_free
    )
    k = sps.csr_matrix((data, indices, indptr), shape=(n_free * d, n_free * d))
    sep = cur.box.minimum_image(cur.positions[pi] - cur.positions[pj])
    sep /= np.sqrt(np.einsum("ij,ij->i", sep, sep))[:, None]
    u = np.zeros((n_free * d, pi.size))
    for c in range(pi.size):
        for particle, sign in ((pi[c], 1.0), (pj[c], -1.0)):
            f = free_index[particle]
            if f >= 0:
                u[d * f : d * f + d, c] = sign * sep[c]
    z = np.empty_like(u)
    cg = 0
    for c in range(pi.size):
        scale = float(np.max(np.abs(u[:, c])))
        if scale == 0.0:  # both ends held: the pair does not enter K
            z[:, c] = 0.0
            continue
        x, ok, its = _pcg(k, u[:, c], fac.solve, 1e-12 * scale, 10 * params.max_cg, d)
        cg += its
        if not ok:
            return False, cg
        z[:, c] = x
    sig = pair_sigmas(cur.diameters, pi, pj)
    c_mat = np.diag(0.5 * (sig * sig) / signs) + u.T @ z
    eig = np.linalg.eigvalsh(0.5 * (c_mat + c_mat.T))
    n_added = int(np.count_nonzero(signs > 0))
    pd = np.count_nonzero(eig > 0) == n_added and np.min(np.abs(eig)) > 1e-10 * np.max(np.abs(eig))
    return bool(pd), cg


def _relax_rattlers(
    packing: Packing, nl: NeighborList, backbone: np.ndarray, ftol: float, max_iter: int = 100
) -> Packing | None:
    """Move the rattlers (``~backbone``) out of their overlaps, the backbone held.

    The event-driven continuation treats rattlers as ghosts, so at its end they may overlap the
    backbone by ~δγ. Each iteration moves every rattler by the mean over its contacts of
    ``(1 − r) n`` (the displacement that empties one contact; half of it for a pair of
    rattlers). Done when no contact touches a rattler (their forces, and theirs on the
    backbone, are then exactly zero) or all such forces are below ``ftol``; ``None`` if not
    within ``max_iter`` (a caged "rattler": the caller's FIRE then relaxes everything).
    """
    rattler = ~backbone
    if not rattler.any():
        return packing
    pos = np.array(packing.positions)
    n, d = pos.shape
    for _ in range(max_iter):
        cur = packing.with_positions(pos)
        ci, cj, _ = _contact_list(cur, nl)
        touch = rattler[ci] | rattler[cj]
        if not touch.any():
            return cur
        ci, cj = ci[touch], cj[touch]
        dr = cur.box.minimum_image(pos[ci] - pos[cj])
        r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
        push = ((pair_sigmas(cur.diameters, ci, cj) - r) / r)[:, None] * dr  # on i; −push on j
        if 2.0 * float(np.max(np.sqrt(np.einsum("ij,ij->i", push, push)))) < ftol:
            return cur
        both = rattler[ci] & rattler[cj]
        share = np.where(both, 0.5, 1.0)[:, None] * push
        move = np.zeros((n, d))
        count = np.bincount(ci[rattler[ci]], minlength=n) + np.bincount(
            cj[rattler[cj]], minlength=n
        )
        for a in range(d):
            move[:, a] = np.bincount(ci, share[:, a] * rattler[ci], minlength=n) - np.bincount(
                cj, share[:, a] * rattler[cj], minlength=n
            )
        moving = count > 0
        pos[moving] += move[moving] / count[moving, None]
    return None


def _continue_network(
    start: Packing,
    fac: _Factor | None,
    strain: float,
    nl: NeighborList,
    ftol: float,
    params: AQSParameters,
    first_substep: float = 1.0,
    predictor: np.ndarray | None = None,
) -> _Branch:
    """Follow the minimum ``start`` to ``strain`` event by event (``docs/aqs.md``).

    Between contact changes the branch is the minimum of the smooth network energy ``E_C`` of
    the current contact set ``C`` (backbone pairs; rattlers are ghosts, moved out of their
    overlaps at the end by :func:`_relax_rattlers`). A substep whose end is consistent (every
    pair of ``C`` still compressed, no new overlap between backbone particles) is accepted;
    otherwise the first crossing inside it is located by interpolating the overlaps linearly in
    ``γ`` and stepping there, and once it is within ``event_tol · δγ`` the set is switched
    (pairs removed or added at zero force) and the backbone recomputed (a particle left with
    ``d`` contacts is a rattler). The branch ends when the network Hessian after a switch is not
    positive definite (a fresh factorisation if the free set changed or is small, else
    :func:`_switch_keeps_pd`), or when Newton fails even at substeps below ``min_substep`` of
    the step. ``fac`` (may be ``None``) preconditions the solves if it has the same backbone.
    """
    n, dim = start.n, start.dim
    its = cg = substeps = refac = events = calls = 0
    ci, cj, cd = _contact_list(start, nl)
    backbone = _backbone_mask(ci, cj, n, dim)
    live = backbone[ci] & backbone[cj]
    ci, cj = ci[live], cj[live]

    def factorise(packing: Packing) -> _Factor | None:
        nonlocal refac
        _, dr, _ = _network_forces(packing, ci, cj)
        refac += 1
        fac = _factorise(packing, nl, backbone, (ci, cj, dr))
        return fac if fac.lu is not None and fac.positive_definite else None

    def ended() -> _Branch:
        return _Branch(None, None, its, cg, substeps, refac, events)

    if (
        fac is None
        or fac.lu is None
        or not fac.positive_definite
        or not np.array_equal(fac.backbone, backbone)
    ):
        fac = factorise(start)
        if fac is None:
            return ended()
    # else: the caller's factorisation (same backbone, positive definite at a nearby minimum)
    # preconditions the solves until the first event
    g0 = start.strain
    total = strain - g0
    cur = start
    h = first_substep * total
    while True:
        g = cur.strain
        last = g + h >= strain - 1e-9 * abs(total)
        target = strain if last else g + h
        trial = _affine_to(cur, target)
        if predictor is not None and g == g0 and last:
            trial = trial.with_positions(trial.positions + predictor)
        new, it_n, cg_n = _network_newton(trial, ci, cj, fac, ftol, params)
        calls += 1
        its += it_n
        cg += cg_n
        if new is None:
            h *= 0.5
            if h < params.min_substep * abs(total):
                return ended()
            continue
        # consistency at the new point: pairs of C compressed, no new backbone overlaps
        _, _, r_new = _network_forces(new, ci, cj)
        opening = np.flatnonzero(r_new >= pair_sigmas(new.diameters, ci, cj))
        ai, aj, _ = _contact_list(new, nl)
        both = backbone[ai] & backbone[aj]
        ai, aj = ai[both], aj[both]
        keys_c = np.sort(_pair_keys(ci, cj, n))
        keys_a = _pair_keys(ai, aj, n)
        fresh_pairs = ~np.isin(keys_a, keys_c, assume_unique=False)
        ai, aj = ai[fresh_pairs], aj[fresh_pairs]
        if opening.size == 0 and ai.size == 0:
            cur = new
            substeps += 1
            if last:
                relaxed = _relax_rattlers(cur, nl, backbone, ftol)
                return _Branch(
                    cur if relaxed is None else relaxed, fac, its, cg, substeps, refac, events
                )
            h = min(2.0 * h, strain - cur.strain)
            continue
        # an event inside (g, target]: overlaps o = σ − r at both ends, crossing by interpolation
        pi = np.concatenate([ci[opening], ai])
        pj = np.concatenate([cj[opening], aj])
        sig = pair_sigmas(cur.diameters, pi, pj)
        dr_a = cur.box.minimum_image(cur.positions[pi] - cur.positions[pj])
        dr_b = new.box.minimum_image(new.positions[pi] - new.positions[pj])
        o_a = sig - np.sqrt(np.einsum("ij,ij->i", dr_a, dr_a))
        o_b = sig - np.sqrt(np.einsum("ij,ij->i", dr_b, dr_b))
        with np.errstate(divide="ignore", invalid="ignore"):
            theta = np.nan_to_num(np.clip(o_a / (o_a - o_b), 0.0, 1.0), nan=0.0)
        span = target - g
        tol = params.event_tol * abs(total)
        first = float(theta.min())
        if first * span <= tol:
            now = theta * span <= tol  # crossing at cur: switch there
        elif np.all((1.0 - theta) * span <= tol):
            cur = new  # every crossing at the end of the substep: accept it, switch there
            substeps += 1
            now = np.ones(theta.size, dtype=bool)
        else:
            h = first * span  # step to (about) the first crossing
            continue
        events += 1
        if events > params.max_events or calls > 10 * params.max_events:
            # pathological (events piling up): the substep continuation takes the whole step
            fac = _factorise(start, nl, _backbone(start, nl))
            b = _continue_branch(start, fac, strain, nl, ftol, params)
            return replace(
                b, iterations=b.iterations + its, refactorised=b.refactorised + refac + 1
            )
        # switch at cur: the pairs crossing here leave (opening) or join (closing) the set
        n_open = opening.size
        drop = _pair_keys(pi[:n_open][now[:n_open]], pj[:n_open][now[:n_open]], n)
        keep = ~np.isin(_pair_keys(ci, cj, n), drop)
        old_ci, old_cj, old_backbone = ci, cj, backbone
        ci = np.concatenate([ci[keep], pi[n_open:][now[n_open:]]])
        cj = np.concatenate([cj[keep], pj[n_open:][now[n_open:]]])
        backbone = _backbone_mask(ci, cj, n, dim)
        live = backbone[ci] & backbone[cj]
        ci, cj = ci[live], cj[live]
        if not backbone.any():
            return ended()
        if (
            fac.free.size >= _ND_MIN_FREE
            and cur.alpha == 2.0
            and np.array_equal(backbone, old_backbone)
        ):
            # same free set: K changes by ±2 b bᵀ per switched pair (zero force at the switch),
            # and its positive definiteness follows from the old K's by inertia additivity
            # (small free sets are refactorised instead: cheaper there)
            signs = np.where(np.arange(pi.size) < n_open, -1.0, 1.0)[now]
            pd, _ = _switch_keeps_pd(cur, old_ci, old_cj, fac, pi[now], pj[now], signs, params)
            if not pd:
                return ended()  # the network lost positive definiteness at the event: unstable
        else:
            fac = factorise(cur)  # the free set changed (a particle became a rattler or not)
            if fac is None:
                return ended()
        h = strain - cur.strain  # (0 at the end: re-converge there with the new set)


def _continue(
    start: Packing,
    fac: _Factor,
    strain: float,
    nl: NeighborList,
    ftol: float,
    params: AQSParameters,
    first_substep: float = 1.0,
    predictor: np.ndarray | None = None,
) -> _Branch:
    """The continuation chosen by ``params.continuation``: ``"network"`` (event-driven,
    :func:`_continue_network`) or ``"substep"`` (:func:`_continue_branch`)."""
    if params.continuation == "network":
        return _continue_network(start, fac, strain, nl, ftol, params, first_substep, predictor)
    return _continue_branch(start, fac, strain, nl, ftol, params, first_substep, predictor)


def _same_minimum(a: Packing, b: Packing, nl: NeighborList, params: AQSParameters) -> bool:
    """Whether two minima at the same strain are one: energies equal within
    ``energy_match · max(1, |E|)`` and backbone-free positions within ``match_tol`` after
    removing the mean displacement.

    Positions alone are not enough near jamming: along modes of stiffness ``λ`` a minimiser
    stopped at ``max|F| < ftol`` is off by ``ftol/λ`` (1e-5 at ``λ = 1e-7``), while its energy
    is off by only ``ftol²/λ``.
    """
    ea = energy_and_forces(a, nl)[0]
    eb = energy_and_forces(b, nl)[0]
    if abs(ea - eb) > params.energy_match * max(1.0, abs(ea)):
        return False
    dr = a.box.minimum_image(a.positions - b.positions)
    dr -= dr.mean(axis=0)
    return bool(np.max(np.abs(dr)) < params.match_tol)


# ------------------------------------------------------------------------------------------------
# observables


def _observe(packing: Packing, nl: NeighborList) -> tuple[dict[str, float], np.ndarray]:
    """Row of the trace at a minimum, and the backbone mask (rattlers removed as in
    :func:`~jamlab.spheres.potential.remove_rattlers`, from one contact list)."""
    ev = evaluate(packing, nl)
    ci, cj, _ = _contact_list(packing, nl)
    n = packing.n
    keep = _backbone_mask(ci, cj, n, packing.dim)
    n_kept = int(keep.sum())
    n_c_kept = int((keep[ci] & keep[cj]).sum())
    row = {
        "energy": ev.energy,
        "shear_stress": ev.shear_stress,
        "pressure": ev.pressure,
        "z": 2.0 * ci.size / n,
        "z_nr": 2.0 * n_c_kept / n_kept if n_kept else 0.0,
        "max_force": ev.max_force,
    }
    return row, keep


# ------------------------------------------------------------------------------------------------
# the driver


def n_steps_for(dgamma: float, gamma_max: float) -> int:
    """``M = round(γ_max / δγ)`` strain steps; validates ``0 < δγ < γ_max``."""
    if not (isinstance(dgamma, int | float) and math.isfinite(dgamma) and dgamma > 0):
        raise ValueError(f"dgamma must be finite and > 0, got dgamma={dgamma!r}")
    if not (isinstance(gamma_max, int | float) and math.isfinite(gamma_max)):
        raise ValueError(f"gamma_max must be finite, got gamma_max={gamma_max!r}")
    if not gamma_max > dgamma:
        raise ValueError(f"need dgamma < gamma_max, got dgamma={dgamma!r}, gamma_max={gamma_max!r}")
    return int(round(gamma_max / dgamma))


def checkpoint_paths(out: str | Path) -> tuple[Path, Path]:
    """``(last, snapshots)``: where :func:`shear` saves the last configuration
    (``<stem>.last.h5``) and every ``save_every``-th one (``<stem>.configs/step_XXXXXXXX.h5``)."""
    out = Path(out)
    stem = out.name[: -len(out.suffix)] if out.suffix else out.name
    return out.with_name(f"{stem}.last.h5"), out.with_name(f"{stem}.configs")


def shear(
    packing: Packing,
    dgamma: float,
    gamma_max: float | None = None,
    *,
    n_steps: int | None = None,
    minimizer: str = "linear",
    ftol: float = 1e-12,
    classify: bool = True,
    params: AQSParameters | None = None,
    fire_params: FireParameters | None = None,
    save_every: int | None = None,
    out: str | Path | None = None,
    previous: Trace | None = None,
    source: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ShearResult:
    """AQS shear of ``packing`` in steps ``δγ`` up to ``γ_max`` (or for ``n_steps`` steps).

    Strains are ``γ_n = γ_0 + n δγ`` (no accumulated rounding), ``γ_0`` the strain of the input
    (or of row 0 of ``previous``). The input is first minimised with FIRE if its largest force is
    ``≥ ftol``. ``minimizer``: ``"linear"`` (linear response + chord Newton, FIRE fallback) or
    ``"fire"`` (plain FIRE every step; ``classify=False`` skips the continuation test and leaves
    ``plastic`` all False). See the module docstring for the elastic/plastic rule.

    ``out``: trace file to write (atomically) at the end and every ``save_every`` steps, together
    with the configuration (:func:`checkpoint_paths`). ``previous``: a trace to continue (resume);
    ``packing`` must then be the configuration at ``previous.gamma[-1]``.
    """
    if minimizer not in MINIMIZERS:
        raise ValueError(f"minimizer must be one of {MINIMIZERS}, got minimizer={minimizer!r}")
    if not (isinstance(ftol, int | float) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    if (gamma_max is None) == (n_steps is None):
        raise ValueError("give exactly one of gamma_max and n_steps")
    if n_steps is None:
        total = n_steps_for(dgamma, gamma_max)
    else:
        if not (isinstance(dgamma, int | float) and math.isfinite(dgamma) and dgamma > 0):
            raise ValueError(f"dgamma must be finite and > 0, got dgamma={dgamma!r}")
        if not (isinstance(n_steps, int) and n_steps >= 1):
            raise ValueError(f"n_steps must be an integer >= 1, got n_steps={n_steps!r}")
        total = n_steps
    if save_every is not None and not (isinstance(save_every, int) and save_every >= 1):
        raise ValueError(f"save_every must be an integer >= 1, got save_every={save_every!r}")
    if save_every is not None and out is None:
        raise ValueError("save_every needs an output path (out=...)")
    params = AQSParameters() if params is None else params
    fire_params = FireParameters() if fire_params is None else fire_params

    nl = NeighborList(packing)
    rows: dict[str, list] = {k: [] for k in _ROW_KEYS}
    if previous is None:
        gamma0 = packing.strain
        start_iterations = 0
        cur = packing
        row, backbone = _observe(cur, nl)
        if row["max_force"] >= ftol:
            res = minimize(cur, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            cur, start_iterations = res.packing, res.iterations
            row, backbone = _observe(cur, nl)
        _append(rows, cur.strain, row, start_iterations, False)
        first = 1
    else:
        gamma0 = float(previous.gamma[0])
        if not math.isclose(packing.strain, float(previous.gamma[-1]), rel_tol=0, abs_tol=1e-15):
            raise ValueError(
                f"configuration strain {packing.strain} does not match the trace's last strain "
                f"{previous.gamma[-1]}"
            )
        for k in _ROW_KEYS:
            rows[k] = list(getattr(previous, k))
        cur = packing
        _, backbone = _observe(cur, nl)
        first = previous.n_steps + 1
    if first > total:
        raise ValueError(f"nothing to do: the trace already has {first - 1} >= {total} steps")

    attrs = {
        "dgamma": float(dgamma),
        "gamma_max": float(gamma0 + total * dgamma),
        "n_steps": int(total),
        "ftol": float(ftol),
        "minimizer": minimizer,
        "N": int(packing.n),
        "dim": int(packing.dim),
        "phi": float(packing.phi),
        "box_length": float(packing.box.length),
        "seed": int(-1 if packing.seed is None else packing.seed),
        "jamlab_version": _version(),
        "source": "" if source is None else str(source),
    }
    counters = {
        "n_fallback": 0,
        "n_substepped": 0,
        "n_cleanup": 0,
        "n_factorisations": 1,
        "n_lean": 0,
    }
    fac = _factorise(cur, nl, backbone)
    age = 0
    predictor: np.ndarray | None = None
    path = _Path(params.path_depth, params.path_degree, params.path_floor)
    secants = _Secants(params.secant_depth) if params.secant_depth else None
    prev = {"gamma": rows["gamma"][-1], **{k: rows[k][-1] for k in _ROW_KEYS if k != "gamma"}}
    cur_keys = _contact_keys(cur, nl) if minimizer == "linear" else None
    flags, flags_build = (
        _consistent_flags(cur, nl, fac, params) if minimizer == "linear" else (None, -1)
    )
    t0 = time.perf_counter()
    for n in range(first, total + 1):
        target = gamma0 + n * dgamma
        affine = _affine_to(cur, target)
        iterations = 0
        plastic = False
        branch: _Branch | None = None
        observed: tuple[Packing, dict[str, float], np.ndarray] | None = None
        lean = lean_change = None
        if minimizer == "linear" and flags is not None and nl.n_builds != flags_build:
            flags, flags_build = _consistent_flags(cur, nl, fac, params)
        if fac.free.size == 0:
            # no rigid backbone (unjammed): E ≈ 0, nothing can jump; FIRE just removes overlaps
            res = minimize(affine, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            new, iterations = res.packing, res.iterations
        elif minimizer == "linear" and flags is not None and nl.n_builds == flags_build and (
            lean := _lean_step(
                cur, target, predictor, nl, fac, flags, prev, ftol, params, secants, affine
            )
        ):
            new, lean_row, iterations, lean_change = lean
            observed = (new, lean_row, backbone)
            counters["n_lean"] += 1
            if lean_change is not None:
                flags = lean_change[0]
        elif minimizer == "linear":
            branch = _continue(cur, fac, target, nl, ftol, params, predictor=predictor)
            if branch.packing is not None and branch.substeps == 1:
                # a contact opening or closing inside the step makes E(γ) a kink, not a parabola
                observed = (branch.packing, *_observe(branch.packing, nl))
                r = (
                    observed[1]["energy"]
                    - rows["energy"][-1]
                    - 0.5
                    * (target - rows["gamma"][-1])
                    * (rows["shear_stress"][-1] + observed[1]["shear_stress"])
                )
                if abs(r) > params.energy_tol * dgamma**2:
                    counters["n_factorisations"] += branch.refactorised
                    iterations += branch.iterations
                    branch = _continue(
                        cur, branch.factor, target, nl, ftol, params, first_substep=0.125
                    )
            iterations += branch.iterations
            counters["n_factorisations"] += branch.refactorised
            new = branch.packing
            if new is not None and branch.substeps > 1:
                counters["n_substepped"] += 1
            if new is None:
                counters["n_fallback"] += 1
                plastic = True
                res = minimize(affine, ftol, params.max_fire_iter, fire_params, neighbors=nl)
                new, iterations = res.packing, iterations + res.iterations
        else:
            res = minimize(affine, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            new, iterations = res.packing, res.iterations
            if classify:
                branch = _continue(cur, fac, target, nl, ftol, params)
                counters["n_factorisations"] += branch.refactorised
                continued = branch.packing
                if continued is not None and _observe(continued, nl)[0]["max_force"] >= ftol:
                    # the continuation holds rattlers where the affine step put them; relax
                    # them as the fast path does before recording, or their overlaps alone
                    # make the energies differ
                    continued = minimize(
                        continued, ftol, params.max_fire_iter, fire_params, neighbors=nl
                    ).packing
                plastic = continued is None or not _same_minimum(new, continued, nl, params)
        if observed is not None and observed[0] is new:
            row, backbone = observed[1], observed[2]
        else:
            row, backbone = _observe(new, nl)
        cleaned = False
        if row["max_force"] >= ftol:
            # Newton relaxed the backbone with rattlers held; let FIRE relax the rest
            counters["n_cleanup"] += 1
            cleaned = True
            res = minimize(new, ftol, params.max_fire_iter, fire_params, neighbors=nl)
            new, iterations = res.packing, iterations + res.iterations
            row, backbone = _observe(new, nl)
        _append(rows, target, row, iterations, plastic)
        predictor = None
        kinked = True
        old_keys = cur_keys
        if minimizer == "linear" and lean is None:
            # did a contact open or close in this step? then u(γ) has a kink inside it
            cur_keys = _contact_keys(new, nl)
            kinked = old_keys is None or not np.array_equal(cur_keys, old_keys)
        elif minimizer == "linear":
            kinked = lean_change is not None
            if kinked:
                cur_keys = lean_change[1]
        if minimizer == "linear" and not plastic and not cleaned:
            u = new.box.minimum_image(new.positions - affine.positions)
            path.add(u, row["max_force"], kinked)
            predictor = path.predict()
        else:
            path.reset()
        cur = new
        age += 1
        if branch is not None and branch.factor is not None and not plastic:
            if branch.refactorised:
                age = 0
            fac = branch.factor
        stale = (
            plastic
            or (cleaned and minimizer == "linear")
            or fac.lu is None
            or not np.array_equal(fac.backbone, backbone)
            or age >= params.refactor_every
            or (branch is not None and branch.cg_iterations > params.stale_cg)
        )
        if stale and n < total:  # (after the last step nothing would use it)
            # the previous preconditioner is useless after an avalanche, and the regular
            # refactorisation re-checks positive definiteness exactly (LDLᵀ pivots)
            fac = _factorise(cur, nl, backbone)
            counters["n_factorisations"] += 1
            age = 0
        prev = {"gamma": target, **row}
        if minimizer == "linear" and (lean is None or stale):
            # contacts of the new minimum, per neighbour-list slot, for the next lean step
            flags, flags_build = _consistent_flags(cur, nl, fac, params)
        if progress is not None:
            progress(n, total)
        if out is not None and save_every is not None and n % save_every == 0 and n < total:
            _save(out, rows, attrs, counters, cur, n, snapshot=True)
    elapsed = time.perf_counter() - t0
    trace = _make_trace(rows, attrs, counters)
    if out is not None:
        _save(out, rows, attrs, counters, cur, total, snapshot=save_every is not None)
    return ShearResult(
        trace=trace,
        packing=cur,
        n_fallback=counters["n_fallback"],
        n_substepped=counters["n_substepped"],
        n_cleanup=counters["n_cleanup"],
        n_not_converged=int(np.count_nonzero(trace.max_force >= ftol)),
        time=elapsed,
    )


# the columns measured at a minimum (the jumps are differences between rows)
_ROW_KEYS = tuple(c for c in TRACE_COLUMNS if c not in ("energy_jump", "stress_jump"))


def _append(rows: dict[str, list], gamma: float, row: dict, iterations: int, plastic: bool) -> None:
    rows["gamma"].append(float(gamma))
    for k in ("energy", "shear_stress", "pressure", "z", "z_nr", "max_force"):
        rows[k].append(row[k])
    rows["iterations"].append(int(iterations))
    rows["plastic"].append(bool(plastic))


def _make_trace(rows: dict[str, list], attrs: dict, counters: dict) -> Trace:
    trace = Trace.from_rows(rows, attrs=dict(attrs))
    trace.attrs.update(counters)
    trace.attrs["n_plastic"] = int(np.count_nonzero(trace.plastic))
    return trace


def _save(
    out: str | Path,
    rows: dict[str, list],
    attrs: dict,
    counters: dict,
    packing: Packing,
    step: int,
    snapshot: bool,
) -> None:
    from jamlab.spheres.io import write_packing

    last, snapshots = checkpoint_paths(out)
    if snapshot:
        snapshots.mkdir(exist_ok=True)
        write_packing(snapshots / f"step_{step:08d}.h5", packing, aqs_step=int(step))
    # configuration first: a trace never refers to a configuration that is not on disk
    write_packing(last, packing, aqs_step=int(step))
    write_trace(out, _make_trace(rows, attrs, counters))


def _version() -> str:
    from jamlab import __version__

    return str(__version__)
