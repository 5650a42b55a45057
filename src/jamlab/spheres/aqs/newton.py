"""One damped Newton iteration on the free backbone, preconditioned by the stored factorisation.

:func:`damped_newton` is the iteration; what it minimises comes from a *force model* with two
methods: ``forces(packing) -> (F_b, state)`` (the forces on the free backbone particles, and
whatever the Hessian can reuse) and ``hessian(packing, state) -> K`` (the pinned backbone
Hessian, CSR). Two models: :class:`PotentialModel` (the pair potential itself, contacts free to
open and close; the factor's rank-one corrections follow them) and :class:`NetworkModel` (the
smooth energy of a fixed contact set, used by the event-driven continuation).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sps

from jamlab.spheres.aqs.linalg import Factor, hessian_matrix, max_norm, pcg
from jamlab.spheres.aqs.network import contact_list, network_forces
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.potential import NeighborList, Packing, energy_and_forces


@dataclass(frozen=True, eq=False)
class NewtonResult:
    """``packing``: the minimum if ``ok``, else the last accepted iterate; ``iterations``:
    Newton (or chord) steps; ``cg_iterations``: PCG iterations of all solves."""

    packing: Packing
    ok: bool
    iterations: int
    cg_iterations: int


class ForceModel(Protocol):
    """What :func:`damped_newton` minimises (module docstring)."""

    def forces(self, packing: Packing) -> tuple[np.ndarray, object]: ...

    def hessian(self, packing: Packing, state: object) -> sps.csr_matrix: ...


class PotentialModel:
    """The pair potential: forces from :func:`~jamlab.spheres.potential.energy_and_forces`,
    Hessian of the current contacts; each Hessian also updates the factor's rank-one
    corrections to those contacts (``max_corrections`` at most)."""

    def __init__(self, nl: NeighborList, fac: Factor, max_corrections: int) -> None:
        self.nl, self.fac, self.max_corrections = nl, fac, max_corrections

    def forces(self, packing: Packing) -> tuple[np.ndarray, None]:
        return energy_and_forces(packing, self.nl)[1][self.fac.free], None

    def hessian(self, packing: Packing, state: None) -> sps.csr_matrix:
        ci, cj, cd = contact_list(packing, self.nl)
        k = hessian_matrix(ci, cj, cd, self.fac)
        self.fac.update(ci, cj, cd, self.max_corrections)
        return k


class NetworkModel:
    """The smooth network energy ``E_C = Σ_{c ∈ C} (1 − r_c)²`` of the pairs ``(ci, cj)``
    (:func:`~jamlab.spheres.aqs.network.network_forces`); the state is the pairs' separations."""

    def __init__(self, ci: np.ndarray, cj: np.ndarray, fac: Factor) -> None:
        self.ci, self.cj, self.fac = ci, cj, fac

    def forces(self, packing: Packing) -> tuple[np.ndarray, np.ndarray]:
        f, dr, _ = network_forces(packing, self.ci, self.cj)
        return f[self.fac.free], dr

    def hessian(self, packing: Packing, state: np.ndarray) -> sps.csr_matrix:
        return hessian_matrix(self.ci, self.cj, state, self.fac)


def damped_newton(
    start: Packing,
    free: np.ndarray,
    model: ForceModel,
    precond: Callable[[np.ndarray], np.ndarray],
    ftol: float,
    params: AQSParameters,
    initial: tuple[np.ndarray, object] | None = None,
) -> NewtonResult:
    """Damped Newton ``x ← x + α K(x)⁻¹ F_b(x)`` on the ``free`` particles until
    ``max |F_b| < ftol``; ``F_b`` and ``K`` from ``model``, ``initial`` its forces at ``start``
    if already known.

    Each solve is PCG preconditioned by ``precond`` (a nearby ``K⁻¹``: the stored
    factorisation); ``α ∈ {1, ½, ¼, ⅛}`` is the first that lowers ``max |F_b|`` (a contact
    that opens or closes makes the Hessian jump and the full step overshoot; the damping stops
    the iteration from cycling between contact sets). Fails (tests: :mod:`jamlab.spheres.aqs`)
    when no ``α`` lowers the force, when more than ``max_strikes`` iterations from the second
    on do not contract by ``contraction``, when the corrections leave the linear-response basin
    (their sum exceeds ``linear_basin`` times the first step), on negative curvature, or after
    ``max_newton`` iterations.
    """
    d = start.dim
    pos = np.array(start.positions)
    current = start
    f, state = model.forces(current) if initial is None else initial
    fmax = max_norm(f)
    linear = 0.0
    correction = np.zeros((free.size, d))
    cg_total = strikes = 0
    prev = math.inf
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
        k = model.hessian(current, state)
        # the next force check decides; 0.25 ftol leaves room for the O(dx²) remainder
        atol = max(0.25 * ftol, 1e-9 * fmax)
        dx, ok, cg_its = pcg(k, f.ravel(), precond, atol, params.max_cg, d)
        cg_total += cg_its
        if not ok:
            break
        dx = dx.reshape(free.size, d)
        for alpha in (1.0, 0.5, 0.25, 0.125):
            trial_pos = pos.copy()
            trial_pos[free] += alpha * dx
            trial = start.with_positions(trial_pos)
            f_trial, state_trial = model.forces(trial)
            f_trial_max = max_norm(f_trial)
            if f_trial_max < fmax:
                break
        else:
            break
        if it == 0:
            linear = float(np.max(np.abs(alpha * dx)))
        else:
            correction += alpha * dx
            # far from the linear prediction: not in the linear-response basin of this branch
            if float(np.max(np.abs(correction))) > params.linear_basin * linear + 1e-12:
                break
        pos, current, f, state, fmax = trial_pos, trial, f_trial, state_trial, f_trial_max
    return NewtonResult(current, False, it, cg_total)


def newton(
    start: Packing, nl: NeighborList, fac: Factor, ftol: float, params: AQSParameters
) -> NewtonResult:
    """Chord steps with the stored factorisation first, then :func:`damped_newton` on the pair
    potential (:class:`PotentialModel`), from ``start``."""
    pos = np.array(start.positions)
    free = fac.free
    d = start.dim
    f = energy_and_forces(start.with_positions(pos), nl)[1][free]
    fmax = max_norm(f)
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
    return damped_newton(
        start,
        free,
        PotentialModel(nl, fac, params.max_corrections),
        fac.solve,
        ftol,
        params,
        initial=(f, None),
    )
