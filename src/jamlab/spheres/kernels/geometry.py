"""Numba kernels of the periodic geometry under Lees–Edwards shear, any dimension ``d >= 2``:
wrapping, minimum images and the neighbour list.

Neighbour list
--------------
A half Verlet list in CSR form (each pair once): the partners of particle ``i`` are
``nbr[start[i]:start[i+1]]``; ``shift[k]`` is the Cartesian periodic-image vector of pair ``k``,
so that ``r_ij = r_i − r_j + shift[k]``, and ``img_y[k] = −shift[k, y]/L`` counts its ``y``
crossings. It
contains every pair closer than ``rc = σ_max + skin`` when built. Under an affine strain step
``γ → γ + Δγ`` the shifts follow exactly (``shift_x −= img_y Δγ L``), so the list is kept across
strain steps. With ``u_i = r_i − r_i^ref − Δγ y_i^ref e_x`` the non-affine displacement since the
build, every pair that can have ``r < 1`` is still in the list as long as

    2 max_i |u_i| + |Δγ| rc < skin,

because for a pair not listed ``r ≥ rc − 2 max|u| − |Δγ| |Δy^ref|`` and ``|Δy^ref| < rc``.

Candidates are found with cells in the sheared (reduced) frame ``s = h⁻¹ r`` with
``h = [[L, γ'L], [0, L]] ⊕ L·1`` and ``γ' = γ − round(γ)``: the ``x`` planes of that lattice are
``L/√(1+γ'²)`` apart, so ``n_x = ⌊L / (rc √(1+γ'²))⌋`` cells of that width (and ``⌊L/rc⌋`` along
every other axis) guarantee that a pair closer than ``rc`` sits in neighbouring cells. With fewer
than 3 cells along some axis the search falls back to all pairs. The box must satisfy
``L > 2 rc`` so that a pair has at most one image within ``rc`` (the Python layer shrinks the
skin for small boxes).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def reduce_strain(gamma):
    """``γ' = γ − round(γ)`` in ``[−1/2, 1/2]``: the same Lees–Edwards lattice."""
    return gamma - np.floor(gamma + 0.5)


@njit(cache=True)
def wrap_positions(pos, L, gamma):
    """In place: map every particle into ``[0, L)^d`` along Lees–Edwards images.

    ``k_y = ⌊y/L⌋``: ``y −= k_y L``, ``x −= k_y γ' L``; then ``r_a −= ⌊r_a/L⌋ L`` for ``a ≠ y``.
    """
    n, d = pos.shape
    g = reduce_strain(gamma)
    for i in range(n):
        ky = np.floor(pos[i, 1] / L)
        pos[i, 1] -= ky * L
        pos[i, 0] -= ky * g * L
        for a in range(d):
            if a != 1:
                pos[i, a] -= np.floor(pos[i, a] / L) * L
            if pos[i, a] >= L:
                pos[i, a] -= L
            if pos[i, a] < 0.0:
                pos[i, a] = 0.0


@njit(cache=True)
def _min_image_into(pos, i, j, L, g, dr, shift):
    """``dr = r_i − r_j + shift`` for the minimum image; returns ``(|dr|², n_y)``.

    ``n_y = round(Δy/L)`` and the ``x`` shift ``n_y γ' L`` is applied before rounding ``x``.
    """
    d = pos.shape[1]
    dy = pos[i, 1] - pos[j, 1]
    ny = np.floor(dy / L + 0.5)
    shift[1] = -ny * L
    dx = pos[i, 0] - pos[j, 0] - ny * g * L
    nx = np.floor(dx / L + 0.5)
    shift[0] = -ny * g * L - nx * L
    for a in range(2, d):
        shift[a] = -np.floor((pos[i, a] - pos[j, a]) / L + 0.5) * L
    r2 = 0.0
    for a in range(d):
        t = pos[i, a] - pos[j, a] + shift[a]
        dr[a] = t
        r2 += t * t
    return r2, int(ny)


# ------------------------------------------------------------------------------------------------
# neighbour list


