"""Numba kernels for harmonic soft spheres under Lees–Edwards shear, any dimension ``d >= 2``.

Pair potential (``SPEC.md`` §3): ``V(r) = (1 − r)²`` for ``r < 1``, else 0, so
``V'(r) = −2(1 − r)`` and ``V''(r) = 2`` inside the cut-off.

Neighbour list
--------------
A half Verlet list in CSR form (each pair once): the partners of particle ``i`` are
``nbr[start[i]:start[i+1]]``; ``shift[k]`` is the Cartesian periodic-image vector of pair ``k``,
so that ``r_ij = r_i − r_j + shift[k]``, and ``img_y[k] = −shift[k, y]/L`` counts its ``y``
crossings. It
contains every pair closer than ``rc = 1 + skin`` when built. Under an affine strain step
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

from jamlab.spheres.pair import pair_sigma, pair_terms

# ------------------------------------------------------------------------------------------------
# periodic geometry


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
    use_cells = True
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
def shift_images(shift, img_y, dgamma, L):
    """In place, after an affine strain step ``Δγ``: ``shift_x −= img_y Δγ L``."""
    for k in range(shift.shape[0]):
        shift[k, 0] -= img_y[k] * dgamma * L


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


# ------------------------------------------------------------------------------------------------
# energy, forces, stress


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
def energy_forces_any(pos, start, nbr, shift, diam, alpha, forces):
    """Dispatch to the unrolled ``d = 2, 3`` kernels, the generic one otherwise."""
    d = pos.shape[1]
    if d == 3:
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


# ------------------------------------------------------------------------------------------------
# FIRE


@njit(cache=True)
def _force_stats(f, v):
    """``(max_i |F_i|², Σ_i F_i·F_i, Σ_i F_i·v_i)`` in one pass."""
    n, d = f.shape
    fmax2 = 0.0
    ff = 0.0
    p = 0.0
    for i in range(n):
        s = 0.0
        for a in range(d):
            s += f[i, a] * f[i, a]
            p += f[i, a] * v[i, a]
        ff += s
        if s > fmax2:
            fmax2 = s
    return fmax2, ff, p


@njit(cache=True)
def fire(
    pos,
    L,
    gamma,
    skin,
    sigma_max,
    budget,
    start,
    nbr,
    shift,
    img_y,
    ref,
    diam,
    pair_alpha,
    ftol,
    max_iter,
    dt0,
    dt_max,
    dt_min,
    n_delay,
    f_inc,
    f_dec,
    alpha0,
    f_alpha,
    n_negative_max,
    dmax,
    fire2,
):
    """FIRE minimisation of ``E`` at fixed strain, entirely in compiled code; ``pos`` in place.

    FIRE 2.0 (Guénolé et al., Comput. Mater. Sci. 175, 109584 (2020), Algorithm 2), unit masses,
    semi-implicit Euler:

        P = F·v
        P > 0: N⁺ += 1; if N⁺ > N_delay: Δt = min(f_inc Δt, Δt_max), α = f_α α
        P ≤ 0: N⁻ += 1 (stop if N⁻ > N⁻_max); unless i < N_delay: Δt = max-guarded f_dec Δt,
               α = α₀; x −= Δt v / 2; v = 0
        v += Δt F;  v = (1 − α) v + α |v| F/|F|;  x += Δt v

    The step is shortened so that no particle moves more than ``dmax`` (using the bound
    ``|v_i| ≤ (1 − α) max|v| + α |v| max|F|/|F|``).

    ``fire2 = False`` gives Bitzek et al., PRL 97, 170201 (2006): no initial delay and no half
    step back. Converged when ``max_i |F_i| < ftol``. The neighbour list (``start, nbr, shift,
    img_y``, valid while ``2 max|r − ref| < budget``, ``budget = skin − |Δγ| rc`` after strain
    steps since its build) is rebuilt, with ``budget = skin``, as soon as that fails.

    The pair law is ``diam`` (list order) and ``pair_alpha`` (:mod:`jamlab.spheres.pair`); the
    list holds pairs closer than ``rc = sigma_max + skin``.

    Returns ``(iterations, max_force, converged, energy, n_rebuilds, start, nbr, shift, img_y,
    ref)``.
    """
    n, d = pos.shape
    f = np.empty((n, d), np.float64)
    v = np.zeros((n, d), np.float64)
    e = energy_forces_any(pos, start, nbr, shift, diam, pair_alpha, f)
    fmax2, ff, p = _force_stats(f, v)
    ftol2 = ftol * ftol
    dt = dt0
    alpha = alpha0
    n_pos = 0
    n_neg = 0
    it = 0
    n_rebuild = 0
    rc = sigma_max + skin
    half_budget2 = 0.25 * budget * budget
    # three passes over the particles per step (velocity, mix-and-move, forces + statistics)
    while fmax2 >= ftol2 and it < max_iter:
        it += 1
        if p > 0.0:
            n_pos += 1
            n_neg = 0
            if n_pos > n_delay:
                dt = min(dt * f_inc, dt_max)
                alpha *= f_alpha
        else:
            n_pos = 0
            n_neg += 1
            if n_neg > n_negative_max:
                break
            if not (fire2 and it < n_delay):
                if dt * f_dec >= dt_min:
                    dt *= f_dec
                alpha = alpha0
            if fire2:
                for i in range(n):
                    for a in range(d):
                        pos[i, a] -= 0.5 * dt * v[i, a]
            v[:, :] = 0.0
        # semi-implicit Euler: v += Δt F, then mix and move
        vv = 0.0
        vmax2 = 0.0
        for i in range(n):
            s = 0.0
            for a in range(d):
                w = v[i, a] + dt * f[i, a]
                v[i, a] = w
                s += w * w
            vv += s
            if s > vmax2:
                vmax2 = s
        if ff > 0.0:
            c1 = 1.0 - alpha
            c2 = alpha * np.sqrt(vv / ff)
        else:
            c1 = 1.0
            c2 = 0.0
        step = dt
        if dmax > 0.0:
            # |c1 v_i + c2 F_i| <= c1 max|v| + c2 max|F| bounds every particle's displacement
            bound = c1 * np.sqrt(vmax2) + c2 * np.sqrt(fmax2)
            if dt * bound > dmax:
                step = dmax / bound
        need = False
        for i in range(n):
            u2 = 0.0
            for a in range(d):
                w = c1 * v[i, a] + c2 * f[i, a]
                v[i, a] = w
                x = pos[i, a] + step * w
                pos[i, a] = x
                u = x - ref[i, a]
                u2 += u * u
            if u2 >= half_budget2:
                need = True
        if need:
            wrap_positions(pos, L, gamma)
            start, nbr, shift, img_y = build_neighbor_list(pos, L, gamma, rc)
            ref[:, :] = pos
            n_rebuild += 1
            half_budget2 = 0.25 * skin * skin
        e = energy_forces_any(pos, start, nbr, shift, diam, pair_alpha, f)
        fmax2, ff, p = _force_stats(f, v)
    fmax = np.sqrt(fmax2)
    return it, fmax, fmax < ftol, e, n_rebuild, start, nbr, shift, img_y, ref
