"""Saddles: FIRE can stop on a saddle point of the energy (``max|F| < ftol`` with a negative
curvature direction), e.g. when the configuration and the affine step share a symmetry that
FIRE's dynamics preserves; :func:`descend` leaves it along the unstable mode and minimises again.

A saddle recorded as a minimum is a wrong result: it is not what AQS follows (the system would
leave it at the next perturbation), and the fast path, whose continuation starts by testing the
Hessian of the current minimum for positive definiteness, then declares the branch ended at every
step the lean step cannot take — the spurious plastic flags of issue 15 (docs/aqs.md).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from jamlab.spheres.aqs.linalg import Factor, backbone_matrix, factorise
from jamlab.spheres.aqs.record import observe
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.potential import NeighborList, Packing

# a Hessian eigenvalue below −NEGATIVE_CURVATURE · λ_max is a resolved unstable mode (a flat or
# floppy direction, |λ| at rounding level, is not: no displacement along it lowers the energy)
NEGATIVE_CURVATURE = 1e-8
# the push along the unstable mode: largest particle displacement, in units of the mean diameter
KICK = 1e-4
MAX_DESCENTS = 10
DENSE_LIMIT = 3000  # Hessians with more rows: the lowest eigenpair by Lanczos (scipy eigsh)


def lowest_mode(packing: Packing, nl: NeighborList, fac: Factor) -> tuple[float, float, np.ndarray]:
    """``(λ_min, λ_max, v)`` of the pinned backbone Hessian of ``packing`` (``fac``'s free set
    and order), ``v`` the eigenvector of ``λ_min`` as ``(n_free, d)``."""
    k = backbone_matrix(packing, nl, fac)
    d = packing.dim
    if k.shape[0] <= DENSE_LIMIT:
        w, v = np.linalg.eigh(k.toarray())
        return float(w[0]), float(w[-1]), v[:, 0].reshape(-1, d)
    lo, vlo = spla.eigsh(k, k=1, which="SA", tol=1e-8)
    hi = spla.eigsh(k, k=1, which="LA", tol=1e-3, return_eigenvectors=False)
    return float(lo[0]), float(hi[0]), vlo[:, 0].reshape(-1, d)


def descend(
    packing: Packing,
    row: dict[str, float],
    backbone: np.ndarray,
    nl: NeighborList,
    ftol: float,
    max_iter: int,
    fire_params: FireParameters,
) -> tuple[Packing, dict[str, float], np.ndarray, Factor, int, int]:
    """The minimum FIRE reaches from ``packing`` (``max|F| < ftol``, row ``row``, backbone
    ``backbone``) once any saddle is left.

    While the pinned backbone Hessian (:func:`~jamlab.spheres.aqs.linalg.factorise`, an exact
    inertia test) is not positive definite and its lowest eigenvalue is a resolved negative one
    (below ``−NEGATIVE_CURVATURE · λ_max``), the backbone particles are pushed along that mode
    (largest displacement ``KICK`` mean diameters; the sign making the largest component
    positive, so the result is deterministic) and FIRE minimises again (at most
    ``MAX_DESCENTS`` times). Returns ``(minimum, row, backbone, factor of the minimum, FIRE
    iterations, factorisations)``.
    """
    iterations = factorisations = 0
    for attempt in range(MAX_DESCENTS + 1):
        fac = factorise(packing, nl, backbone)
        factorisations += 1
        if fac.free.size == 0 or fac.positive_definite or attempt == MAX_DESCENTS:
            break
        lo, hi, v = lowest_mode(packing, nl, fac)
        if not lo < -NEGATIVE_CURVATURE * abs(hi):
            break  # positive semi-definite: a flat direction, not a saddle
        norms = np.sqrt(np.einsum("ij,ij->i", v, v))
        big = int(np.argmax(norms))
        sign = 1.0 if v[big, int(np.argmax(np.abs(v[big])))] > 0 else -1.0
        push = np.zeros_like(packing.positions)
        push[fac.free] = (sign * KICK * float(np.mean(packing.diameters)) / norms[big]) * v
        res = minimize(
            packing.with_positions(packing.positions + push),
            ftol,
            max_iter,
            fire_params,
            neighbors=nl,
        )
        packing = res.packing
        iterations += res.iterations
        row, backbone = observe(packing, nl)
    return packing, row, backbone, fac, iterations, factorisations
