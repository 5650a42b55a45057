"""One damped Newton iteration on the free backbone, preconditioned by the stored factorisation.

:func:`damped_newton` is the iteration; what it minimises comes from a *force model* with two
methods: ``forces(packing) -> (F_b, state)`` (the forces on the free backbone particles, and
whatever the Hessian can reuse) and ``hessian(packing, state) -> K`` (the pinned backbone
Hessian, CSR). The model of the event-driven continuation is :class:`NetworkModel`, the smooth
energy of a fixed contact set. (Until issue 14 a second copy of this iteration ran on the pair
potential itself for the substep continuation, and a third polished FIRE's minima in
``spheres/newton.py``; both were removed, ``docs/aqs.md``.)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sps

from jamlab.spheres.aqs.linalg import Factor, hessian_matrix, max_norm, pcg
from jamlab.spheres.aqs.network import network_forces
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.potential import Packing


@dataclass(frozen=True, eq=False)
class NewtonResult:
    """``packing``: the minimum if ``ok``, else the last accepted iterate; ``iterations``:
    Newton (or chord) steps; ``cg_iterations``: PCG iterations of all solves; ``reason``: why
    it failed (empty if ``ok``)."""

    packing: Packing
    ok: bool
    iterations: int
    cg_iterations: int
    reason: str = ""


class ForceModel(Protocol):
    """What :func:`damped_newton` minimises (module docstring)."""

    def forces(self, packing: Packing) -> tuple[np.ndarray, object]: ...

    def hessian(self, packing: Packing, state: object) -> sps.csr_matrix: ...


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
    forcing: float = 1e-9,
) -> NewtonResult:
    """Damped Newton ``x ← x + α K(x)⁻¹ F_b(x)`` on the ``free`` particles until
    ``max |F_b| < ftol``; ``F_b`` and ``K`` from ``model``, ``initial`` its forces at ``start``
    if already known.

    Each solve is PCG to a residual ``max(ftol/4, forcing · max|F_b|)`` (``forcing``: the
    inexact-Newton forcing term; the default 1e-9 makes every solve practically exact),
    preconditioned by ``precond`` (a nearby ``K⁻¹``: the stored
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
    reason = "max_newton"
    for it in range(params.max_newton + 1):
        if fmax < ftol:
            return NewtonResult(current, True, it, cg_total)
        if it == params.max_newton:
            break
        if it >= 2 and fmax > params.contraction * prev:
            strikes += 1
            if strikes > params.max_strikes:
                reason = "no contraction"
                break
        prev = fmax
        k = model.hessian(current, state)
        # the next force check decides; 0.25 ftol leaves room for the O(dx²) remainder
        atol = max(0.25 * ftol, forcing * fmax)
        dx, ok, cg_its = pcg(k, f.ravel(), precond, atol, params.max_cg, d)
        cg_total += cg_its
        if not ok:
            reason = "solve failed (negative curvature or max_cg)"
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
            reason = "no damping lowers the force"
            break
        if it == 0:
            linear = float(np.max(np.abs(alpha * dx)))
        else:
            correction += alpha * dx
            # far from the linear prediction: not in the linear-response basin of this branch
            if float(np.max(np.abs(correction))) > params.linear_basin * linear + 1e-12:
                reason = "left the linear-response basin"
                break
        pos, current, f, state, fmax = trial_pos, trial, f_trial, state_trial, f_trial_max
    return NewtonResult(current, False, it, cg_total, reason)
