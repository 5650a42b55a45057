"""Independent brute force for harmonic spheres: every pair, every periodic image, plain numpy.

It never uses jamlab's minimum-image code: the images ``r_j + n_x L e_x + n_y (γ L e_x + L e_y)
+ Σ_k n_k L e_k`` are enumerated explicitly over a range wide enough for positions in
``[0, L)^d`` and the given strain, and every image closer than 1 contributes.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def image_shifts(L: float, dim: int, gamma: float) -> np.ndarray:
    """All lattice vectors that can bring two points of ``[0, L)^d`` within distance 1."""
    kx = math.ceil(abs(gamma)) + 2
    shifts = []
    for n in itertools.product(range(-kx, kx + 1), *([range(-1, 2)] * (dim - 1))):
        t = np.array(n, dtype=float) * L
        t[0] += n[1] * gamma * L
        shifts.append(t)
    return np.array(shifts)


def pair_terms(pos: np.ndarray, L: float, gamma: float):
    """Every interacting (i, j, image) with i < j: arrays i, j and r_ij = r_i − (r_j + t)."""
    n, dim = pos.shape
    ii, jj = np.triu_indices(n, k=1)
    out_i, out_j, out_d = [], [], []
    for t in image_shifts(L, dim, gamma):
        dr = pos[ii] - (pos[jj] + t)
        r = np.sqrt((dr * dr).sum(axis=1))
        m = r < 1.0
        out_i.append(ii[m])
        out_j.append(jj[m])
        out_d.append(dr[m])
    return np.concatenate(out_i), np.concatenate(out_j), np.concatenate(out_d)


def brute_force(pos: np.ndarray, L: float, gamma: float) -> dict:
    """E, F, S_ab (extensive virial), Σ, p and the dense Hessian, by the SPEC.md formulas."""
    n, dim = pos.shape
    i, j, dr = pair_terms(pos, L, gamma)
    r = np.sqrt((dr * dr).sum(axis=1))
    vprime = -2.0 * (1.0 - r)
    e_terms = (1.0 - r) ** 2
    fvec = -(vprime / r)[:, None] * dr
    forces = np.zeros((n, dim))
    np.add.at(forces, i, fvec)
    np.add.at(forces, j, -fvec)
    s_terms = (vprime / r)[:, None, None] * dr[:, :, None] * dr[:, None, :]
    S = s_terms.sum(axis=0)
    H = np.zeros((n * dim, n * dim))
    eye = np.eye(dim)
    for p in range(len(r)):
        nn = np.outer(dr[p], dr[p]) / r[p] ** 2
        B = 2.0 * nn + (vprime[p] / r[p]) * (eye - nn)
        a, b = i[p] * dim, j[p] * dim
        H[a : a + dim, a : a + dim] += B
        H[b : b + dim, b : b + dim] += B
        H[a : a + dim, b : b + dim] -= B
        H[b : b + dim, a : a + dim] -= B
    return {
        "energy": e_terms.sum(),
        "energy_scale": e_terms.sum(),
        "forces": forces,
        "force_scale": np.abs(fvec).sum(axis=0).max() + 1e-300,
        "virial": S,
        "virial_scale": np.abs(s_terms).sum(axis=0),
        "shear_stress": S[0, 1],
        "pressure": -np.trace(S) / (dim * L**dim),
        "hessian": H,
        "n_contacts": len(r),
        "pairs": (i, j),
    }
