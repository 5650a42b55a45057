"""Numba kernels of the AQS fast path: the pinned backbone Hessian assembled directly as CSR."""

from __future__ import annotations

import numpy as np
from numba import njit

from jamlab.spheres.kernels.pairs import pair_stiffness
from jamlab.spheres.pair import pair_sigma, pair_terms


@njit(cache=True)
def backbone_hessian_csr(ci, cj, cd, diam, alpha, free_index, n_free):
    """CSR arrays ``(data, indices, indptr)`` of ``K = H[b, b]`` (``d·n_free`` square).

    ``free_index[i]`` is the row block of particle ``i`` in ``K`` or ``−1`` (pinned particle,
    rattler: held fixed). From the contact pairs ``(i, j, r_ij)`` and the pair block
    ``B = 2 n nᵀ + (V'(r)/r)(1 − n nᵀ)``: ``K_ii = Σ_{j in contact} B_ij`` over *all* contacts
    (a held particle acts as a fixed spring end), ``K_ij = −B_ij`` between free particles
    (``diam`` in the numbering of ``ci, cj``).
    Column indices inside a row are not sorted; the matrix is symmetric.
    """
    m, d = cd.shape
    deg = np.zeros(n_free, np.int64)
    for p in range(m):
        fi = free_index[ci[p]]
        fj = free_index[cj[p]]
        if fi >= 0 and fj >= 0:
            deg[fi] += 1
            deg[fj] += 1
    slot_ptr = np.zeros(n_free + 1, np.int64)
    for i in range(n_free):
        slot_ptr[i + 1] = slot_ptr[i] + 1 + deg[i]
    n_slots = slot_ptr[n_free]
    blocks = np.zeros((n_slots, d, d), np.float64)
    block_col = np.empty(n_slots, np.int64)
    fill = np.ones(n_free, np.int64)  # slot 0 of each block row is the diagonal
    for i in range(n_free):
        block_col[slot_ptr[i]] = i
    B = np.empty((d, d), np.float64)
    for p in range(m):
        fi = free_index[ci[p]]
        fj = free_index[cj[p]]
        if fi < 0 and fj < 0:
            continue
        pair_stiffness(cd[p], pair_sigma(diam, ci[p], cj[p]), alpha, B)
        si = -1
        sj = -1
        if fi >= 0 and fj >= 0:
            si = slot_ptr[fi] + fill[fi]
            block_col[si] = fj
            fill[fi] += 1
            sj = slot_ptr[fj] + fill[fj]
            block_col[sj] = fi
            fill[fj] += 1
        for a in range(d):
            for b in range(d):
                v = B[a, b]
                if fi >= 0:
                    blocks[slot_ptr[fi], a, b] += v
                if fj >= 0:
                    blocks[slot_ptr[fj], a, b] += v
                if si >= 0:
                    blocks[si, a, b] -= v
                    blocks[sj, a, b] -= v
    size = d * n_free
    indptr = np.zeros(size + 1, np.int64)
    for i in range(n_free):
        width = d * (1 + deg[i])
        for a in range(d):
            indptr[d * i + a + 1] = indptr[d * i + a] + width
    data = np.empty(indptr[size], np.float64)
    indices = np.empty(indptr[size], np.int64)
    for i in range(n_free):
        for a in range(d):
            q = indptr[d * i + a]
            for s in range(slot_ptr[i], slot_ptr[i + 1]):
                col = block_col[s]
                for b in range(d):
                    data[q] = blocks[s, a, b]
                    indices[q] = d * col + b
                    q += 1
    return data, indices, indptr


