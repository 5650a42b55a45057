"""Continuation of the branch of a minimum through a strain step, event-driven on the contact
network (:func:`continue_network`), with its positive-definiteness test at a contact switch
(:func:`switch_keeps_pd`) and the relaxation of the rattlers at the end (:func:`relax_rattlers`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamlab.spheres.aqs.linalg import (
    ND_MIN_FREE,
    Factor,
    capacitance_keeps_pd,
    factorise,
    hessian_matrix,
    pcg,
)
from jamlab.spheres.aqs.network import (
    affine_to,
    backbone_mask,
    contact_list,
    network_forces,
    pair_keys,
)
from jamlab.spheres.aqs.newton import NetworkModel, damped_newton
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.pair import pair_sigmas
from jamlab.spheres.potential import NeighborList, Packing

CHATTER_SWITCHES = 8
"""A pair switched more than this many times at one strain ends the branch (``docs/aqs.md``,
"A contact that chatters"). At a strain where the network with the pair puts it in tension and
the network without it overlaps it, no contact set is consistent: the continuation switched
the pair in and out until ``max_events`` (1000) ended the branch, ≈ 14 ms per switch at N =
1000. Ending it after a few switches gives the same verdict, and FIRE the same start."""


@dataclass(frozen=True, eq=False)
class Branch:
    """Outcome of :func:`continue_network`: the continued minimum (``None``: the branch ends
    inside the step), the factorisation it ended with, Newton and CG iterations, accepted
    substeps, factorisations made and contact-set switches."""

    packing: Packing | None  # None: the branch ends inside the step
    factor: Factor | None
    iterations: int
    cg_iterations: int
    substeps: int
    refactorised: int
    events: int = 0  # contact-set switches


def switch_keeps_pd(
    cur: Packing,
    ci: np.ndarray,
    cj: np.ndarray,
    fac: Factor,
    pi: np.ndarray,
    pj: np.ndarray,
    signs: np.ndarray,
    params: AQSParameters,
) -> tuple[bool, int]:
    """Whether ``K' = K + U S Uᵀ`` is positive definite, ``K`` the network Hessian of the pairs
    ``(ci, cj)`` at ``cur``, ``U`` the columns ``b`` (``+n`` on ``i``, ``−n`` on ``j``, free
    particles only) of the switched pairs ``(pi, pj)``, ``S = diag(2 · signs / σ²)`` (the
    harmonic contact stiffness at zero overlap; the caller uses this only for ``α = 2``).

    With ``K`` positive definite (PCG meeting no negative curvature), ``K'`` is iff the
    capacitance ``C = S⁻¹ + Uᵀ K⁻¹ U`` has as many positive eigenvalues as pairs added (Haynsworth
    inertia additivity, as in :class:`Factor`); ``K⁻¹ U`` by PCG preconditioned by ``fac`` to a
    relative residual ``1e-12``. Returns ``(positive definite, CG iterations)``."""
    d = cur.dim
    free_index, n_free = fac.free_index, fac.free.size
    _, dr, _ = network_forces(cur, ci, cj)
    k = hessian_matrix(ci, cj, dr, fac)
    sep = cur.box.minimum_image(cur.positions[pi] - cur.positions[pj])
    sep /= np.sqrt(np.einsum("ij,ij->i", sep, sep))[:, None]
    u = np.zeros((n_free * d, pi.size))
    for c in range(pi.size):
        for particle, sign in ((pi[c], 1.0), (pj[c], -1.0)):
            f = free_index[particle]
            if f >= 0:
                u[d * f : d * f + d, c] = sign * sep[c]
    z = np.empty_like(u)
    cg = 0
    for c in range(pi.size):
        scale = float(np.max(np.abs(u[:, c])))
        if scale == 0.0:  # both ends held: the pair does not enter K
            z[:, c] = 0.0
            continue
        x, ok, its = pcg(k, u[:, c], fac.solve, 1e-12 * scale, 10 * params.max_cg, d)
        cg += its
        if not ok:
            return False, cg
        z[:, c] = x
    sig = pair_sigmas(cur.diameters, pi, pj)
    c_mat = np.diag(0.5 * (sig * sig) / signs) + u.T @ z
    return capacitance_keeps_pd(c_mat, int(np.count_nonzero(signs > 0))), cg


def relax_rattlers(
    packing: Packing, nl: NeighborList, backbone: np.ndarray, ftol: float, max_iter: int = 100
) -> Packing | None:
    """Move the rattlers (``~backbone``) out of their overlaps, the backbone held.

    The event-driven continuation treats rattlers as ghosts, so at its end they may overlap the
    backbone by ~δγ. Each iteration moves every rattler by the mean over its contacts of
    ``(σ − r) n`` (the displacement that empties one contact; half of it for a pair of
    rattlers). Done when no contact touches a rattler (their forces, and theirs on the
    backbone, are then exactly zero) or all such forces are below ``ftol``; ``None`` if not
    within ``max_iter`` (a caged "rattler": the caller's FIRE then relaxes everything).
    """
    rattler = ~backbone
    if not rattler.any():
        return packing
    pos = np.array(packing.positions)
    n, d = pos.shape
    for _ in range(max_iter):
        cur = packing.with_positions(pos)
        ci, cj, _ = contact_list(cur, nl)
        touch = rattler[ci] | rattler[cj]
        if not touch.any():
            return cur
        ci, cj = ci[touch], cj[touch]
        dr = cur.box.minimum_image(pos[ci] - pos[cj])
        r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
        push = ((pair_sigmas(cur.diameters, ci, cj) - r) / r)[:, None] * dr  # on i; −push on j
        if 2.0 * float(np.max(np.sqrt(np.einsum("ij,ij->i", push, push)))) < ftol:
            return cur
        both = rattler[ci] & rattler[cj]
        share = np.where(both, 0.5, 1.0)[:, None] * push
        move = np.zeros((n, d))
        count = np.bincount(ci[rattler[ci]], minlength=n) + np.bincount(
            cj[rattler[cj]], minlength=n
        )
        for a in range(d):
            move[:, a] = np.bincount(ci, share[:, a] * rattler[ci], minlength=n) - np.bincount(
                cj, share[:, a] * rattler[cj], minlength=n
            )
        moving = count > 0
        pos[moving] += move[moving] / count[moving, None]
    return None


def _overlaps(packing: Packing, pi: np.ndarray, pj: np.ndarray) -> np.ndarray:
    """``σ − r`` of the pairs ``(pi, pj)``."""
    dr = packing.box.minimum_image(packing.positions[pi] - packing.positions[pj])
    return pair_sigmas(packing.diameters, pi, pj) - np.sqrt(np.einsum("ij,ij->i", dr, dr))


def continue_network(
    start: Packing,
    fac: Factor | None,
    strain: float,
    nl: NeighborList,
    ftol: float,
    params: AQSParameters,
    first_substep: float = 1.0,
    predictor: np.ndarray | None = None,
) -> Branch:
    """Follow the minimum ``start`` to ``strain`` event by event (``docs/aqs.md``).

    Between contact changes the branch is the minimum of the smooth network energy ``E_C`` of
    the current contact set ``C`` (backbone pairs; rattlers are ghosts, moved out of their
    overlaps at the end by :func:`relax_rattlers`). A substep whose end is consistent (every
    pair of ``C`` still compressed, no new overlap between backbone particles) is accepted;
    otherwise the first crossing inside it is located by interpolating the overlaps linearly in
    ``γ`` and stepping there (a landing that stops short of it aims next at the secant
    extrapolation of the same pairs' overlaps, not at a doubled substep), and once it is within
    ``event_tol · δγ`` the set is switched
    (pairs removed or added at zero force) and the backbone recomputed (a particle left with
    ``d`` contacts is a rattler). The branch ends when the network Hessian after a switch is not
    positive definite (a fresh factorisation if the free set changed or is small, else
    :func:`switch_keeps_pd`), or when Newton fails even at substeps below ``min_substep`` of
    the step. ``fac`` (may be ``None``) preconditions the solves if it has the same backbone.
    """
    n, dim = start.n, start.dim
    its = cg = substeps = refac = events = calls = 0
    ci, cj, cd = contact_list(start, nl)
    backbone = backbone_mask(ci, cj, n, dim)
    live = backbone[ci] & backbone[cj]
    ci, cj = ci[live], cj[live]

    def network_factor(packing: Packing) -> Factor | None:
        nonlocal refac
        _, dr, _ = network_forces(packing, ci, cj)
        refac += 1
        fac = factorise(packing, nl, backbone, (ci, cj, dr), positive_only=True)
        return fac if fac.lu is not None and fac.positive_definite else None

    def ended() -> Branch:
        return Branch(None, None, its, cg, substeps, refac, events)

    if (
        fac is None
        or fac.lu is None
        or not fac.positive_definite
        or not np.array_equal(fac.backbone, backbone)
    ):
        fac = network_factor(start)
        if fac is None:
            return ended()
    # else: the caller's factorisation (same backbone, positive definite at a nearby minimum)
    # preconditions the solves until the first event
    g0 = start.strain
    total = strain - g0
    cur = start
    h = first_substep * total
    tol = params.event_tol * abs(total)  # a crossing this close (in strain) is switched at
    aim = None  # a crossing being landed on: (pairs i, j, how many opening, overlaps, at strain)
    failed = None  # the nearest strain Newton failed to reach on the current contact set
    switched_at, switches = None, {}  # switches of each pair at the strain switched_at
    while True:
        if calls > 10 * params.max_events:
            return ended()  # pathological (never seen in practice): FIRE takes the step
        g = cur.strain
        last = g + h >= strain - 1e-9 * abs(total)
        target = strain if last else g + h
        trial = affine_to(cur, target)
        if predictor is not None and g == g0 and last:
            trial = trial.with_positions(trial.positions + predictor)
        # the factor corrected (Woodbury) for the pairs where the network differs from the
        # factor's contacts (switched ones, rattlers' contacts)
        fac.update(ci, cj, trial.box.minimum_image(trial.positions[ci] - trial.positions[cj]),
                   params.max_corrections)
        res = damped_newton(trial, fac.free, NetworkModel(ci, cj, fac), fac.solve, ftol, params)
        new, it_n, cg_n = res.packing if res.ok else None, res.iterations, res.cg_iterations
        calls += 1
        its += it_n
        cg += cg_n
        if new is None:
            aim = None
            failed = target if failed is None else min(failed, target)
            h *= 0.5
            if h < params.min_substep * abs(total):
                return ended()
            continue
        # consistency at the new point: pairs of C compressed, no new backbone overlaps
        _, _, r_new = network_forces(new, ci, cj)
        opening = np.flatnonzero(r_new >= pair_sigmas(new.diameters, ci, cj))
        ai, aj, _ = contact_list(new, nl)
        both = backbone[ai] & backbone[aj]
        ai, aj = ai[both], aj[both]
        keys_c = np.sort(pair_keys(ci, cj, n))
        keys_a = pair_keys(ai, aj, n)
        fresh_pairs = ~np.isin(keys_a, keys_c, assume_unique=False)
        ai, aj = ai[fresh_pairs], aj[fresh_pairs]
        if opening.size == 0 and ai.size == 0:
            cur = new
            substeps += 1
            if last:
                relaxed = relax_rattlers(cur, nl, backbone, ftol)
                return Branch(
                    cur if relaxed is None else relaxed, fac, its, cg, substeps, refac, events
                )
            if aim is None:
                h = min(2.0 * h, strain - cur.strain)
                if failed is not None and cur.strain >= failed:
                    failed = None
                elif failed is not None:
                    # not beyond a strain Newton already failed to reach: bisect towards it, and
                    # once it is within twice the smallest substep, retry it (a failure then
                    # ends the branch, as before; halving alone would approach it forever)
                    gap = failed - cur.strain
                    h = min(h, 0.5 * gap if gap >= 2.0 * params.min_substep * abs(total) else gap)
                continue
            # a landing on a crossing stopped short of it: the crossing lies just ahead, at the
            # secant extrapolation of the aimed pairs' overlaps (at the landing's start and here)
            pi, pj, n_open, o_a, g_a = aim
            o_b = _overlaps(cur, pi, pj)
            with np.errstate(divide="ignore", invalid="ignore"):
                ahead = o_b * (cur.strain - g_a) / (o_a - o_b)  # > 0: approaching zero
            ahead = np.where(np.isfinite(ahead) & (ahead > 0.0), ahead, np.inf)
            now = ahead <= tol
            if not now.any():
                aim = (pi, pj, n_open, o_b, cur.strain)
                h = min(float(ahead.min()), strain - cur.strain)
                continue
            # within tol of the crossing: switch here
        else:
            # an event inside (g, target]: overlaps o = σ − r at both ends, crossing by
            # interpolation
            pi = np.concatenate([ci[opening], ai])
            pj = np.concatenate([cj[opening], aj])
            n_open = opening.size
            o_a, o_b = _overlaps(cur, pi, pj), _overlaps(new, pi, pj)
            with np.errstate(divide="ignore", invalid="ignore"):
                theta = np.nan_to_num(np.clip(o_a / (o_a - o_b), 0.0, 1.0), nan=0.0)
            span = target - g
            first = float(theta.min())
            if first * span <= tol:
                now = theta * span <= tol  # crossing at cur: switch there
            elif np.all((1.0 - theta) * span <= tol):
                cur = new  # every crossing at the end of the substep: accept it, switch there
                substeps += 1
                now = np.ones(theta.size, dtype=bool)
            else:
                h = first * span  # step to (about) the first crossing
                aim = (pi, pj, n_open, o_a, g)
                continue
        aim = failed = None
        events += 1
        if events > params.max_events:
            # events piling up: the branch is declared ended and FIRE takes the step (the
            # substep continuation did it until issue 14)
            return ended()
        # switch at cur: the pairs crossing here leave (opening) or join (closing) the set
        drop = pair_keys(pi[:n_open][now[:n_open]], pj[:n_open][now[:n_open]], n)
        add_i, add_j = pi[n_open:][now[n_open:]], pj[n_open:][now[n_open:]]
        if cur.strain != switched_at:
            switched_at, switches = cur.strain, {}
        for key in np.concatenate([drop, pair_keys(add_i, add_j, n)]).tolist():
            switches[key] = switches.get(key, 0) + 1
            if switches[key] > CHATTER_SWITCHES:
                return ended()  # the pair chatters: no consistent contact set at this strain
        keep = ~np.isin(pair_keys(ci, cj, n), drop)
        old_ci, old_cj, old_backbone = ci, cj, backbone
        ci = np.concatenate([ci[keep], add_i])
        cj = np.concatenate([cj[keep], add_j])
        backbone = backbone_mask(ci, cj, n, dim)
        live = backbone[ci] & backbone[cj]
        ci, cj = ci[live], cj[live]
        if not backbone.any():
            return ended()
        if (
            fac.free.size >= ND_MIN_FREE
            and cur.alpha == 2.0
            and np.array_equal(backbone, old_backbone)
        ):
            # same free set: K changes by ±2 b bᵀ per switched pair (zero force at the switch),
            # and its positive definiteness follows from the old K's by inertia additivity
            # (small free sets are refactorised instead: cheaper there)
            signs = np.where(np.arange(pi.size) < n_open, -1.0, 1.0)[now]
            pd, _ = switch_keeps_pd(cur, old_ci, old_cj, fac, pi[now], pj[now], signs, params)
            if not pd:
                return ended()  # the network lost positive definiteness at the event: unstable
        else:
            fac = network_factor(cur)  # the free set changed (a particle became a rattler or not)
            if fac is None:
                return ended()
        h = strain - cur.strain  # (0 at the end: re-converge there with the new set)
