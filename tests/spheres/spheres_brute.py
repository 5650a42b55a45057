"""Independent brute force for soft spheres: every pair, every periodic image, plain numpy.

It never uses jamlab's minimum-image code: the images ``r_j + n_x L e_x + n_y (γ L e_x + L e_y)
+ Σ_k n_k L e_k`` are enumerated explicitly over a range wide enough for positions in
``[0, L)^d`` and the given strain, and every image closer than ``σ_ij`` contributes. The pair law
``V = (1 − r/σ_ij)^α`` (``SPEC.md`` §5) is written out here by hand, not taken from jamlab.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def wrap(pos: np.ndarray, L: float, gamma: float) -> np.ndarray:
    """Into [0, L)^d: crossing y by k boxes moves x by −k γ L, then the other axes modulo L."""
    pos = np.array(pos, dtype=float)
    k = np.floor(pos[:, 1] / L)
    pos[:, 1] -= k * L
    pos[:, 0] -= k * gamma * L
    for a in range(pos.shape[1]):
        if a != 1:
            pos[:, a] -= np.floor(pos[:, a] / L) * L
    return pos


def image_shifts(L: float, dim: int, gamma: float) -> np.ndarray:
    """All lattice vectors that can bring two points of ``[0, L)^d`` within distance 1."""
    kx = math.ceil(abs(gamma)) + 2
    shifts = []
    for n in itertools.product(range(-kx, kx + 1), *([range(-1, 2)] * (dim - 1))):
        t = np.array(n, dtype=float) * L
        t[0] += n[1] * gamma * L
        shifts.append(t)
    return np.array(shifts)


def pair_terms(pos: np.ndarray, L: float, gamma: float, diameters: np.ndarray | None = None):
    """Every interacting (i, j, image) with i < j: arrays i, j and r_ij = r_i − (r_j + t)."""
    n, dim = pos.shape
    diam = np.ones(n) if diameters is None else np.asarray(diameters, dtype=float)
    ii, jj = np.triu_indices(n, k=1)
    sig = (diam[ii] + diam[jj]) / 2
    out_i, out_j, out_d = [], [], []
    for t in image_shifts(L, dim, gamma):
        dr = pos[ii] - (pos[jj] + t)
        r = np.sqrt((dr * dr).sum(axis=1))
        m = r < sig
        out_i.append(ii[m])
        out_j.append(jj[m])
        out_d.append(dr[m])
    return np.concatenate(out_i), np.concatenate(out_j), np.concatenate(out_d)


def brute_force(
    pos: np.ndarray,
    L: float,
    gamma: float,
    diameters: np.ndarray | None = None,
    alpha: float = 2.0,
) -> dict:
    """E, F, S_ab (extensive virial), Σ, p and the dense Hessian, by the SPEC.md formulas."""
    n, dim = pos.shape
    diam = np.ones(n) if diameters is None else np.asarray(diameters, dtype=float)
    i, j, dr = pair_terms(pos, L, gamma, diam)
    r = np.sqrt((dr * dr).sum(axis=1))
    sig = (diam[i] + diam[j]) / 2
    h = 1.0 - r / sig
    vprime = -alpha / sig * h ** (alpha - 1)
    v2 = alpha * (alpha - 1) / sig**2 * h ** (alpha - 2)
    e_terms = h**alpha
    fvec = -(vprime / r)[:, None] * dr
    forces = np.zeros((n, dim))
    np.add.at(forces, i, fvec)
    np.add.at(forces, j, -fvec)
    s_terms = (vprime / r)[:, None, None] * dr[:, :, None] * dr[:, None, :]
    S = s_terms.sum(axis=0)
    H = np.zeros((n * dim, n * dim))
    xi = np.zeros((n, dim))  # ∂F/∂γ at fixed reduced coordinates: −Σ_j B_ij e_x y_ij
    eye = np.eye(dim)
    for p in range(len(r)):
        nn = np.outer(dr[p], dr[p]) / r[p] ** 2
        B = v2[p] * nn + (vprime[p] / r[p]) * (eye - nn)
        a, b = i[p] * dim, j[p] * dim
        H[a : a + dim, a : a + dim] += B
        H[b : b + dim, b : b + dim] += B
        H[a : a + dim, b : b + dim] -= B
        H[b : b + dim, a : a + dim] -= B
        xi[i[p]] -= B[:, 0] * dr[p, 1]
        xi[j[p]] += B[:, 0] * dr[p, 1]
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
        "dforce_dstrain": xi,
        "n_contacts": len(r),
        "pairs": (i, j),
    }


def brute_jammed_state(packing, ftol: float) -> dict:
    """The jammed verdict by brute force: contacts from :func:`pair_terms` (every pair, every
    image, σ_ij from the diameters), rattlers removed one particle at a time from a work queue,
    the virial pressure of ``V = (1 − r/σ_ij)^α`` written out, the floor ``10 ftol N / L^d``, and
    the net forces summed pair by pair (a configuration with ``max_i |F_i| ≥ ftol`` is not a
    minimum: not jammed)."""
    from collections import deque

    pos = packing.wrapped().positions
    L, d, n = packing.box.length, packing.dim, packing.n
    diam = np.asarray(packing.diameters, dtype=float)
    alpha = float(packing.alpha)
    i, j, dr = pair_terms(pos, L, packing.strain, diam)
    r = np.sqrt((dr * dr).sum(axis=1))
    sig = (diam[i] + diam[j]) / 2
    p = float(np.sum(alpha / sig * (1.0 - r / sig) ** (alpha - 1) * r) / (d * L**d))
    push = (alpha / sig * (1.0 - r / sig) ** (alpha - 1) / r)[:, None] * dr
    net = np.zeros((n, d))
    np.add.at(net, i, push)
    np.add.at(net, j, -push)
    fmax = float(np.sqrt((net * net).sum(axis=1)).max()) if n else 0.0
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for a, b in zip(i, j, strict=True):
        nbrs[a].append(b)
        nbrs[b].append(a)
    alive = np.ones(n, dtype=bool)
    count = np.array([len(x) for x in nbrs])
    queue = deque(k for k in range(n) if count[k] < d + 1)
    while queue:
        k = queue.popleft()
        if not alive[k]:
            continue
        alive[k] = False
        for m in nbrs[k]:
            if alive[m]:
                count[m] -= 1
                if count[m] < d + 1:
                    queue.append(m)
    n_kept = int(alive.sum())
    n_c = int(np.sum(alive[i] & alive[j]))
    floor = 10.0 * ftol * n / L**d
    jammed = fmax < ftol and n_kept > 0 and n_c >= d * (n_kept - 1) + 1 and p > floor
    return {
        "n_kept": n_kept, "n_c": n_c, "p": p, "floor": floor, "jammed": jammed, "backbone": alive,
        "max_force": fmax,
    }  # fmt: skip


def brute_elastic_response(
    pos: np.ndarray,
    L: float,
    gamma: float,
    keep: np.ndarray,
    dgamma: float,
    diameters: np.ndarray | None = None,
    alpha: float = 2.0,
) -> np.ndarray:
    """``u^el = δγ H⁺ Ξ`` of the minimum ``pos`` (in ``[0, L)^d``) by dense least squares on the
    system with the non-``keep`` particles (rattlers) deleted: the hand-written dense Hessian
    and ``∂F/∂γ`` of :func:`brute_force`; the minimum-norm solution has no translation (zero
    mean over the kept particles). Deleted particles get 0."""
    n, dim = pos.shape
    keep = np.asarray(keep, dtype=bool)
    diam = np.ones(n) if diameters is None else np.asarray(diameters, dtype=float)
    b = brute_force(pos[keep], L, gamma, diam[keep], alpha)
    sol = np.linalg.lstsq(b["hessian"], dgamma * b["dforce_dstrain"].ravel(), rcond=1e-12)[0]
    u = np.zeros((n, dim))
    u[keep] = sol.reshape(-1, dim)
    return u
