"""Damped Newton on the free backbone, preconditioned by the stored factorisation."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from jamlab.spheres import _aqs_kernels as AK
from jamlab.spheres.aqs.linalg import Factor, backbone_matrix, max_norm, pcg
from jamlab.spheres.aqs.network import contact_list, network_forces
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.potential import NeighborList, Packing, energy_and_forces


@dataclass(frozen=True, eq=False)
class NewtonResult:
    packing: Packing
    ok: bool
    iterations: int
    cg_iterations: int


def newton(
    start: Packing, nl: NeighborList, fac: Factor, ftol: float, params: AQSParameters
) -> NewtonResult:
    """Damped Newton ``x ← x + α K(x)⁻¹ F_b(x)`` on the free backbone until ``max |F_b| < ftol``.

    Each solve is PCG preconditioned with the factorisation ``fac``; ``α ∈ {1, ½, ¼, ⅛}`` is the
    first that lowers ``max |F_b|`` (a contact that opens or closes makes the Hessian jump and the
    full step overshoot; the damping stops the iteration from cycling between contact sets).
    Fails (tests: module docstring) when no ``α`` lowers the force, when more than
    ``max_strikes`` iterations from the second on do not contract by ``contraction``, when the
    corrections leave the linear-response basin, on negative curvature, or after
    ``max_newton`` iterations.
    """
    pos = np.array(start.positions)
    free = fac.free
    d = start.dim
    linear = 0.0
    correction = np.zeros((free.size, d))
    cg_total = 0
    strikes = 0
    current = start.with_positions(pos)
    f = energy_and_forces(current, nl)[1][free]
    fmax = max_norm(f)
    prev = math.inf
    # cheap first: chord steps x ← x + M⁻¹ F_b with the stored factorisation M ≈ K; accepted only
    # while each contracts the force by the factor chord_contraction (M⁻¹K ≈ 1 on the excited
    # modes, i.e. the branch is as stable as where M was taken), else full Newton below
    chord_pos, chord_f, chord_fmax = pos, f, fmax
    for chord in range(params.max_chord):
        if chord_fmax < ftol:
            return NewtonResult(start.with_positions(chord_pos), True, chord, 0)
        # the preconditioner follows the contacts that opened or closed since it was factorised
        fac.update(*contact_list(start.with_positions(chord_pos), nl), params.max_corrections)
        trial_pos = chord_pos.copy()
        trial_pos[free] += fac.solve(chord_f.ravel()).reshape(free.size, d)
        trial_f = energy_and_forces(start.with_positions(trial_pos), nl)[1][free]
        trial_fmax = max_norm(trial_f)
        if not trial_fmax < params.chord_contraction * chord_fmax:
            if trial_fmax < ftol and trial_fmax < params.contraction * chord_fmax:
                # converged, though M⁻¹K is only roughly 1 here (a contact changed in the step)
                return NewtonResult(start.with_positions(trial_pos), True, chord + 1, 0)
            break
        chord_pos, chord_f, chord_fmax = trial_pos, trial_f, trial_fmax
    else:
        if chord_fmax < ftol:
            return NewtonResult(start.with_positions(chord_pos), True, params.max_chord, 0)
    for it in range(params.max_newton + 1):
        if fmax < ftol:
            return NewtonResult(current, True, it, cg_total)
        if it == params.max_newton:
            break
        if it >= 2 and fmax > params.contraction * prev:
            strikes += 1
            if strikes > params.max_strikes:
                break
        prev = fmax
        contacts = contact_list(current, nl)
        k = backbone_matrix(current, nl, fac, contacts)
        fac.update(*contacts, params.max_corrections)
        # the next force check decides; 0.25 ftol leaves room for the O(dx²) remainder
        atol = max(0.25 * ftol, 1e-9 * fmax)
        dx, ok, cg_its = pcg(k, f.ravel(), fac.solve, atol, params.max_cg, d)
        cg_total += cg_its
        if not ok:
            break
        dx = dx.reshape(free.size, d)
        accepted = False
        for alpha in (1.0, 0.5, 0.25, 0.125):
            trial_pos = pos.copy()
            trial_pos[free] += alpha * dx
            trial = start.with_positions(trial_pos)
            f_trial = energy_and_forces(trial, nl)[1][free]
            f_trial_max = max_norm(f_trial)
            if f_trial_max < fmax:
                accepted = True
                break
        if not accepted:
            break
        if it == 0:
            linear = float(np.max(np.abs(alpha * dx)))
        else:
            correction += alpha * dx
            # far from the linear prediction: not in the linear-response basin of this branch
            if float(np.max(np.abs(correction))) > params.linear_basin * linear + 1e-12:
                break
        pos, current, f, fmax = trial_pos, trial, f_trial, f_trial_max
    return NewtonResult(current, False, it, cg_total)


def network_newton(
    start: Packing,
    ci: np.ndarray,
    cj: np.ndarray,
    fac: Factor,
    ftol: float,
    params: AQSParameters,
) -> tuple[Packing | None, int, int]:
    """Newton on the smooth network energy ``E_C`` from ``start`` (affinely sheared), each solve
    PCG preconditioned by ``fac``, with the damping, contraction and linear-basin tests of
    :func:`newton`. Returns ``(minimum or None, iterations, CG iterations)``."""
    free, d = fac.free, start.dim
    pos = np.array(start.positions)
    cur = start
    f, dr, _ = network_forces(cur, ci, cj)
    fb = f[free]
    fmax = max_norm(fb)
    linear = 0.0
    correction = np.zeros((free.size, d))
    cg_total = strikes = 0
    prev = math.inf
    for it in range(params.max_newton + 1):
        if fmax < ftol:
            return cur, it, cg_total
        if it == params.max_newton:
            break
        if it >= 2 and fmax > params.contraction * prev:
            strikes += 1
            if strikes > params.max_strikes:
                break
        prev = fmax
        data, indices, indptr = AK.backbone_hessian_csr(ci, cj, dr, fac.free_index, free.size)
        size = free.size * d
        k = sps.csr_matrix((data, indices, indptr), shape=(size, size))
        atol = max(0.25 * ftol, 1e-9 * fmax)
        dx, ok, cg_its = pcg(k, fb.ravel(), fac.solve, atol, params.max_cg, d)
        cg_total += cg_its
        if not ok:
            break
        dx = dx.reshape(free.size, d)
        for alpha in (1.0, 0.5, 0.25, 0.125):
            trial_pos = pos.copy()
            trial_pos[free] += alpha * dx
            trial = start.with_positions(trial_pos)
            f_t, dr_t, _ = network_forces(trial, ci, cj)
            fmax_t = max_norm(f_t[free])
            if fmax_t < fmax:
                break
        else:
            break
        if it == 0:
            linear = float(np.max(np.abs(alpha * dx)))
        else:
            correction += alpha * dx
            if float(np.max(np.abs(correction))) > params.linear_basin * linear + 1e-12:
                break
        pos, cur, fb, dr, fmax = trial_pos, trial, f_t[free], dr_t, fmax_t
    return None, it, cg_total