@njit(cache=True)
def _fill_all_pairs(pos, L, g, rc2, start, nbr, shift, img_y):
    """All-pairs search; writes at most ``len(nbr)`` pairs and returns how many there are."""
    n, d = pos.shape
    cap = nbr.shape[0]
    dr = np.empty(d, np.float64)
    sh = np.empty(d, np.float64)
    m = 0
    for i in range(n):
        start[i] = m
        for j in range(i + 1, n):
            r2, ny = _min_image_into(pos, i, j, L, g, dr, sh)
            if r2 < rc2:
                if m < cap:
                    nbr[m] = j
                    for a in range(d):
                        shift[m, a] = sh[a]
                    img_y[m] = ny
                m += 1
    start[n] = m
    return m


@njit(cache=True)
def _fill_cells(pos, L, g, rc2, ncell, start, nbr, shift, img_y):
    """Cell search (sheared cells, 3^d stencil); writes at most ``len(nbr)`` pairs and returns
    how many there are."""
    n, d = pos.shape
    cap = nbr.shape[0]
    m = 0
    # Cell coordinates in the sheared frame, s_x = (x − γ' y)/L, s_a = r_a/L, wrapped to [0, 1).
    # w_i = h s_i is the representative of particle i in the reference parallelepiped and
    # off_i = w_i − r_i a lattice vector (−off_y_i L along y): a candidate pair then needs
    # no rounding, its image is fixed by the wrap T of the stencil cell, r_ij = w_i − (w_j + T).
    coords = np.empty((n, d), np.int64)
    cell_of = np.empty(n, np.int64)
    stride = np.empty(d, np.int64)
    w = np.empty((n, d), np.float64)
    off = np.empty((n, d), np.float64)
    off_y = np.empty(n, np.int64)
    total = 1
    for a in range(d):
        stride[a] = total
        total *= ncell[a]
    for i in range(n):
        sy = pos[i, 1] / L
        ky = np.floor(sy)
        sy -= ky
        sx = (pos[i, 0] - g * pos[i, 1]) / L
        sx -= np.floor(sx)
        w[i, 0] = (sx + g * sy) * L
        w[i, 1] = sy * L
        for a in range(2, d):
            sa = pos[i, a] / L
            w[i, a] = (sa - np.floor(sa)) * L
        for a in range(d):
            off[i, a] = w[i, a] - pos[i, a]
        off_y[i] = int(ky)
        c = 0
        for a in range(d):
            if a == 0:
                s = sx
            elif a == 1:
                s = sy
            else:
                s = w[i, a] / L
            k = int(s * ncell[a])
            if k >= ncell[a]:
                k = ncell[a] - 1
            coords[i, a] = k
            c += k * stride[a]
        cell_of[i] = c
    # counting sort of particles by cell
    cell_start = np.zeros(total + 1, np.int64)
    for i in range(n):
        cell_start[cell_of[i] + 1] += 1
    for c in range(total):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:-1].copy()
    members = np.empty(n, np.int64)
    for i in range(n):
        members[fill[cell_of[i]]] = i
        fill[cell_of[i]] += 1

    # Half stencil: the own cell (pairs j > i) and the 13 (in 3d) offsets whose last non-zero
    # component is +1; with >= 3 cells per axis every pair of adjacent cells is visited once.
    nfull = 3**d
    stencil = np.empty(((nfull + 1) // 2, d), np.int64)
    nstencil = 0
    for o in range(nfull):
        code = o
        last = 0
        for _a in range(d):
            v = (code % 3) - 1
            code //= 3
            if v != 0:
                last = v
        if last >= 0:
            code = o
            for a in range(d):
                stencil[nstencil, a] = (code % 3) - 1
                code //= 3
            nstencil += 1
    T = np.empty(d, np.float64)
    wi = np.empty(d, np.float64)
    for i in range(n):
        start[i] = m
        for a in range(d):
            wi[a] = w[i, a]
        for o in range(nstencil):
            c = 0
            own = True
            for a in range(d):
                T[a] = 0.0
                if stencil[o, a] != 0:
                    own = False
            wrap_y = 0
            for a in range(d):
                k = coords[i, a] + stencil[o, a]
                t = 0
                if k < 0:
                    k += ncell[a]
                    t = -1
                elif k >= ncell[a]:
                    k -= ncell[a]
                    t = 1
                c += k * stride[a]
                if t != 0:
                    if a == 1:
                        T[0] += t * g * L
                        T[1] += t * L
                        wrap_y = t
                    else:
                        T[a] += t * L
            for q in range(cell_start[c], cell_start[c + 1]):
                j = members[q]
                if own and j <= i:
                    continue
                r2 = 0.0
                for a in range(d):
                    u = wi[a] - w[j, a] - T[a]
                    r2 += u * u
                if r2 < rc2:
                    if m < cap:
                        nbr[m] = j
                        for a in range(d):
                            shift[m, a] = off[i, a] - off[j, a] - T[a]
                        img_y[m] = off_y[i] - off_y[j] + wrap_y
                    m += 1
    start[n] = m
    return m


@njit(cache=True)
def build_neighbor_list(pos, L, gamma, rc):
    """Half Verlet list of all pairs with ``|r_i − r_j + image| < rc`` (see module docstring).

    Returns ``(start, nbr, shift, img_y)``; ``start`` has ``N + 1`` entries.
    """
    n, d = pos.shape
    g = reduce_strain(gamma)
    rc2 = rc * rc
    ncell = np.empty(d, np.int64)
    ncell[0] = int(np.floor(L / (rc * np.sqrt(1.0 + g * g))))
    for a in range(1, d):
        ncell[a] = int(np.floor(L / rc))
    # cells need three per axis, and above d = 4 a stencil (3^d cells, each visited per particle)
    # no larger than N: a box of a few diameters in high d has 3^d cells and a few particles
    # (d = 12, N = 2: 49 s and 4 GB; d = 32 overflowed and crashed), where all pairs is cheaper
    use_cells = d <= 4 or 3.0**d <= n
    for a in range(d):
        if ncell[a] < 3:
            use_cells = False
    # a density estimate of the list size; the fill is redone once if it was too small (the
    # arrays are never reassigned inside a loop, which would cost reference counting per pair)
    cap = int(0.5 * n * (n / L**d) * (2.0 * rc) ** d * 0.8) + 4 * n + 16
    start = np.zeros(n + 1, np.int64)
    for _attempt in range(2):
        nbr = np.empty(cap, np.int64)
        shift = np.empty((cap, d), np.float64)
        img_y = np.empty(cap, np.int64)
        if use_cells:
            m = _fill_cells(pos, L, g, rc2, ncell, start, nbr, shift, img_y)
        else:
            m = _fill_all_pairs(pos, L, g, rc2, start, nbr, shift, img_y)
        if m <= cap:
            return start, nbr[:m].copy(), shift[:m].copy(), img_y[:m].copy()
        cap = m
    raise RuntimeError("neighbour list did not fit after resizing")


@njit(cache=True)
def shift_images(shift, built, img_y, dgamma, L):
    """In place, the shifts at ``Δγ`` from the list's build: ``shift_x = built_x − img_y Δγ L``
    (``built``: the shifts the build made). From the build, not from the last update: moved by
    increments, shifts collect a rounding per update, and a continuation that goes back and
    forth between two strains a thousand times moved them by ~1e-12 (``docs/aqs.md``, "A
    contact that chatters")."""
    for k in range(shift.shape[0]):
        shift[k, 0] = built[k, 0] - img_y[k] * dgamma * L


@njit(cache=True)
def max_nonaffine_displacement(pos, ref, dgamma):
    """``max_i |r_i − r_i^ref − Δγ y_i^ref e_x|``: the displacement the Verlet skin must absorb."""
    n, d = pos.shape
    best = 0.0
    for i in range(n):
        u2 = 0.0
        for a in range(d):
            u = pos[i, a] - ref[i, a]
            if a == 0:
                u -= dgamma * ref[i, 1]
            u2 += u * u
        if u2 > best:
            best = u2
    return np.sqrt(best)
