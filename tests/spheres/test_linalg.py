"""The backbone factorisation (:mod:`jamlab.spheres.aqs.linalg`): CHOLMOD's Cholesky against
dense linear algebra (solutions, and the positive-definiteness verdict against the eigenvalues)
and against SuperLU's ``LDLᵀ``, which it replaced; the fallback where the matrix is indefinite."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps

import jamlab.spheres as sp
import jamlab.spheres.aqs.linalg as linalg
from jamlab.spheres.aqs.linalg import (
    Cholesky,
    backbone_matrix,
    cholesky,
    factor_matrix,
    factorise,
    ldlt,
)
from jamlab.spheres.aqs.network import find_backbone


def _random_symmetric(n: int, shift: float, seed: int) -> sps.csc_matrix:
    """A sparse symmetric matrix with a few couplings per row, shifted by ``shift``·1 (its
    definiteness set by the shift: checked against ``eigvalsh`` by the tests)."""
    rng = np.random.default_rng(seed)
    a = sps.random(n, n, density=4.0 / n, random_state=rng, format="csr")
    a = a + a.T
    return sps.csc_matrix(a + shift * sps.identity(n))


@pytest.mark.parametrize("natural", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cholesky_solves_and_tells_definiteness_as_the_eigenvalues_do(natural, seed):
    for shift in (-1.0, 0.0, 1.0, 4.0, 8.0):
        k = _random_symmetric(120, shift, seed)
        dense = k.toarray()
        lowest = float(np.linalg.eigvalsh(dense)[0])
        if abs(lowest) < 1e-8:
            continue  # the verdict is a rounding question there
        chol = cholesky(k, natural)
        assert (chol is not None) == (lowest > 0)
        if chol is None:
            continue
        b = np.random.default_rng(seed).standard_normal((120, 3))
        x_dense = np.linalg.solve(dense, b)
        assert np.allclose(chol.solve(b[:, 0]), x_dense[:, 0], rtol=1e-10, atol=1e-12)
        assert chol.solve(b[:, 0]).shape == (120,)
        assert np.allclose(chol.solve(b), x_dense, rtol=1e-10, atol=1e-12)
        # SuperLU's inertia gives the same verdict, and the same solution
        lu, pd = ldlt(k, natural)
        assert pd
        assert np.allclose(lu.solve(b[:, 0]), x_dense[:, 0], rtol=1e-10, atol=1e-12)


def test_the_solve_does_not_touch_its_right_hand_side():
    k = _random_symmetric(50, 8.0, 3)
    chol = cholesky(k)
    b = np.arange(50, dtype=np.float64)
    keep = b.copy()
    chol.solve(b)
    assert np.array_equal(b, keep)


def test_an_indefinite_matrix_falls_back_to_superlu_and_its_inertia():
    k = _random_symmetric(120, -1.0, 0)
    assert np.linalg.eigvalsh(k.toarray())[0] < -1e-3
    factor, pd = factor_matrix(k, True)
    assert not pd
    assert not isinstance(factor, Cholesky)
    assert factor is not None and hasattr(factor, "perm_r")  # SuperLU's


@pytest.mark.parametrize("seed", [1, 2])
def test_the_backbone_factor_agrees_with_superlu_on_a_jammed_packing(seed, monkeypatch):
    """``factorise`` on ``jam(256, 3, p = 1e-4)`` (fewer free particles than ``ND_MIN_FREE``:
    the factorisation's own order; the nested-dissection order is the random matrices' natural
    one above) with CHOLMOD and with
    ``FACTORISATION = "superlu"``: both positive definite, and their solves agree with each
    other and with the backbone Hessian (``K x = b``)."""
    p = sp.jam(256, 3, seed=seed, p_target=1e-4).packing
    nl = sp.NeighborList(p)
    backbone = find_backbone(p, nl)
    fac = factorise(p, nl, backbone)
    assert fac.positive_definite and isinstance(fac.lu, Cholesky)
    monkeypatch.setattr(linalg, "FACTORISATION", "superlu")
    old = factorise(p, nl, backbone)
    assert old.positive_definite and not isinstance(old.lu, Cholesky)
    assert np.array_equal(fac.free, old.free)
    k = backbone_matrix(p, nl, fac)
    b = np.random.default_rng(seed).standard_normal(k.shape[0])
    x, y = fac.solve(b), old.solve(b)
    assert np.linalg.norm(k @ x - b) <= 1e-9 * np.linalg.norm(b)
    assert np.max(np.abs(x - y)) <= 1e-8 * np.max(np.abs(y))


def test_an_unknown_factorisation_is_refused(monkeypatch):
    monkeypatch.setattr(linalg, "FACTORISATION", "pardiso")
    with pytest.raises(ValueError, match="FACTORISATION must be one of"):
        factor_matrix(_random_symmetric(10, 8.0, 0))
