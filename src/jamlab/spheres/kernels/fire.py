"""The compiled FIRE loop (:func:`fire`) and its force statistics."""

from __future__ import annotations

import numpy as np
from numba import njit

from jamlab.spheres.kernels.geometry import build_neighbor_list, wrap_positions
from jamlab.spheres.kernels.pairs import energy_forces_any


@njit(cache=True)
def _stats_and_kick(f, v, w, dt):
    """``(max_i |F_i|², Σ_i F_i·F_i, P = Σ_i F_i·v_i)`` and, in the same pass, the velocity
    ``w = v + Δt F`` of FIRE's next step if that step makes no restart (``P > 0``), with
    ``(Σ_i |w_i|², max_i |w_i|²)``.

    Every sum runs over the particles in order, as the separate passes it replaces did (the same
    bits), except ``P``, whose sign alone is used: in 3D its three components are summed
    separately and added at the end (three short dependency chains instead of one long one, the
    slowest part of the pass), which can change the last bits of ``P`` and so a decision only
    where ``|P|`` is at rounding level of ``Σ_i |F_i·v_i|``."""
    n, d = f.shape
    fmax2 = 0.0
    ff = 0.0
    p0 = 0.0
    p1 = 0.0
    p2 = 0.0
    vv = 0.0
    vmax2 = 0.0
    if d == 3:
        for i in range(n):
            f0 = f[i, 0]
            f1 = f[i, 1]
            f2 = f[i, 2]
            s = f0 * f0 + f1 * f1 + f2 * f2
            v0 = v[i, 0]
            v1 = v[i, 1]
            v2 = v[i, 2]
            p0 += f0 * v0
            p1 += f1 * v1
            p2 += f2 * v2
            ff += s
            if s > fmax2:
                fmax2 = s
            w0 = v0 + dt * f0
            w1 = v1 + dt * f1
            w2 = v2 + dt * f2
            w[i, 0] = w0
            w[i, 1] = w1
            w[i, 2] = w2
            t = w0 * w0 + w1 * w1 + w2 * w2
            vv += t
            if t > vmax2:
                vmax2 = t
        return fmax2, ff, p0 + p1 + p2, vv, vmax2
    p = 0.0
    for i in range(n):
        s = 0.0
        t = 0.0
        for a in range(d):
            s += f[i, a] * f[i, a]
            p += f[i, a] * v[i, a]
            x = v[i, a] + dt * f[i, a]
            w[i, a] = x
            t += x * x
        ff += s
        if s > fmax2:
            fmax2 = s
        vv += t
        if t > vmax2:
            vmax2 = t
    return fmax2, ff, p, vv, vmax2


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

    The kick ``v += Δt F`` of a step without restart is made in the force pass before it, with
    the ``Δt`` that step will take (:func:`_stats_and_kick`; after a restart it is made again
    from ``v = 0``): one pass over the particles fewer per step.

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
    w = np.zeros((n, d), np.float64)
    e = energy_forces_any(pos, start, nbr, shift, diam, pair_alpha, f, branch_free_pairs)
    # (v = 0: P = 0, so the first step is a restart and does not use the kick made here)
    fmax2, ff, p, vv_next, vmax2_next = _stats_and_kick(f, v, w, dt0)
    ftol2 = ftol * ftol
    dt = dt0
    alpha = alpha0
    n_pos = 0
    n_neg = 0
    it = 0
    n_rebuild = 0
    rc = sigma_max + skin
    half_budget2 = 0.25 * budget * budget
    # two passes over the particles per step besides the forces (mix-and-move; the force
    # statistics with the next kick ``v += Δt F``), three after a restart (the kick again)
    while fmax2 >= ftol2 and it < max_iter:
        it += 1
        if p > 0.0:
            n_pos += 1
            n_neg = 0
            if n_pos > n_delay:
                dt = min(dt * f_inc, dt_max)
                alpha *= f_alpha
            # the kick v += Δt F was made with this Δt in the last force pass
            v, w = w, v
            vv = vv_next
            vmax2 = vmax2_next
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
            # semi-implicit Euler: v += Δt F (after a restart; otherwise made above), then mix
            # and move
            vv = 0.0
            vmax2 = 0.0
            if d == 3:
                for i in range(n):
                    w0 = v[i, 0] + dt * f[i, 0]
                    w1 = v[i, 1] + dt * f[i, 1]
                    w2 = v[i, 2] + dt * f[i, 2]
                    v[i, 0] = w0
                    v[i, 1] = w1
                    v[i, 2] = w2
                    s = w0 * w0 + w1 * w1 + w2 * w2
                    vv += s
                    if s > vmax2:
                        vmax2 = s
            else:
                for i in range(n):
                    s = 0.0
                    for a in range(d):
                        x = v[i, a] + dt * f[i, a]
                        v[i, a] = x
                        s += x * x
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
        if d == 3:
            for i in range(n):
                w0 = c1 * v[i, 0] + c2 * f[i, 0]
                w1 = c1 * v[i, 1] + c2 * f[i, 1]
                w2 = c1 * v[i, 2] + c2 * f[i, 2]
                v[i, 0] = w0
                v[i, 1] = w1
                v[i, 2] = w2
                x0 = pos[i, 0] + step * w0
                x1 = pos[i, 1] + step * w1
                x2 = pos[i, 2] + step * w2
                pos[i, 0] = x0
                pos[i, 1] = x1
                pos[i, 2] = x2
                u0 = x0 - ref[i, 0]
                u1 = x1 - ref[i, 1]
                u2 = x2 - ref[i, 2]
                if u0 * u0 + u1 * u1 + u2 * u2 >= half_budget2:
                    need = True
        else:
            for i in range(n):
                u2 = 0.0
                for a in range(d):
                    y = c1 * v[i, a] + c2 * f[i, a]
                    v[i, a] = y
                    x = pos[i, a] + step * y
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
        # the next kick, made now with the Δt a step without restart will take
        dt_next = min(dt * f_inc, dt_max) if n_pos + 1 > n_delay else dt
        fmax2, ff, p, vv_next, vmax2_next = _stats_and_kick(f, v, w, dt_next)
    fmax = np.sqrt(fmax2)
    return it, fmax, fmax < ftol, e, n_rebuild, start, nbr, shift, img_y, ref