@njit(cache=True)
def sort_by_key(keys, values):
    """In place: sort ``keys`` ascending (heapsort) and permute ``values`` alongside.

    The keys must be distinct (then the order is unique and equals ``np.argsort``'s). Written out
    because ``np.argsort`` in numba compiles its generic quicksort (~1.5 s on first use).
    """
    n = keys.size
    # build a max-heap, then move the maximum to the end n - 1 times
    for root in range(n // 2 - 1, -1, -1):
        _sift_down(keys, values, root, n)
    for end in range(n - 1, 0, -1):
        keys[0], keys[end] = keys[end], keys[0]
        values[0], values[end] = values[end], values[0]
        _sift_down(keys, values, 0, end)


@njit(cache=True)
def _sift_down(keys, values, root, end):
    """Restore the max-heap property below ``root`` in ``keys[:end]``."""
    while True:
        child = 2 * root + 1
        if child >= end:
            return
        if child + 1 < end and keys[child + 1] > keys[child]:
            child += 1
        if keys[root] >= keys[child]:
            return
        keys[root], keys[child] = keys[child], keys[root]
        values[root], values[child] = values[child], values[root]
        root = child


@njit(cache=True)
def contact_changes(keys0, row0, ci, cj, n):
    """Contacts that closed and opened since a reference list.

    ``keys0``: sorted keys ``min(i, j)·n + max(i, j)`` of the reference contacts, ``row0`` their
    row pointers (``keys0[row0[i]:row0[i+1]]`` are the pairs whose smaller index is ``i``);
    ``(ci, cj)`` the current contacts (either orientation, any order). Returns
    ``(closed, where, opened)``: the sorted keys of current contacts absent from ``keys0``,
    their positions in ``(ci, cj)``, and the sorted keys of reference contacts absent now.
    """
    m0 = keys0.size
    seen = np.zeros(m0, np.bool_)
    m = ci.size
    new_pos = np.empty(m, np.int64)
    new_keys = np.empty(m, np.int64)
    k = 0
    for p in range(m):
        a = ci[p]
        b = cj[p]
        if a > b:
            a, b = b, a
        key = a * n + b
        found = False
        for q in range(row0[a], row0[a + 1]):
            if keys0[q] == key:
                seen[q] = True
                found = True
                break
        if not found:
            new_pos[k] = p
            new_keys[k] = key
            k += 1
    closed = new_keys[:k].copy()
    where = new_pos[:k].copy()
    sort_by_key(closed, where)
    n_open = m0
    for q in range(m0):
        if seen[q]:
            n_open -= 1
    opened = np.empty(n_open, np.int64)
    k = 0
    for q in range(m0):
        if not seen[q]:
            opened[k] = keys0[q]
            k += 1
    return closed, where, opened


@njit(cache=True)
def forces_virial_flags(pos, start, nbr, shift, diam, alpha, forces, virial, flags, write):
    """One pass over the neighbour list: ``E``, forces, the virial ``S_ab`` (as
    ``pairs.energy_forces_virial``) and the contact state of every list slot.

    ``flags[k]`` is 1 if slot ``k`` (pair ``i``, ``nbr[k]``) is a contact (``r < σ_ij``). With
    ``write`` the states are stored in ``flags``; otherwise they are compared with it. Returns
    ``(E, N_c, mismatches)``: ``mismatches`` counts slots whose state differs from ``flags``
    (0 when writing).
    """
    if pos.shape[1] == 3:
        return _forces_virial_flags_3d(
            pos, start, nbr, shift, diam, alpha, forces, virial, flags, write
        )
    n, d = pos.shape
    forces[:, :] = 0.0
    virial[:, :] = 0.0
    e = 0.0
    n_c = 0
    mism = 0
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
            c_now = 1 if r2 < s * s else 0
            if write:
                flags[k] = c_now
            elif c_now != flags[k]:
                mism += 1
            if c_now:
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
    return e, n_c, mism


@njit(cache=True)
def _forces_virial_flags_3d(pos, start, nbr, shift, diam, alpha, forces, virial, flags, write):
    n = pos.shape[0]
    forces[:, :] = 0.0
    e = 0.0
    n_c = 0
    mism = 0
    sxx = sxy = sxz = syy = syz = szz = 0.0
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
            c_now = 1 if r2 < s * s else 0
            if write:
                flags[k] = c_now
            elif c_now != flags[k]:
                mism += 1
            if c_now:
                r = np.sqrt(r2)
                v, dv, _ = pair_terms(r, s, alpha)
                e += v
                n_c += 1
                c = -dv / r
                fx += c * dx
                fy += c * dy
                fz += c * dz
                forces[j, 0] -= c * dx
                forces[j, 1] -= c * dy
                forces[j, 2] -= c * dz
                sxx -= c * dx * dx
                sxy -= c * dx * dy
                sxz -= c * dx * dz
                syy -= c * dy * dy
                syz -= c * dy * dz
                szz -= c * dz * dz
        forces[i, 0] += fx
        forces[i, 1] += fy
        forces[i, 2] += fz
    virial[0, 0] = sxx
    virial[0, 1] = sxy
    virial[0, 2] = sxz
    virial[1, 0] = sxy
    virial[1, 1] = syy
    virial[1, 2] = syz
    virial[2, 0] = sxz
    virial[2, 1] = syz
    virial[2, 2] = szz
    return e, n_c, mism


@njit(cache=True)
def rows_max_norm(f, rows):
    """``max_k |f[rows[k]]|`` (all rows if ``rows`` is empty is not supported: pass them)."""
    best = 0.0
    d = f.shape[1]
    for k in range(rows.size):
        i = rows[k]
        s = 0.0
        for a in range(d):
            s += f[i, a] * f[i, a]
        if s > best:
            best = s
    return np.sqrt(best)


@njit(cache=True)
def gather_rows(f, rows):
    """``f[rows]`` as a new C-contiguous array."""
    d = f.shape[1]
    out = np.empty((rows.size, d))
    for k in range(rows.size):
        for a in range(d):
            out[k, a] = f[rows[k], a]
    return out


@njit(cache=True)
def moved(pos, rows, dx):
    """A copy of ``pos`` with ``dx[k]`` added to row ``rows[k]``."""
    out = pos.copy()
    d = pos.shape[1]
    for k in range(rows.size):
        for a in range(d):
            out[rows[k], a] += dx[k, a]
    return out
