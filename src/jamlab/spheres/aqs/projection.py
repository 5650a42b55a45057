"""Floppy steps by projection: the overlap-free configuration nearest to the affine start.

A step that starts from an unjammed minimum (``E ≈ 0``, no state of self-stress) ends, if it stays
floppy, in *some* configuration without overlaps: every such configuration is a minimum
(``E = 0``, every force zero). Which one is a property of the protocol, not of the landscape.
FIRE picks the end of its damped dynamics; near jamming it approaches it slowly (a hovering
sample spends 20–40 thousand iterations per step sliding the last ``1e-8 → 1e-12`` of force along
nearly flat directions, ``docs/aqs.md``). This module picks instead the overlap-free
configuration nearest to the affine start ``x₀`` (hard-sphere quasi-static shear, minimal
displacement):

    minimise ½ |x − x₀|²   subject to   g_c(x) = r_c(x) − σ_c ≥ 0   for every pair c.

Both ends have the same form: to first order in the displacement, FIRE's is ``x − x₀ = Gᵀ Λ``
with ``Λ_c ≥ 0`` the accumulated repulsive contact impulses (its velocity is a positive mixture
of past forces), the projection's ``x − x₀ = Gᵀ λ``, ``λ ≥ 0``, with complementarity
``λ_c g_c = 0``; they differ only by contacts that push for a while and then open, so the two
minima are close (measured in ``docs/aqs.md``), but not equal: the choice is a protocol choice,
selectable
(:class:`~jamlab.spheres.aqs.parameters.AQSParameters` ``floppy``).

**Method.** Sequential convex programming. Linearise the gaps at ``x_k`` (``g + G d``,
``G_c = ∂r_c/∂x``: ``+n_c`` on ``i``, ``−n_c`` on ``j``); since ``r_c`` is convex in ``x``,
``g_c(x) ≥ g_c(x_k) + G_c (x − x_k)``, so every solution of the linearised problem is free of
overlaps (an inner approximation: each iterate is feasible and ``|x_k − x₀|`` cannot grow). The
linearised problem is a projection onto a polyhedron; its dual is the linear complementarity
problem

    w = q + M λ ≥ 0,   λ ≥ 0,   wᵀλ = 0,    M = G Gᵀ,   q = g(x_k) − G (x_k − x₀),

``x = x₀ + Gᵀ λ``, solved by the primal–dual active set iteration (semismooth Newton): ``λ_A`` from
``M_AA λ_A = −q_A`` (CHOLMOD), ``A ← {c : λ_c − w_c > 0}``, until ``A`` repeats. ``M_AA`` is
positive definite when the active contacts carry no state of self-stress — the floppy case; where
a factorisation fails, the active set does not settle within ``max_active`` iterations, or the
linearisations do not settle within ``max_sqp``, there is no nearby floppy end (the step jams,
or the active set cycles) and :func:`project` says so: the caller takes the step as before.
Candidate pairs are those of the neighbour list (all pairs within ``σ_max + skin``); the result
is checked against the full list: no pair overlaps by more than ``overlap_tol``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from jamlab.spheres.aqs.linalg import cholesky, pcg
from jamlab.spheres.neighbors import list_positions
from jamlab.spheres.pair import pair_sigmas
from jamlab.spheres.potential import NeighborList, Packing

__all__ = ["Projection", "project", "candidate_pairs"]

CG_ATOL = 1e-16  # largest residual of the active gaps (length units) for a CG solution
CG_MAXITER = 20
TOUCH_GAP = 1e-9  # pairs of the parent this close start the active set


@dataclass(frozen=True, eq=False)
class Projection:
    """Outcome of :func:`project`: the overlap-free configuration (``None`` if not found), the
    number of linearisations ``sqp`` and of factorisations ``solves``, the multipliers
    ``lam`` of the pairs ``(pi, pj)`` at the end (``λ_c > 0``: the pair touches and pushes) and
    ``reason`` (empty when found)."""

    packing: Packing | None
    sqp: int
    solves: int
    pi: np.ndarray
    pj: np.ndarray
    lam: np.ndarray
    reason: str = ""

    def __bool__(self) -> bool:
        return self.packing is not None


MAX_PAIR_ROUNDS = 8
"""How many times :func:`project` solves again with the pairs its end overlapped that were not
candidates."""


def candidate_pairs(packing: Packing, nl: NeighborList) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of the neighbour list (original numbering, ``i < j`` not implied): the pairs
    within ``σ_max + skin`` at its build, which contain every pair that can touch while the list
    is valid."""
    _, nl = list_positions(packing, nl)
    counts = np.diff(nl.start)
    i = np.repeat(np.arange(counts.size), counts)
    return nl.order[i], nl.order[np.asarray(nl.nbr[: nl.start[-1]])]


