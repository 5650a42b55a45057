"""The lean elastic step: the chord iteration in the neighbour list's order, one fused kernel
per iterate (:func:`lean_step`)."""

from __future__ import annotations

import numpy as np

from jamlab.spheres import kernels as AK
from jamlab.spheres import kernels as K
from jamlab.spheres.aqs.linalg import Factor
from jamlab.spheres.aqs.network import affine_to, backbone_mask, contact_list, pair_keys
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.aqs.predictor import Secants
from jamlab.spheres.potential import NeighborList, Packing


def consistent_flags(
    packing: Packing, nl: NeighborList, fac: Factor, params: AQSParameters
) -> tuple[np.ndarray | None, int]:
    """Contact state of every neighbour-list slot at the minimum ``packing`` and the list's build
    number, once ``fac`` has been corrected for the contacts changed since its factorisation;
    ``(None, -1)`` when the corrected factor does not hold them (too many changes, or the
    corrected matrix not positive definite) or there is nothing to factorise."""
    if fac.lu is None or fac.free.size == 0:
        return None, -1
    fac.update(*contact_list(packing, nl), params.max_corrections)
    if fac.corr_keys is not None and fac.corr_keys.size and fac.w is None:
        return None, -1
    pos = nl.sorted(packing.positions)
    d = pos.shape[1]
    flags = np.empty(nl.nbr.size, dtype=np.uint8)
    AK.forces_virial_flags(
        pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha,
        np.empty_like(pos), np.empty((d, d)), flags, True,
    )
    return flags, nl.n_builds


def lean_step(
    cur: Packing,
    target: float,
    predictor: np.ndarray | None,
    nl: NeighborList,
    fac: Factor,
    flags: np.ndarray,
    prev: dict[str, float],
    ftol: float,
    params: AQSParameters,
    secants: Secants | None = None,
    affine: Packing | None = None,
) -> tuple[Packing, dict[str, float], int, tuple | None] | None:
    """The common elastic step in as few passes over the pairs as possible, or ``None``.

    The chord iteration of :func:`newton` (each step cutting ``max|F_b|`` by
    ``chord_contraction``, by ``contraction`` once a contact has changed in the step; at most
    ``max_chord`` steps), run in the neighbour list's particle
    order with one fused kernel per iterate (forces, virial and the contact state of every list
    slot, compared with ``flags``: the contacts of the minimum ``cur``, with which ``fac`` and
    its corrections are consistent). When a contact opens or closes at an iterate, the
    correction of ``fac`` is updated there (as :func:`newton` does) and the iteration goes on,
    provided the backbone stays the same and the corrected factor is positive definite (at most
    ``max_lean_changes`` times per step). A neighbour-list rebuild, a force left on a rattler,
    a trapezoid residual above ``energy_tol δγ²``, a chord step that does not contract, or a
    change of the backbone returns ``None``, and the general continuation
    (:func:`~jamlab.spheres.aqs.continuation.continue_network`) takes the step instead.

    Returns ``(minimum, row, chord steps, change)``; ``change`` is ``None`` when the contact
    set is that of ``cur``, else ``(flags, contact keys)`` of the new contact set.
    """
    if affine is None:
        affine = affine_to(cur, target)
    pos = affine.positions if predictor is None else affine.positions + predictor
    builds = nl.n_builds
    nl.update(pos, target)
    if nl.n_builds != builds:
        return None
    if fac.free_sorted is None:
        fac.free_sorted = nl.inverse[fac.free]
    free_s = fac.free_sorted
    n = cur.n
    d = pos.shape[1]
    z_nr = prev["z_nr"]
    change = None
    n_changes = 0

    def adopt(ps: np.ndarray) -> bool:
        # contacts opened or closed at this iterate: correct the factor for them
        nonlocal flags, change, z_nr, n_changes
        n_changes += 1
        if n_changes > params.max_lean_changes:
            return False
        ci, cj, cd = contact_list(affine.with_positions(nl.unsorted(ps)), nl)
        if nl.n_builds != builds:
            return False
        keep = backbone_mask(ci, cj, n, d)
        if not np.array_equal(keep, fac.backbone):
            return False
        fac.update(ci, cj, cd, params.max_corrections)
        if fac.corr_keys is not None and fac.corr_keys.size and fac.w is None:
            return False
        flags = np.empty_like(flags)
        AK.forces_virial_flags(
            ps, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha,
            np.empty_like(ps), np.empty((d, d)), flags, True,
        )
        n_kept = int(keep.sum())
        z_nr = 2.0 * int((keep[ci] & keep[cj]).sum()) / n_kept
        change = (flags, np.sort(pair_keys(ci, cj, n)))
        return True

    def at(x: np.ndarray) -> tuple[tuple, int]:
        # one pass: (x, F, S, E, N_c, F on the free particles, its max) and the contact changes
        fx = np.empty_like(x)
        sx = np.empty((d, d))
        ex, ncx, ch = AK.forces_virial_flags(
            x, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha, fx, sx, flags, False
        )
        return (x, fx, sx, ex, ncx, AK.gather_rows(fx, free_s), AK.rows_max_norm(fx, free_s)), ch

    state, changed = at(nl.sorted(pos))
    if changed and not adopt(state[0]):
        return None
    its = 0
    while not state[6] < ftol:
        ps, fb, fmax = state[0], state[5], state[6]
        if (
            secants is not None
            and fmax < params.secant_reach * ftol
            and (dx := secants.correction(fb)) is not None
        ):
            # first without a solve: the part of the residual the recent chord steps explain
            trial, changed = at(AK.moved(ps, free_s, dx))
            if not changed and trial[6] < params.contraction * fmax:
                state = trial
                if trial[6] < ftol:
                    break
                ps, fb, fmax = state[0], state[5], state[6]
        if its == params.max_chord:
            return None
        dx = fac.solve(fb.ravel()).reshape(free_s.size, d)
        trial, changed = at(AK.moved(ps, free_s, dx))
        its += 1
        tmax = trial[6]
        # after a contact change in this step the rank-one correction is exact only at zero
        # overlap and the new contact stiffens as it closes: contraction by `contraction` then
        required = params.contraction if n_changes else params.chord_contraction
        if not (tmax < required * fmax or (tmax < ftol and tmax < params.contraction * fmax)):
            return None
        if changed and not adopt(trial[0]):
            return None
        if secants is not None:
            secants.push(dx, fb - trial[5])
        state = trial
    ps, f, s, e, n_c = state[:5]
    # the list must still hold every pair at the final positions (NeighborList.update's test)
    dg = target - nl.ref_strain
    if not 2.0 * K.max_nonaffine_displacement(ps, nl.ref, dg) < nl.skin - abs(dg) * nl.cutoff:
        return None
    positions = nl.unsorted(ps)
    max_force = float(K.max_force(f))
    if not max_force < ftol:  # a rattler (or the pinned particle) to relax: general path
        return None
    row = {
        "energy": float(e),
        "shear_stress": float(s[0, 1]),
        "pressure": float(-np.trace(s) / (d * cur.box.volume)),
        "z": 2.0 * n_c / n,
        "z_nr": z_nr,
        "max_force": max_force,
    }
    r = (
        row["energy"]
        - prev["energy"]
        - 0.5 * (target - prev["gamma"]) * (prev["shear_stress"] + row["shear_stress"])
    )
    if abs(r) > params.energy_tol * (target - prev["gamma"]) ** 2:
        return None
    fac.fresh = False
    return affine.with_positions(positions), row, its, change
