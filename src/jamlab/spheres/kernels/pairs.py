"""Numba kernels of the pair sums: energy, forces, virial, contact lists, Hessian blocks and
``∂F/∂γ``, every one with the pair law of :mod:`jamlab.spheres.pair` (``V = (1 − r/σ_ij)^α``,
``diam`` the diameters in the numbering of the positions, ``alpha`` the exponent).

Neighbour lists (``start, nbr, shift``) come from :mod:`jamlab.spheres.kernels.geometry`: the
partners of particle ``i`` are ``nbr[start[i]:start[i+1]]`` and ``r_ij = r_i − r_j + shift[k]``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from jamlab.spheres.pair import harmonic_terms_masked, pair_sigma, pair_terms


@njit(cache=True)
def energy(pos, start, nbr, shift, diam, alpha):
    """``E = Σ_{i<j} V(r_ij)`` (pair law: :mod:`jamlab.spheres.pair`)."""
    n, d = pos.shape
    e = 0.0
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            s = pair_sigma(diam, i, j)
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a] + shift[k, a]
                r2 += t * t
            if r2 < s * s:
                v, _, _ = pair_terms(np.sqrt(r2), s, alpha)
                e += v
    return e


@njit(cache=True)
def energy_forces(pos, start, nbr, shift, diam, alpha, forces):
    """Total energy; writes ``F_i = −∂E/∂r_i = −Σ_j V'(r_ij) r_ij/r_ij`` into ``forces``."""
    n, d = pos.shape
    forces[:, :] = 0.0
    e = 0.0
    dr = np.empty(d, np.float64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            s = pair_sigma(diam, i, j)
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a] + shift[k, a]
                dr[a] = t
                r2 += t * t
            if r2 < s * s:
                r = np.sqrt(r2)
                v, dv, _ = pair_terms(r, s, alpha)
                e += v
                c = -dv / r
                for a in range(d):
                    forces[i, a] += c * dr[a]
                    forces[j, a] -= c * dr[a]
    return e


@njit(cache=True)
def energy_forces_3d(pos, start, nbr, shift, diam, alpha, forces):
    """``energy_forces`` unrolled for ``d = 3`` (same formula)."""
    n = pos.shape[0]
    forces[:, :] = 0.0
    e = 0.0
    for i in range(n):
        xi = pos[i, 0]
        yi = pos[i, 1]
        zi = pos[i, 2]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            dx = xi - pos[j, 0] + shift[k, 0]
            dy = yi - pos[j, 1] + shift[k, 1]
            dz = zi - pos[j, 2] + shift[k, 2]
            r2 = dx * dx + dy * dy + dz * dz
            s = pair_sigma(diam, i, j)
            if r2 < s * s:
                r = np.sqrt(r2)
                v, dv, _ = pair_terms(r, s, alpha)
                e += v
                c = -dv / r
                fx += c * dx
                fy += c * dy
                fz += c * dz
                forces[j, 0] -= c * dx
                forces[j, 1] -= c * dy
                forces[j, 2] -= c * dz
        forces[i, 0] += fx
        forces[i, 1] += fy
        forces[i, 2] += fz
    return e


@njit(cache=True)
def energy_forces_2d(pos, start, nbr, shift, diam, alpha, forces):
    """``energy_forces`` unrolled for ``d = 2`` (same formula)."""
    n = pos.shape[0]
    forces[:, :] = 0.0
    e = 0.0
    for i in range(n):
        xi = pos[i, 0]
        yi = pos[i, 1]
        fx = 0.0
        fy = 0.0
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            dx = xi - pos[j, 0] + shift[k, 0]
            dy = yi - pos[j, 1] + shift[k, 1]
            r2 = dx * dx + dy * dy
            s = pair_sigma(diam, i, j)
            if r2 < s * s:
                r = np.sqrt(r2)
                v, dv, _ = pair_terms(r, s, alpha)
                e += v
                c = -dv / r
                fx += c * dx
                fy += c * dy
                forces[j, 0] -= c * dx
                forces[j, 1] -= c * dy
        forces[i, 0] += fx
        forces[i, 1] += fy
    return e