def _gaps(x: np.ndarray, packing: Packing, pi, pj, sigma):
    dr = packing.box.minimum_image(x[pi] - x[pj])
    r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
    return r - sigma, dr / r[:, None]


def _jacobian(pi, pj, u, n, d) -> sps.csr_matrix:
    m = pi.size
    rows = np.repeat(np.arange(m), 2 * d)
    cols = np.concatenate([pi[:, None] * d + np.arange(d), pj[:, None] * d + np.arange(d)], 1)
    return sps.csr_matrix((np.concatenate([u, -u], 1).ravel(), (rows, cols.ravel())),
                          shape=(m, n * d))


def _anderson(xs: list[np.ndarray], fs: list[np.ndarray], m: int) -> np.ndarray:
    """The Anderson-mixed next point of the fixed point ``x ← x + f`` from the last ``m + 1``
    points ``xs`` and residuals ``fs`` (type II: ``x + f − (ΔX + ΔF) γ``, ``γ`` the least-squares
    solution of ``ΔF γ ≈ f``); the plain step ``x + f`` with one point. Trims both lists to
    those last ``m + 1`` entries."""
    del xs[: -(m + 1)], fs[: -(m + 1)]
    x, f = xs[-1], fs[-1]
    if len(xs) < 2:
        return x + f
    dx = np.diff(np.array(xs), axis=0).T
    df = np.diff(np.array(fs), axis=0).T
    gamma = np.linalg.lstsq(df, f, rcond=None)[0]
    return x + f - (dx + df) @ gamma


