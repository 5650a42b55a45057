"""Numba kernels of the AQS fast path: the pinned backbone Hessian assembled directly as CSR."""

from __future__ import annotations

import numpy as np
from numba import njit

from jamlab.spheres._kernels import pair_stiffness


@njit(cache=True)
def backbone_hessian_csr(ci, cj, cd, free_index, n_free):
    """CSR arrays ``(data, indices, indptr)`` of ``K = H[b, b]`` (``d·n_free`` square).

    ``free_index[i]`` is the row block of particle ``i`` in ``K`` or ``−1`` (pinned particle,
    rattler: held fixed). From the contact pairs ``(i, j, r_ij)`` and the pair block
    ``B = 2 n nᵀ + (V'(r)/r)(1 − n nᵀ)``: ``K_ii = Σ_{j in contact} B_ij`` over *all* contacts
    (a held particle acts as a fixed spring end), ``K_ij = −B_ij`` between free particles.
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
        pair_stiffness(cd[p], B)
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
    order = np.argsort(new_keys[:k])
    closed = new_keys[:k][order]
    where = new_pos[:k][order]
    n_open = m0 - np.count_nonzero(seen)
    opened = np.empty(n_open, np.int64)
    k = 0
    for q in range(m0):
        if not seen[q]:
            opened[k] = keys0[q]
            k += 1
    return closed, where, opened