@njit(cache=True)
def energy_forces_3d_masked(pos, start, nbr, shift, diam, forces):
    """``energy_forces_3d`` for the harmonic law without a branch on the contact test
    (:func:`jamlab.spheres.pair.harmonic_terms_masked`): the same bits."""
    n = pos.shape[0]
    forces[:, :] = 0.0
    e = 0.0
    for i in range(n):
        xi = pos[i, 0]
        yi = pos[i, 1]
        zi = pos[i, 2]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            dx = xi - pos[j, 0] + shift[k, 0]
            dy = yi - pos[j, 1] + shift[k, 1]
            dz = zi - pos[j, 2] + shift[k, 2]
            r2 = dx * dx + dy * dy + dz * dz
            r = np.sqrt(r2)
            v, dv = harmonic_terms_masked(r2, r, pair_sigma(diam, i, j))
            e += v
            c = -dv / r
            fx += c * dx
            fy += c * dy
            fz += c * dz
            forces[j, 0] -= c * dx
            forces[j, 1] -= c * dy
            forces[j, 2] -= c * dz
        forces[i, 0] += fx
        forces[i, 1] += fy
        forces[i, 2] += fz
    return e


@njit(cache=True, inline="always")
def energy_forces_any(pos, start, nbr, shift, diam, alpha, forces, branch_free_pairs):
    """Dispatch to the unrolled ``d = 2, 3`` kernels (in ``d = 3`` branch-free for the harmonic
    law on lists longer than ``branch_free_pairs``: the machine's crossover, measured by
    :func:`jamlab.spheres.kernel_choice.threshold_for`; both give the same bits), the generic
    one otherwise. (``d = 2`` stays branchy: a 2D branch-free kernel measured no gain at
    N = 4000, 10.8k pairs, 17.0 against 17.5 ns per particle, and was not kept.)

    Inlined into its compiled callers (``inline="always"``, numba's level): with the threshold an
    argument, FIRE's loop around the call came out 2–3 % slower per iteration at N = 1000 than
    with the constant it replaced; inlined, it is level with it (measured alternating)."""
    d = pos.shape[1]
    if d == 3:
        if alpha is None and nbr.shape[0] > branch_free_pairs:
            return energy_forces_3d_masked(pos, start, nbr, shift, diam, forces)
        return energy_forces_3d(pos, start, nbr, shift, diam, alpha, forces)
    if d == 2:
        return energy_forces_2d(pos, start, nbr, shift, diam, alpha, forces)
    return energy_forces(pos, start, nbr, shift, diam, alpha, forces)


@njit(cache=True)
def virial_tensor(pos, start, nbr, shift, diam, alpha):
    """Extensive ``S_ab = Σ_{i<j} V'(r) r_a r_b / r``.

    ``Σ = S_xy = ∂E/∂γ`` and ``p = −tr S / (d L^d)``.
    """
    n, d = pos.shape
    st = np.zeros((d, d), np.float64)
    dr = np.empty(d, np.float64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            s = pair_sigma(diam, i, j)
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a] + shift[k, a]
                dr[a] = t
                r2 += t * t
            if r2 < s * s:
                r = np.sqrt(r2)
                _, dv, _ = pair_terms(r, s, alpha)
                c = dv / r
                for a in range(d):
                    for b in range(d):
                        st[a, b] += c * dr[a] * dr[b]
    return st


@njit(cache=True)
def energy_forces_virial(pos, start, nbr, shift, diam, alpha, forces, virial):
    """One pass: returns ``E``, writes ``F`` into ``forces`` and ``S_ab`` (see
    ``virial_tensor``) into ``virial``; also returns the number of contacts ``N_c``."""
    n, d = pos.shape
    forces[:, :] = 0.0
    virial[:, :] = 0.0
    e = 0.0
    n_c = 0
    dr = np.empty(d, np.float64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            s = pair_sigma(diam, i, j)
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a] + shift[k, a]
                dr[a] = t
                r2 += t * t
            if r2 < s * s:
                r = np.sqrt(r2)
                v, dv, _ = pair_terms(r, s, alpha)
                e += v
                n_c += 1
                c = -dv / r
                for a in range(d):
                    forces[i, a] += c * dr[a]
                    forces[j, a] -= c * dr[a]
                    for b in range(d):
                        virial[a, b] -= c * dr[a] * dr[b]
    return e, n_c