def project(
    affine: Packing,
    nl: NeighborList,
    parent: Packing | None = None,
    max_sqp: int = 40,
    max_active: int = 40,
    anderson: int = 4,
    start: Packing | None = None,
    xtol: float = 1e-10,
    overlap_tol: float = 1e-14,
    pairs: tuple[np.ndarray, np.ndarray] | None = None,
) -> Projection:
    """The overlap-free configuration nearest to ``affine`` (module docstring), or why not.

    ``parent``: the minimum ``affine`` was sheared from; its pairs closer than
    :data:`TOUCH_GAP` (touching) start the active set, else the pairs overlapping at
    ``affine``. (A guess only: each linearised problem is a projection onto a convex set, with
    one solution, so the end depends on the guess at rounding level only; and the guess comes
    from the configuration alone, so a resumed run repeats it.)
    Stops when a linearisation moves no particle by more than ``xtol``; the end must have no
    overlap above ``overlap_tol`` among the neighbour list's pairs. A linearisation whose
    active set is the previous one's is solved by conjugate gradients preconditioned with the
    previous factor (a nearby ``M_AA``), refactorised only where that does not converge.

    Once the touching pairs have settled, the linearisations converge linearly (each takes
    ``x`` to ``T(x)``, the projection onto the gaps linearised at ``x``; measured ratio ≈ 0.5
    near jamming, where the touching network is nearly isostatic and the gaps' curvature
    matters on its soft modes). ``anderson`` > 0 accelerates this fixed point by Anderson
    mixing of the last ``anderson`` residuals ``T(x) − x`` of one active set (reset when it
    changes): the next linearisation point only, so every iterate ``T(x)`` stays an inner
    approximation (free of overlaps) and the end is the same fixed point; ``0`` is the plain
    iteration.

    ``start``: where the gaps are first linearised (default ``affine`` itself). Any point will
    do — each iterate is the projection of ``affine`` onto gaps linearised somewhere — and where
    the linearisation at ``affine`` has no solution (a chain of contacts under self-stress that
    opens only at second order, by bending) one nearer the end can have one (measured with
    FIRE's loose minimum as ``start`` in ``docs/aqs.md``; the stepper does not use it: it did not
    pay on whole samples).

    ``pairs``: the candidate pairs (default :func:`candidate_pairs` of ``affine``). With the
    default, where the end overlaps pairs that were not candidates (the projection moved
    particles beyond the list's skin: a large step, or a thin skin), it is solved again with
    those pairs added, at most :data:`MAX_PAIR_ROUNDS` times.
    """
    n = affine.positions.shape[0]
    pi, pj = candidate_pairs(affine, nl) if pairs is None else pairs
    auto = pairs is None
    solves = 0
    for rounds in range(MAX_PAIR_ROUNDS + 1):
        x, k, used, lam, why = _solve(affine, pi, pj, parent, start, max_sqp, max_active,
                                      anderson, xtol)
        solves += used
        if why:
            return Projection(None, k, solves, pi, pj, lam, why)
        out = affine.with_positions(x)
        ci, cj = candidate_pairs(out, nl)  # the list at the end (it may have been rebuilt)
        g, _ = _gaps(x, out, ci, cj, pair_sigmas(out.diameters, ci, cj))
        if not g.size or g.min() >= -overlap_tol:
            return Projection(out, k, solves, pi, pj, lam)
        over = g < -overlap_tol
        known = np.unique(np.minimum(pi, pj) * n + np.maximum(pi, pj))
        keys = np.unique(np.minimum(ci[over], cj[over]) * n + np.maximum(ci[over], cj[over]))
        missed = keys[~np.isin(keys, known)]
        if not (auto and missed.size and rounds < MAX_PAIR_ROUNDS):
            return Projection(None, k, solves, pi, pj, lam,
                              f"an overlap of {-g.min():.2e} remains")
        # pairs that were no candidates (the projection moved particles beyond the list's
        # skin): solved again with them added
        pi, pj = np.concatenate([pi, missed // n]), np.concatenate([pj, missed % n])
    raise AssertionError("unreachable: the last round returns")


def _solve(affine: Packing, pi, pj, parent, start, max_sqp, max_active, anderson, xtol):
    """One projection with the candidate pairs ``(pi, pj)`` (the SQP of :func:`project`):
    ``(x, linearisations, factorisations, λ, reason)``, ``reason`` empty when it settled."""
    n, d = affine.positions.shape
    solves = 0
    sigma = pair_sigmas(affine.diameters, pi, pj)
    x0 = np.array(affine.positions)
    x = x0.copy() if start is None else np.array(start.positions)
    lam = np.zeros(pi.size)
    cached: tuple[np.ndarray, object] | None = None  # (active indices, their factor)

    hist_x: list[np.ndarray] = []  # accelerated linearisation points (one active set)
    hist_f: list[np.ndarray] = []  # their residuals T(x) − x
    last_active: np.ndarray | None = None
    for k in range(1, max_sqp + 1):
        g, u = _gaps(x, affine, pi, pj, sigma)
        jac = _jacobian(pi, pj, u, n, d)
        q = g - jac @ (x - x0).ravel()
        m = (jac @ jac.T).tocsr()
        if k > 1:
            a = lam > 0.0  # the last linearisation's touching pairs
        elif parent is not None:
            a = _gaps(parent.positions, parent, pi, pj, sigma)[0] < TOUCH_GAP
        else:
            a = q < 0.0
        for _ in range(max_active):
            idx = np.flatnonzero(a)
            lam = np.zeros(pi.size)
            if idx.size:
                m_aa = m[idx][:, idx]
                sol = None
                if cached is not None and np.array_equal(cached[0], idx):
                    sol, ok, _ = pcg(m_aa, -q[idx], cached[1].solve, CG_ATOL, CG_MAXITER, 1)
                    sol = sol if ok else None
                if sol is None:
                    fac = cholesky(m_aa.tocsc(), natural=False)
                    solves += 1
                    if fac is None:
                        return x, k, solves, lam, "a state of self-stress among the touching pairs"
                    cached = (idx, fac)
                    sol = fac.solve(-q[idx])
                lam[idx] = sol
            w = q + m @ lam
            new = (lam - w) > 0.0
            if np.array_equal(new, a):
                break
            a = new
        else:
            return (x, k, solves, lam,
                    f"the touching pairs did not settle in {max_active} iterations")
        x_new = x0 + (jac.T @ lam).reshape(n, d)
        moved = float(np.abs(x_new - x).max())
        if moved < xtol:
            return x_new, k, solves, lam, ""
        active = lam > 0.0
        if last_active is None or not np.array_equal(active, last_active):
            hist_x, hist_f = [], []
        last_active = active
        hist_x.append(x.ravel())
        hist_f.append((x_new - x).ravel())
        x = _anderson(hist_x, hist_f, anderson).reshape(n, d) if anderson else x_new
    return x, max_sqp, solves, lam, f"the linearisations did not settle in {max_sqp}"
