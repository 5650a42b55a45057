"""The unstable-mode test of :mod:`jamlab.spheres.aqs.saddle` on matrices whose spectrum is known
independently (LAPACK's tridiagonal eigensolvers for the tridiagonal ones, dense ``eigh``
otherwise), on the sparse route (more than ``DENSE_LIMIT`` rows) and the dense one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.linalg import eigh_tridiagonal

from jamlab.spheres.aqs.saddle import DENSE_LIMIT, NEGATIVE_CURVATURE, unstable_mode

N_ROWS = 3 * 1101  # above DENSE_LIMIT: the sparse route


def laplacian(n: int) -> sps.csr_matrix:
    """``tridiag(−1, 2, −1)``: eigenvalues ``2 − 2 cos(jπ/(n+1))``, dense near 0 (gaps
    ~ 3 (π/n)², 2.7e-6 here) like the low end of a Hessian near jamming."""
    return sps.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")


def lowest_of_laplacian(n: int) -> float:
    return 2.0 - 2.0 * np.cos(np.pi / (n + 1))


def tridiagonal_eigen(k: sps.csr_matrix, index: int, vectors: bool = False):
    """Eigenvalue (and vector) ``index`` of a symmetric tridiagonal ``k``, by LAPACK's
    tridiagonal solver (no dense matrix: a dense ``eigh`` of 3303 rows took 6–19 s)."""
    n = k.shape[0]
    assert sps.triu(k, 2).nnz == 0 and sps.tril(k, -2).nnz == 0
    out = eigh_tridiagonal(k.diagonal(), k.diagonal(1), eigvals_only=not vectors,
                           select="i", select_range=(index % n, index % n))
    return (out[0][0], out[1][:, 0]) if vectors else out[0]


def test_the_sizes_take_the_sparse_route():
    assert N_ROWS > DENSE_LIMIT


@pytest.mark.parametrize("below", [1e-9, 1e-8])
def test_a_cluster_just_below_zero_is_flat_not_a_saddle(below):
    """λ_min = −1e-9 or −1e-8 with λ_max ≈ 4: above −NEGATIVE_CURVATURE·λ_max = −4e-8, so no
    push (the dense rule's verdict); this is the spectrum on which ARPACK's ``SA`` stalled."""
    k = laplacian(N_ROWS) - (lowest_of_laplacian(N_ROWS) + below) * sps.identity(N_ROWS)
    k = k.tocsr()
    w_min, w_max = tridiagonal_eigen(k, 0), tridiagonal_eigen(k, -1)
    assert w_min == pytest.approx(-below, rel=1e-4, abs=1e-12)
    assert not w_min < -NEGATIVE_CURVATURE * abs(w_max)  # the dense rule: flat
    assert unstable_mode(k, 3) is None


def test_a_resolved_negative_mode_is_found_on_the_sparse_route():
    """One strongly negative diagonal entry: a localized eigenvector with eigenvalue ≈ −1.6, far
    below the continuum [0, 4]; the direction returned is that eigenvector (sign free)."""
    k = laplacian(N_ROWS).tolil()
    k[1700, 1700] -= 3.0
    k = k.tocsr()
    w0, v0 = tridiagonal_eigen(k, 0, vectors=True)
    assert w0 < -1.0 and tridiagonal_eigen(k, 1) > 0.0
    x = unstable_mode(k, 3)
    assert x is not None and x.shape == (N_ROWS // 3, 3)
    x = x.ravel()
    assert abs(x @ v0) == pytest.approx(1.0, abs=1e-8)
    assert x @ (k @ x) == pytest.approx(w0, rel=1e-10)


def test_a_weakly_resolved_mode_in_the_continuum_lowers_the_energy():
    """λ_min = −1e-6 (resolved: below −4e-8) on top of the dense low end: the eigenvector is
    not well separated from the next (gap 2.7e-6), but the direction returned has a Rayleigh
    quotient below the threshold, between λ_min and λ_2 — a push along it lowers the energy."""
    k = laplacian(N_ROWS) - (lowest_of_laplacian(N_ROWS) + 1e-6) * sps.identity(N_ROWS)
    k = k.tocsr()
    w_min, w_max = tridiagonal_eigen(k, 0), tridiagonal_eigen(k, -1)
    x = unstable_mode(k, 3)
    assert x is not None
    q = float(x.ravel() @ (k @ x.ravel()))
    assert w_min - 1e-12 <= q < -NEGATIVE_CURVATURE * abs(w_max)


def test_the_sparse_route_gives_the_same_bits_every_time():
    """The weakly resolved mode (above) asked for twice, with an ARPACK call between them that
    advances ARPACK's own random generator: the same direction, bit for bit (a random start
    of the λ_max Lanczos made the shifts, the factor and so the direction differ from call to
    call, and a constant-volume run at jamming not reproducible)."""
    k = laplacian(N_ROWS) - (lowest_of_laplacian(N_ROWS) + 1e-6) * sps.identity(N_ROWS)
    k = k.tocsr()
    first = unstable_mode(k, 3)
    spla.eigsh(laplacian(500), k=1, which="LA", tol=1e-3, return_eigenvectors=False)
    second = unstable_mode(k, 3)
    assert first is not None and np.array_equal(first, second)


def test_the_dense_route_is_the_lowest_eigenvector():
    n = 3 * 40
    k = laplacian(n).tolil()
    k[7, 7] -= 3.0
    k = k.tocsr()
    w, v = np.linalg.eigh(k.toarray())
    x = unstable_mode(k, 3)
    assert np.array_equal(x.ravel(), v[:, 0])  # the same bits as before the sparse route changed
    flat = (laplacian(n) - lowest_of_laplacian(n) * sps.identity(n)).tocsr()
    assert unstable_mode(flat, 3) is None


def test_the_n2000_minimum_that_stopped_the_constant_volume_run():
    """The packing on which ``descend`` stopped a constant-volume run (ARPACK ``SA``: no
    convergence in 58,951 iterations; ``tests/data/saddle``): its pinned backbone Hessian is not
    positive definite, its lowest eigenvalues are a cluster near −1e-9 (dense ``eigvalsh``), above
    the resolved threshold — a flat direction, no push."""
    from jamlab.spheres.aqs.linalg import backbone_matrix, factorise
    from jamlab.spheres.aqs.network import find_backbone
    from jamlab.spheres.io import read_packing
    from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList

    path = Path(__file__).resolve().parents[1] / "data" / "saddle" / "jam2000-flat-cluster.h5"
    packing = read_packing(path)
    nl = NeighborList(packing, skin=RELAX_SKIN)
    fac = factorise(packing, nl, find_backbone(packing, nl))
    assert not fac.positive_definite
    k = backbone_matrix(packing, nl, fac)
    assert k.shape[0] > DENSE_LIMIT
    w = np.linalg.eigvalsh(k.toarray())
    assert w[0] < 0 and not w[0] < -NEGATIVE_CURVATURE * abs(w[-1])
    assert unstable_mode(k, 3) is None
