"""The compiled FIRE loop (:func:`fire`) and its force statistics."""

from __future__ import annotations

import numpy as np
from numba import njit

from jamlab.spheres.kernels.geometry import build_neighbor_list, wrap_positions
from jamlab.spheres.kernels.pairs import energy_forces_any


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
    branch_free_pairs,
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
    list holds pairs closer than ``rc = sigma_max + skin``. Lists longer than
    ``branch_free_pairs`` take the branch-free force kernel (the same bits;
    :mod:`jamlab.spheres.kernel_choice`).

    Returns ``(iterations, max_force, converged, energy, n_rebuilds, start, nbr, shift, img_y,
    ref)``.
    """
    n, d = pos.shape
    f = np.empty((n, d), np.float64)
    v = np.zeros((n, d), np.float64)
    e = energy_forces_any(pos, start, nbr, shift, diam, pair_alpha, f, branch_free_pairs)
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
            # an explicit copy: the array-to-array slice assignment ``ref[:, :] = pos`` would
            # compile numba's broadcasting machinery (~3 s on first use, see bench_coldstart)
            for i in range(n):
                for a in range(d):
                    ref[i, a] = pos[i, a]
            n_rebuild += 1
            half_budget2 = 0.25 * skin * skin
        e = energy_forces_any(pos, start, nbr, shift, diam, pair_alpha, f, branch_free_pairs)
        fmax2, ff, p = _force_stats(f, v)
    fmax = np.sqrt(fmax2)
    return it, fmax, fmax < ftol, e, n_rebuild, start, nbr, shift, img_y, ref
