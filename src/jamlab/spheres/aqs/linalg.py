"""Linear algebra on the backbone: the pinned backbone Hessian, METIS nested-dissection order,
its factorisation with a positive-definiteness test (CHOLMOD's supernodal Cholesky, SuperLU's
``LDLᵀ`` and its inertia where Cholesky fails), Woodbury (rank-one) corrections for contacts
that opened or closed, and preconditioned CG.

**Why CHOLMOD.** Every factor here is of a symmetric matrix, nearly always positive definite
(a minimum's Hessian; where it is not, SuperLU's ``LDLᵀ`` is made as before, for its inertia
and for the callers that use an indefinite factor). SuperLU factorises it as a general ``LU``
with panel updates; CHOLMOD's supernodal ``LLᵀ`` (SuiteSparse, through ``cvxopt``, one
thread) does half the arithmetic in dense blocks. Measured on the pinned backbone Hessians of
``jam(N, 3, seed, p = 1e-4)``, the same METIS order, CPU time, conversion and symbolic
analysis included (``benchmarks/bench_factorisation.py``, ``docs/aqs.md``): factorisation
3.1–3.4× (N = 1000), 4.4× (2000) and 5.4× (4000) faster, a solve 2.5×, 4.1× and 2.1× (at
φ = 0.8, N = 1000: 3.5–5.3× and 4.1×); the solutions agree to ~1e-12 relative.
``FACTORISATION = "superlu"`` restores the factor used before (for comparisons; the results
differ at rounding level: the factor only preconditions).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pymetis
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from jamlab.spheres import kernels as AK
from jamlab.spheres.aqs.network import contact_list, pair_keys
from jamlab.spheres.blas import import_cvxopt
from jamlab.spheres.pair import pair_sigmas
from jamlab.spheres.potential import NeighborList, Packing

cvxopt = import_cvxopt()  # with CHOLMOD, on the BLAS kernels of this CPU (spheres.blas)


@dataclass(eq=False)
class Factor:
    """Factorised pinned backbone Hessian ``M = K(x₀)`` at one configuration ``x₀``, and the
    low-rank corrections for the contacts that opened or closed since (:meth:`update`).

    A contact that closes adds ``(2/σ²) n nᵀ`` to the pair block of ``K`` (its tangential part
    ``(V'/r)(1 − n nᵀ)`` vanishes at ``r = σ``), one that opens removes it. With ``U`` the
    columns ``b_c`` (``+n`` on particle ``i``, ``−n`` on ``j``, held particles left out) and
    ``S = diag(±2/σ_ij²)`` (harmonic law; no corrections for ``α ≠ 2``), the preconditioner is
    ``P = M + U S Uᵀ`` and (Woodbury)
    ``P⁻¹ = M⁻¹ − W C⁻¹ Wᵀ``, ``W = M⁻¹U``, ``C = S⁻¹ + UᵀW``; each new column of ``W`` costs
    one triangular solve, cached per contact. ``P`` is positive definite iff the number of
    positive eigenvalues of ``C`` equals the number of closed contacts (Haynsworth inertia
    additivity on ``[[M, U], [Uᵀ, −S⁻¹]]``, ``M`` positive definite;
    :func:`capacitance_keeps_pd`): an exact test of the corrected matrix; where it fails the
    corrections are dropped and ``M`` alone preconditions (the iteration's own tests and a fresh
    factorisation then decide).
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
    kernel_law: tuple = (None, None)  # the same in the kernels' form (pair.kernel_law)

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
        # S⁻¹ = diag(±1/V''(σ⁻)), V''(σ⁻) = 2/σ_ij² for the harmonic law
        pairs = np.abs(signed) - 1
        sig = pair_sigmas(self.diameters, pairs // n, pairs % n)
        c = np.diag(np.where(signed > 0, 1.0, -1.0) * (0.5 * sig * sig))
        for a in range(signed.size):
            c[a, :] += vals[a] @ w[idxs[a], :]
        c = 0.5 * (c + c.T)
        self.corrected_pd = capacitance_keeps_pd(c, int(np.count_nonzero(signed > 0)))
        if self.corrected_pd:
            self.w, self.c_inv = w, np.linalg.inv(c)


# smallest |λ| / max |λ| of a capacitance matrix counted as nonzero (capacitance_keeps_pd)
INERTIA_CUTOFF = 1e-10


def capacitance_keeps_pd(c: np.ndarray, n_added: int) -> bool:
    """Whether ``K + U S Uᵀ`` is positive definite, given ``K`` positive definite and the
    capacitance matrix ``C = S⁻¹ + Uᵀ K⁻¹ U`` (``S`` diagonal, ``n_added`` positive entries).

    Haynsworth inertia additivity on ``[[K, U], [Uᵀ, −S⁻¹]]``: the corrected matrix is positive
    definite iff ``C`` has exactly ``n_added`` positive eigenvalues and none zero. An
    eigenvalue with ``|λ| ≤ INERTIA_CUTOFF · max |λ|`` counts as zero (its sign is not
    resolved: the columns of ``K⁻¹ U`` are computed to a relative residual of ~1e-12, by PCG
    in the contact-switch test), so the answer is then "not positive definite".
    """
    eig = np.linalg.eigvalsh(0.5 * (c + c.T))
    return bool(
        np.count_nonzero(eig > 0) == n_added
        and np.min(np.abs(eig)) > INERTIA_CUTOFF * np.max(np.abs(eig))
    )


def free_set(backbone: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    idx = np.flatnonzero(backbone)
    free = idx[1:]  # pin the first backbone particle: removes the d global translations
    free_index = np.full(backbone.shape[0], -1, dtype=np.int64)
    free_index[free] = np.arange(free.size)
    return free, free_index


def hessian_matrix(ci: np.ndarray, cj: np.ndarray, dr: np.ndarray, fac: Factor) -> sps.csr_matrix:
    """The pinned backbone Hessian ``K`` (CSR, rows in ``fac``'s order of the free particles) of
    the pairs ``(ci, cj)`` with separations ``dr``: pair block ``V'' n nᵀ + (V'(r)/r)(1 − n nᵀ)``
    of the pair law (:mod:`jamlab.spheres.pair`), a held particle (pinned, rattler) a fixed spring
    end."""
    data, indices, indptr = AK.backbone_hessian_csr(
        ci, cj, dr, *fac.kernel_law, fac.free_index, fac.free.size
    )
    size = fac.free.size * dr.shape[1]
    return sps.csr_matrix((data, indices, indptr), shape=(size, size))


def backbone_matrix(
    packing: Packing, nl: NeighborList, fac: Factor, contacts: tuple | None = None
) -> sps.csr_matrix:
    """:func:`hessian_matrix` of the contacts of ``packing`` (or of ``contacts``)."""
    ci, cj, cd = contact_list(packing, nl) if contacts is None else contacts
    return hessian_matrix(ci, cj, cd, fac)


ND_MIN_FREE = 400  # fewer free particles: the factorisation's own order (as fast there)


def nested_dissection(free: np.ndarray, ci: np.ndarray, cj: np.ndarray, n: int) -> np.ndarray:
    """The free particles reordered by METIS nested dissection of their contact graph
    (``pymetis``; deterministic). On this graph it leaves ~20 % less fill in the factor than
    SuperLU's minimum-degree orderings and factorises ~1.6× faster (docs/aqs.md)."""
    if free.size < ND_MIN_FREE:
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


def factorise(
    packing: Packing, nl: NeighborList, backbone: np.ndarray, contacts: tuple | None = None,
    positive_only: bool = False,
) -> Factor:
    """Factorise the backbone Hessian with one particle pinned; test positive definiteness.

    The free particles are numbered in a nested-dissection order of their contact graph
    (:func:`nested_dissection`), so ``K`` is assembled already permuted and factorised in its
    natural order (:func:`factor_matrix`): CHOLMOD's Cholesky, which succeeds exactly where
    ``K`` is positive definite; where it does not, SuperLU's ``LDLᵀ`` (:func:`ldlt`: its
    inertia, and a factor for the callers that use an indefinite one; ``positive_only``: no
    factor there, ``lu`` None).
    """
    free, free_index = free_set(backbone)
    fac = Factor(backbone, free, free_index, None, False)
    fac.diameters, fac.alpha = packing.diameters, packing.alpha
    fac.kernel_law = packing.kernel_law
    if free.size == 0:
        return fac
    ci, cj, cd = contact_list(packing, nl) if contacts is None else contacts
    fac.free = nested_dissection(free, ci, cj, packing.n)
    fac.free_index[fac.free] = np.arange(fac.free.size)
    k = backbone_matrix(packing, nl, fac, (ci, cj, cd))
    keys = pair_keys(ci, cj, packing.n)  # ci > cj after a re-sort
    order = np.argsort(keys)
    fac.keys0 = keys[order]
    fac.row0 = np.searchsorted(fac.keys0, np.arange(packing.n + 1) * packing.n)
    fac.normals0 = cd[order]
    # K is symmetric, so its CSR arrays read as CSC are K itself: no conversion
    kc = sps.csc_matrix((k.data, k.indices, k.indptr), shape=k.shape)
    fac.lu, fac.positive_definite = factor_matrix(kc, fac.free.size >= ND_MIN_FREE, positive_only)
    return fac


FACTORISATIONS: tuple[str, ...] = ("cholmod", "superlu")
FACTORISATION: str = "cholmod"
"""The factorisation :func:`factorise` uses (module docstring): ``cholmod`` (CHOLMOD's
supernodal Cholesky; SuperLU ``LDLᵀ`` where the matrix is not positive definite) or
``superlu`` (SuperLU ``LDLᵀ`` every time, the factor before)."""


class Cholesky:
    """CHOLMOD's ``K = L Lᵀ`` of a positive definite matrix (:func:`cholesky`); :meth:`solve`
    as SuperLU's factor has it."""

    __slots__ = ("_factor",)

    def __init__(self, factor) -> None:
        self._factor = factor

    def solve(self, r: np.ndarray) -> np.ndarray:
        """``K⁻¹ r`` for a vector or the columns of a matrix ``r`` (a new array)."""
        x = cvxopt.matrix(np.asarray(r, dtype=np.float64))
        cvxopt.cholmod.solve(self._factor, x)
        return np.array(x).reshape(r.shape)


def cholesky(k: sps.csc_matrix, natural: bool = True) -> Cholesky | None:
    """CHOLMOD's supernodal ``K = L Lᵀ`` of a symmetric matrix (its lower triangle read), or
    ``None`` where ``K`` is not positive definite (a pivot ≤ 0). ``natural``: ``K`` is already in
    a fill-reducing order (nested dissection); otherwise CHOLMOD's own (AMD)."""
    low = sps.tril(k, format="coo")
    n = k.shape[0]
    a = cvxopt.spmatrix(cvxopt.matrix(low.data), cvxopt.matrix(low.row.astype(np.int64)),
                        cvxopt.matrix(low.col.astype(np.int64)), (n, n))
    cvxopt.cholmod.options["supernodal"] = 2
    order = cvxopt.matrix(np.arange(n, dtype=np.int64)) if natural else None
    symbolic = (cvxopt.cholmod.symbolic(a, p=order) if natural
                else cvxopt.cholmod.symbolic(a))
    try:
        cvxopt.cholmod.numeric(a, symbolic)
    except ArithmeticError:  # a pivot <= 0: not positive definite
        return None
    return Cholesky(symbolic)


def factor_matrix(k: sps.csc_matrix, natural: bool = True,
                  positive_only: bool = False) -> tuple[object | None, bool]:
    """The factor of :data:`FACTORISATION` and whether ``K`` is positive definite: CHOLMOD's
    Cholesky, or — where it fails, and with ``FACTORISATION = "superlu"`` — :func:`ldlt`.
    ``positive_only``: the caller uses only a positive definite factor, so where Cholesky
    fails ``(None, False)`` without the ``LDLᵀ``."""
    if FACTORISATION not in FACTORISATIONS:
        raise ValueError(f"FACTORISATION must be one of {', '.join(FACTORISATIONS)}, "
                         f"got {FACTORISATION!r}")
    if FACTORISATION == "cholmod" and k.shape[0] > 0:
        chol = cholesky(k, natural)
        if chol is not None:
            return chol, True
        if positive_only:
            return None, False
    return ldlt(k, natural)


def ldlt(k: sps.csc_matrix, natural: bool = True) -> tuple[object | None, bool]:
    """SuperLU ``K = L D Lᵀ`` of a symmetric matrix and whether ``K`` is positive definite.

    ``natural``: ``K`` is already in a fill-reducing order (nested dissection); otherwise
    SuperLU's ``MMD_AT_PLUS_A``. With ``diag_pivot_thresh=0`` no rows are pivoted, ``U = D Lᵀ``,
    and the inertia of ``K`` is the signs of ``diag(U)`` (Sylvester). Any row pivoting
    (``perm_r ≠ perm_c``) or a zero pivot counts as "not positive definite"; an exactly singular
    matrix gives ``(None, False)``.
    """
    try:
        lu = spla.splu(
            k,
            permc_spec="NATURAL" if natural else "MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError:  # exactly singular
        return None, False
    return lu, bool(np.array_equal(lu.perm_r, lu.perm_c) and np.all(lu.U.diagonal() > 0))


def max_norm(f: np.ndarray) -> float:
    return float(np.sqrt(np.max(np.einsum("ij,ij->i", f, f)))) if f.size else 0.0


def pcg(
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
        if max_norm(r.reshape(-1, d)) < atol:
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