@njit(cache=True)
def contact_pairs(pos, start, nbr, shift, diam):
    """Pairs in contact (``r_ij < σ_ij``): arrays ``i``, ``j`` (``i < j``) and the separations."""
    n, d = pos.shape
    m = 0
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            s = pair_sigma(diam, i, j)
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a] + shift[k, a]
                r2 += t * t
            if r2 < s * s:
                m += 1
    ci = np.empty(m, np.int64)
    cj = np.empty(m, np.int64)
    cd = np.empty((m, d), np.float64)
    m = 0
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            s = pair_sigma(diam, i, j)
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a] + shift[k, a]
                r2 += t * t
            if r2 < s * s:
                sign = 1.0
                if i < j:
                    ci[m] = i
                    cj[m] = j
                else:
                    ci[m] = j
                    cj[m] = i
                    sign = -1.0
                for a in range(d):
                    cd[m, a] = sign * (pos[i, a] - pos[j, a] + shift[k, a])
                m += 1
    return ci, cj, cd


@njit(cache=True)
def pair_force_factors(r, ci, cj, diam, alpha):
    """``−V'(r)/r`` of each pair ``(ci, cj)`` at distance ``r`` (no cut-off applied: a network
    spring in tension too, :func:`jamlab.spheres.pair.pair_terms`); the force on ``i`` is
    ``−V'(r)/r · r_ij``."""
    m = r.shape[0]
    c = np.empty(m, np.float64)
    for p in range(m):
        _, dv, _ = pair_terms(r[p], pair_sigma(diam, ci[p], cj[p]), alpha)
        c[p] = -dv / r[p]
    return c


@njit(cache=True)
def pair_stiffness(dr, sigma, alpha, out):
    """``B = ∂²V/∂r∂r = V'' n nᵀ + (V'/r)(1 − n nᵀ)`` at separation ``dr`` (``|dr| < σ``)."""
    d = dr.shape[0]
    r2 = 0.0
    for a in range(d):
        r2 += dr[a] * dr[a]
    r = np.sqrt(r2)
    _, dv, d2v = pair_terms(r, sigma, alpha)
    t = dv / r
    for a in range(d):
        for b in range(d):
            nn = dr[a] * dr[b] / r2
            out[a, b] = d2v * nn + t * ((1.0 if a == b else 0.0) - nn)


@njit(cache=True)
def hessian_coo(ci, cj, cd, diam, alpha):
    """COO triplets of ``H = ∂²E/∂r∂r`` (dN×dN, index ``d·i + a``), from contact pairs.

    ``H_ii += B_ij``, ``H_jj += B_ij``, ``H_ij = H_ji = −B_ij`` with ``B`` from ``pair_stiffness``
    (``diam`` in the numbering of ``ci, cj``); duplicates are to be summed (as ``scipy.sparse``
    does).
    """
    m, d = cd.shape
    nnz = 4 * m * d * d
    rows = np.empty(nnz, np.int64)
    cols = np.empty(nnz, np.int64)
    vals = np.empty(nnz, np.float64)
    B = np.empty((d, d), np.float64)
    q = 0
    for p in range(m):
        i = ci[p]
        j = cj[p]
        pair_stiffness(cd[p], pair_sigma(diam, i, j), alpha, B)
        for a in range(d):
            for b in range(d):
                v = B[a, b]
                rows[q] = d * i + a
                cols[q] = d * i + b
                vals[q] = v
                rows[q + 1] = d * j + a
                cols[q + 1] = d * j + b
                vals[q + 1] = v
                rows[q + 2] = d * i + a
                cols[q + 2] = d * j + b
                vals[q + 2] = -v
                rows[q + 3] = d * j + a
                cols[q + 3] = d * i + b
                vals[q + 3] = -v
                q += 4
    return rows, cols, vals


@njit(cache=True)
def dforce_dstrain(n, ci, cj, cd, diam, alpha):
    """``Ξ_i = ∂F_i/∂γ`` at fixed reduced coordinates (affine ``∂r_ij/∂γ = y_ij e_x``).

    ``F_i = −Σ_j V'(r_ij) n_ij`` so ``Ξ_i = −Σ_j B_ij e_x y_ij`` and ``Ξ_j`` the opposite.
    """
    m, d = cd.shape
    xi = np.zeros((n, d), np.float64)
    B = np.empty((d, d), np.float64)
    for p in range(m):
        pair_stiffness(cd[p], pair_sigma(diam, ci[p], cj[p]), alpha, B)
        y = cd[p, 1]
        for a in range(d):
            v = B[a, 0] * y
            xi[ci[p], a] -= v
            xi[cj[p], a] += v
    return xi


@njit(cache=True)
def max_force(forces):
    """``max_i |F_i|``."""
    n, d = forces.shape
    best = 0.0
    for i in range(n):
        f2 = 0.0
        for a in range(d):
            f2 += forces[i, a] * forces[i, a]
        if f2 > best:
            best = f2
    return np.sqrt(best)
