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
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from jamlab.spheres.aqs.linalg import Factor, backbone_matrix, factorise, ldlt
from jamlab.spheres.aqs.record import observe
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.potential import NeighborList, Packing, energy

# a Hessian eigenvalue below −NEGATIVE_CURVATURE · λ_max is a resolved unstable mode (a flat or
# floppy direction, |λ| at rounding level, is not: no displacement along it lowers the energy)
NEGATIVE_CURVATURE = 1e-8
# the push along the unstable mode: largest particle displacement, in units of the mean diameter
KICK = 1e-4
MAX_DESCENTS = 10
# Hessians with more rows take the sparse route of :func:`unstable_mode` (measured, docs/aqs.md
# "Saddles": dense ``eigh`` 0.05 s at 738 rows, 0.3 s at 1473, 2.4 s at 2934; the sparse route
# 0.01-0.02 s on a positive definite K and 0.22 s on the N = 1000 saddle at 2934 rows)
DENSE_LIMIT = 1000
INVERSE_ITERATIONS = 200  # at most, for the unstable mode of a large Hessian


def _shifted_ldlt(k: sps.csr_matrix, shift: float):
    """:func:`~jamlab.spheres.aqs.linalg.ldlt` of ``K + shift·I`` (natural order: ``K`` is
    assembled in its nested-dissection order, and the sparse route has more free particles than
    ``ND_MIN_FREE``)."""
    return ldlt((k + shift * sps.identity(k.shape[0], format="csr")).tocsc())


def unstable_mode(k: sps.csr_matrix, d: int) -> np.ndarray | None:
    """A direction of resolved negative curvature of the pinned backbone Hessian ``k`` (rows of
    ``d`` coordinates per free particle), as ``(n_free, d)``, or ``None`` if every eigenvalue is
    above ``−NEGATIVE_CURVATURE · λ_max``.

    Up to ``DENSE_LIMIT`` rows: the eigenvector of the lowest eigenvalue, dense. Above: no
    Lanczos on the low end of the spectrum — near jamming it is a cluster of eigenvalues within
    ~1e-9 of zero (prestress on floppy-like modes; measured at N = 2000, φ_J, 19 of them between
    −1.1e-9 and −0.9e-9, λ_max = 12.5), where ARPACK's ``which="SA"`` did not converge in 59,000
    iterations and stopped the run. Instead: ``λ_max`` by Lanczos (the top of the spectrum is
    well separated), then the exact inertia test on ``K + εI``, ``ε = NEGATIVE_CURVATURE ·
    λ_max``: positive definite means no eigenvalue below ``−ε`` (``None``, the rule of the dense
    route). Otherwise the shift ``s = ε 4^j`` is raised until ``K + sI`` is positive definite
    (so ``−s < λ_min ≤ −s/4``) and inverse iteration with that factor converges to the lowest
    eigenvector (the nearest eigenvalue to ``−s``; deterministic start, until the Rayleigh
    quotient settles to 1e-10 relative, at most ``INVERSE_ITERATIONS``)."""
    if k.shape[0] <= DENSE_LIMIT:
        w, v = np.linalg.eigh(k.toarray())
        if not w[0] < -NEGATIVE_CURVATURE * abs(w[-1]):
            return None
        return v[:, 0].reshape(-1, d)
    # ARPACK's own start vector is random (LAPACK's generator, whose state advances with every
    # call): λ_max to tol 1e-3 then differed between runs, and so did ε, the shifts and the
    # push — a run was not reproducible bit for bit once a minimum needed this test; the
    # inverse iteration below starts from the same vector
    start = np.random.default_rng(0).standard_normal(k.shape[0])
    hi = float(
        spla.eigsh(k, k=1, which="LA", tol=1e-3, v0=start, return_eigenvectors=False)[0]
    )
    eps = NEGATIVE_CURVATURE * abs(hi)
    _, pd = _shifted_ldlt(k, eps)
    if pd:
        return None
    shift, lu = eps, None
    while shift < 4.0 * abs(hi):
        shift *= 4.0
        lu, pd = _shifted_ldlt(k, shift)
        if pd:
            break
    if lu is None or not pd:
        return None  # (not reached: K + 4 λ_max I is positive definite)
    x = start / np.linalg.norm(start)  # the Lanczos start (eigsh copies it): deterministic
    rayleigh = float(x @ (k @ x))
    for _ in range(INVERSE_ITERATIONS):
        x = lu.solve(x)
        x /= np.linalg.norm(x)
        new = float(x @ (k @ x))
        settled = abs(new - rayleigh) <= 1e-10 * abs(new)
        rayleigh = new
        if settled:
            break
    if not rayleigh < -eps:
        return None  # (a direction that does not lower the energy is no push)
    return x.reshape(-1, d)


def saddle_push(
    packing: Packing, nl: NeighborList, backbone: np.ndarray, test: bool = True,
    downhill: bool = False,
) -> tuple[np.ndarray | None, Factor]:
    """The push off a saddle: factorise the pinned backbone Hessian of ``packing`` (an exact
    inertia test, :func:`~jamlab.spheres.aqs.linalg.factorise`); if it is not positive definite
    and its lowest eigenvalue is a resolved negative one (:func:`unstable_mode`), the
    displacement of every particle along that mode (backbone particles only; largest
    displacement ``KICK`` mean diameters, the sign making the largest component positive, so the
    result is deterministic), else ``None`` (a minimum, or a flat direction). Returns ``(push,
    factor)``; with ``test=False`` only the factor (the push is ``None``). ``downhill``: the
    sign instead the one of lower energy at the pushed point (a saddle next to a contact at
    touching rises at once on one side, where the minimum reached lies no lower than the saddle;
    measured at fixed pressure, ``docs/aqs.md``)."""
    fac = factorise(packing, nl, backbone)
    if fac.free.size == 0 or fac.positive_definite or not test:
        return None, fac
    v = unstable_mode(backbone_matrix(packing, nl, fac), packing.dim)
    if v is None:
        return None, fac  # positive semi-definite: a flat direction, not a saddle
    norms = np.sqrt(np.einsum("ij,ij->i", v, v))
    big = int(np.argmax(norms))
    sign = 1.0 if v[big, int(np.argmax(np.abs(v[big])))] > 0 else -1.0
    push = np.zeros_like(packing.positions)
    push[fac.free] = (sign * KICK * float(np.mean(packing.diameters)) / norms[big]) * v
    if downhill and (energy(packing.with_positions(packing.positions - push), nl)
                     < energy(packing.with_positions(packing.positions + push), nl)):
        push = -push
    return push, fac


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
    (:func:`saddle_push`) and FIRE minimises again (at most ``MAX_DESCENTS`` times). Returns
    ``(minimum, row, backbone, factor of the minimum, FIRE iterations, factorisations)``.
    """
    iterations = factorisations = 0
    for attempt in range(MAX_DESCENTS + 1):
        push, fac = saddle_push(packing, nl, backbone, test=attempt < MAX_DESCENTS)
        factorisations += 1
        if push is None:
            break
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
