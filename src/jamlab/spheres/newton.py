"""Hybrid minimiser: FIRE to a loose force tolerance, then Newton–Raphson on the backbone.

Near jamming FIRE spends most of its iterations in the tail: reaching ``max_i |F_i| < 1e-12``
from ``1e-8`` takes ~85 % of the iterations on AQS plastic steps (δγ = 1e-5) at N = 128,
p ≈ 1e-5 and ~96 % at N = 500, p ≈ 1e-7 (``benchmarks/bench_minimize.py --split``). Where the
contact network has settled there the energy is quadratic to high accuracy and Newton's method
finishes in two steps (1e-8 → ~1e-10 → ~1e-15). The hybrid exploits that, and falls back to
FIRE where the network is still changing.

:func:`minimize_hybrid`:

1. FIRE (:func:`jamlab.spheres.fire.minimize`) from the start until ``max_i |F_i| < switch``.
   FIRE is deterministic, so this point is on plain FIRE's trajectory.
2. Newton–Raphson on the rattler-free backbone with one backbone particle pinned (the factorised
   backbone Hessian ``K`` of :mod:`jamlab.spheres.aqs`: ``K = L D Lᵀ``, positive definite iff all
   pivots are positive), rattlers held: ``x ← x + α K⁻¹ F_b``. Skipped without factorising when
   the backbone has fewer contacts than degrees of freedom (``N_c' < d(N' − 1)``: floppy modes,
   the network is still forming). After the first step, a chord step with the factorisation at
   hand is tried and kept if it cuts ``max |F_b|`` by ``chord_contraction`` without raising the
   energy; otherwise ``K`` is refactorised at the current point and must be positive definite,
   and ``α`` is the first of ``1, ½, ¼, …, min_alpha`` that satisfies Armijo's condition
   ``E(x + α dx) ≤ E(x) − c α Fᵀdx`` (where that decrease is below the rounding noise of ``E``,
   :func:`_noise`: ``E`` does not rise and ``max |F_b|`` falls). Every accepted step lowers the
   energy: a descent method from FIRE's point. The polish succeeds when
   ``max |F_b| < newton_ftol_factor · ftol``, ``K`` refactorised there (``verify``) is positive
   definite (a minimum), and no force — on rattlers, held by Newton — exceeds ``squeeze`` times
   the largest force at the start (otherwise a "rattler" is joining the backbone: the network
   is still changing and the point is a minimum only with it held). It fails when ``K`` is not
   positive definite, no step length is accepted, the backbone changes more than
   ``max_backbone_changes`` times, or after ``max_newton`` steps.
3. A failed polish is discarded: FIRE continues from the point the polish started at (FIRE
   restarts with zero velocity) to a ``switch_factor`` (0.1) tighter tolerance and step 2 is
   retried, until ``max_attempts`` (1) polishes that factorised have failed (hypostatic skips
   cost only a contact list and are not counted); then FIRE runs to ``ftol``.
4. After a successful polish, if some force (rattlers, the pinned particle) still exceeds
   ``ftol``, FIRE relaxes the whole system from there ("cleanup", as in
   :func:`jamlab.spheres.aqs.shear`).

The result has ``max_i |F_i| < ftol`` unless the FIRE iteration budget ``max_iter`` (shared by
all FIRE phases) runs out, which is reported (``converged=False``), never ignored. A
configuration without a backbone (unjammed: every particle a rattler) is plain FIRE.

Where it pays — measured (``benchmarks/bench_minimize.py``, same minimum as plain FIRE in every
case, within FIRE's own resolution at ``ftol``):

- N = 128, p ≈ 1e-5, steps that are elastic or nearly so (the first AQS steps from the jammed
  packing): Newton succeeds at the first attempt, ~750 FIRE iterations + 2 Newton steps instead
  of ~2300 FIRE iterations, ~1.3x faster (two factorisations, ~2.5 ms each, are half the cost).
- AQS *plastic* steps (where :func:`jamlab.spheres.aqs.shear` uses FIRE): the hybrid is slower,
  0.77x (switch 1e-8) / 0.90x (1e-9) at N = 128 and 0.94x / 0.90x at N = 500, p ≈ 1e-7. There
  the contact network is still changing at ``max|F| ~ 1e-8–1e-11`` (backbone hypostatic,
  "rattlers" joining it, FIRE still moving particles by up to ~1e-4): the Newton polish fails
  (line search, rattlers squeezed, not positive definite) and FIRE has to finish anyway.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from jamlab.spheres.aqs.linalg import factorise as _factorise
from jamlab.spheres.aqs.linalg import max_norm as _max_norm
from jamlab.spheres.aqs.network import backbone_mask as _backbone_mask
from jamlab.spheres.aqs.network import contact_list as _contact_list
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.potential import NeighborList, Packing, energy_and_forces

__all__ = ["HybridParameters", "HybridResult", "minimize_hybrid"]


@dataclass(frozen=True)
class HybridParameters:
    """Tolerances of the Newton polish (names as in the module docstring).

    ``max_newton``: accepted Newton steps per polish; ``max_attempts``: failed polishes (with a
    factorisation) before FIRE runs to the end; ``switch_factor``: FIRE tolerance factor between
    attempts; ``chord_contraction``: force reduction a chord step must achieve; ``armijo``:
    sufficient-decrease constant ``c``; ``min_alpha``: smallest step length tried;
    ``newton_ftol_factor``: the polish's target on ``max |F_b|`` relative to ``ftol``;
    ``max_backbone_changes``: rattler-set changes tolerated within a polish; ``squeeze``:
    allowed growth of the largest force (rattlers) over the polish; ``verify``: refactorise at
    the final point and require ``K`` positive definite.
    """

    max_newton: int = 40
    max_attempts: int = 1
    switch_factor: float = 0.1
    chord_contraction: float = 0.1
    armijo: float = 1e-4
    min_alpha: float = 1.0 / 64
    newton_ftol_factor: float = 0.1
    max_backbone_changes: int = 4
    squeeze: float = 1.0
    verify: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.max_newton, int) and self.max_newton >= 1):
            raise ValueError(f"max_newton must be an integer >= 1, got {self.max_newton!r}")
        if not (isinstance(self.max_attempts, int) and self.max_attempts >= 0):
            raise ValueError(f"max_attempts must be an integer >= 0, got {self.max_attempts!r}")
        for name in ("switch_factor", "chord_contraction", "armijo", "min_alpha"):
            v = getattr(self, name)
            if not 0 < v < 1:
                raise ValueError(f"{name} must be in (0, 1), got {v!r}")
        if not 0 < self.newton_ftol_factor <= 1:
            raise ValueError(f"newton_ftol_factor must be in (0, 1], got {self.newton_ftol_factor}")


@dataclass(frozen=True, eq=False)
class HybridResult:
    """Outcome of :func:`minimize_hybrid`.

    ``iterations = fire_iterations + newton_iterations``; ``newton_iterations`` counts accepted
    Newton steps (chord and full) of all attempts, ``n_factorisations`` the backbone
    factorisations, ``n_attempts`` the Newton polishes tried, ``newton_ok`` whether one of them
    succeeded (False: the result is plain FIRE's continuation), ``n_cleanup`` FIRE runs after a
    successful polish (rattler forces), ``switch`` the FIRE tolerance of the last attempt.
    """

    packing: Packing
    energy: float
    max_force: float
    iterations: int
    fire_iterations: int
    newton_iterations: int
    n_factorisations: int
    n_attempts: int
    newton_ok: bool
    n_cleanup: int
    converged: bool
    switch: float
    time: float
    ftol: float

    def __repr__(self) -> str:
        return (
            f"HybridResult(converged={self.converged}, iterations={self.iterations} "
            f"(FIRE {self.fire_iterations}, Newton {self.newton_iterations}, "
            f"{self.n_factorisations} factorisations), energy={self.energy!r}, "
            f"max_force={self.max_force:.3e}, newton_ok={self.newton_ok}, time={self.time:.3f}s)"
        )


@dataclass(frozen=True, eq=False)
class _Polish:
    packing: Packing  # the backbone minimum if ok, else the start
    ok: bool
    steps: int
    factorisations: int
    reason: str


def _noise(e: float, packing: Packing) -> float:
    """Bound on the rounding error of an energy difference near ``E``.

    Each overlap ``δ = 1 − r`` carries an absolute error ``~ ε L`` (coordinates of size ``L``),
    so ``E = Σ δ²`` carries ``≲ 2 ε L Σ δ ≤ 2 ε L √(N_c E)``, with ``N_c ≤ 6 N`` contacts
    (``z ≤ 12`` in 3D; ``N_c ≤ d(d+1)N/2`` in general, a generous bound). Measured at
    N = 128, p ≈ 1e-5: ``|ΔE|`` of steps of ``1e-15`` is ``~5e-20``, this bound ``~1e-17``.
    """
    d = packing.dim
    n_c = 0.5 * d * (d + 1) * packing.n
    length = max(float(packing.box.length), 1.0)
    return 2.0 * np.finfo(np.float64).eps * length * math.sqrt(n_c * max(e, 0.0)) + 1e-300


def _mask(packing: Packing, nl: NeighborList) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rattler-free backbone (as :func:`~jamlab.spheres.potential.remove_rattlers`) and the
    contact pairs ``(i, j)``."""
    ci, cj, _ = _contact_list(packing, nl)
    return _backbone_mask(ci, cj, packing.n, packing.dim), ci, cj


def _finish(
    start: Packing,
    cur: Packing,
    f: np.ndarray,
    f_start: float,
    steps: int,
    nfac: int,
    squeeze: float,
) -> _Polish:
    """Accept the backbone minimum ``cur`` unless the rattlers (held by Newton) are now pushed
    harder than anything was at the start: then a "rattler" is joining the backbone (the
    contact network is still forming) and ``cur`` is a minimum only with it held; the polish
    fails and FIRE continues from ``start``."""
    if _max_norm(f) > squeeze * f_start:
        return _Polish(start, False, steps, nfac, "rattlers squeezed")
    return _Polish(cur, True, steps, nfac, "converged")


def _polish(start: Packing, nl: NeighborList, ftol: float, params: HybridParameters) -> _Polish:
    """Newton–Raphson on the backbone from ``start`` (module docstring, step 2)."""
    d = start.dim
    backbone, ci, cj = _mask(start, nl)
    n_bb = int(backbone.sum())
    if n_bb == 0:
        return _Polish(start, False, 0, 0, "no backbone")
    if int(np.count_nonzero(backbone[ci] & backbone[cj])) < d * (n_bb - 1):
        # fewer constraints than degrees of freedom: floppy modes, K singular or indefinite
        # (the contact network is still forming); no need to factorise
        return _Polish(start, False, 0, 0, "hypostatic")
    fac = _factorise(start, nl, backbone)
    nfac = 1
    if fac.lu is None or not fac.positive_definite:
        return _Polish(start, False, 0, nfac, "not positive definite")
    fresh = True  # fac was factorised at the current point
    pos = np.array(start.positions)
    cur = start
    e, f = energy_and_forces(cur, nl)
    fb = f[fac.free]
    fbmax = _max_norm(fb)
    f_start = _max_norm(f)
    target = params.newton_ftol_factor * ftol
    steps = 0
    changes = 0
    while True:
        if fbmax < target:
            if not params.verify:
                return _finish(start, cur, f, f_start, steps, nfac, params.squeeze)
            if not fresh:
                backbone = _mask(cur, nl)[0]
                fac = _factorise(cur, nl, backbone)
                nfac += 1
            if fac.lu is None or not fac.positive_definite:
                return _Polish(start, False, steps, nfac, "final Hessian not positive definite")
            return _finish(start, cur, f, f_start, steps, nfac, params.squeeze)
        if steps >= params.max_newton:
            return _Polish(start, False, steps, nfac, "max_newton")
        accepted = False
        if not fresh:
            # chord step with the factorisation of an earlier point
            dx = fac.lu.solve(fb.ravel()).reshape(-1, d)
            tpos = pos.copy()
            tpos[fac.free] += dx
            trial = start.with_positions(tpos)
            te, tf = energy_and_forces(trial, nl)
            tfb = tf[fac.free]
            tfbmax = _max_norm(tfb)
            if tfbmax < params.chord_contraction * fbmax and te <= e + _noise(e, start):
                accepted = True
        if not accepted:
            if not fresh:
                new_backbone = _mask(cur, nl)[0]
                if not np.array_equal(new_backbone, fac.backbone):
                    changes += 1
                    if changes > params.max_backbone_changes:
                        return _Polish(start, False, steps, nfac, "backbone keeps changing")
                    if not new_backbone.any():
                        return _Polish(start, False, steps, nfac, "no backbone")
                fac = _factorise(cur, nl, new_backbone)
                nfac += 1
                fresh = True
                if fac.lu is None or not fac.positive_definite:
                    return _Polish(start, False, steps, nfac, "not positive definite")
                fb = f[fac.free]
                fbmax = _max_norm(fb)
                if fbmax < target:
                    continue
            dx = fac.lu.solve(fb.ravel()).reshape(-1, d)
            slope = -float(fb.ravel() @ dx.ravel())  # dE/dα at α = 0 (< 0: K is PD)
            alpha = 1.0
            while alpha >= params.min_alpha:
                tpos = pos.copy()
                tpos[fac.free] += alpha * dx
                trial = start.with_positions(tpos)
                te, tf = energy_and_forces(trial, nl)
                tfb = tf[fac.free]
                tfbmax = _max_norm(tfb)
                decrease = -params.armijo * alpha * slope
                if decrease > _noise(e, start):
                    accepted = te <= e - decrease
                else:  # the energy cannot resolve the step: use the force
                    accepted = te <= e + _noise(e, start) and tfbmax < fbmax
                if accepted:
                    break
                alpha *= 0.5
            if not accepted:
                return _Polish(start, False, steps, nfac, "line search failed")
        steps += 1
        fresh = False
        pos, cur, e, f, fb, fbmax = tpos, trial, te, tf, tfb, tfbmax


def minimize_hybrid(
    packing: Packing,
    ftol: float = 1e-12,
    *,
    switch: float = 1e-8,
    max_iter: int = 2_000_000,
    fire_params: FireParameters | None = None,
    neighbors: NeighborList | None = None,
    params: HybridParameters | None = None,
) -> HybridResult:
    """Minimise ``packing`` at fixed box and strain to ``max_i |F_i| < ftol``: FIRE to ``switch``,
    then Newton on the backbone (module docstring). ``max_iter`` caps the FIRE iterations of all
    phases together; ``neighbors`` is updated in place as by :func:`~jamlab.spheres.fire.minimize`.
    """
    if not (isinstance(ftol, int | float) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    if not (isinstance(switch, int | float) and math.isfinite(switch) and switch > 0):
        raise ValueError(f"switch must be finite and > 0, got switch={switch!r}")
    if not (isinstance(max_iter, int | np.integer) and max_iter >= 0):
        raise ValueError(f"max_iter must be an integer >= 0, got max_iter={max_iter!r}")
    params = HybridParameters() if params is None else params
    fire_params = FireParameters() if fire_params is None else fire_params
    t0 = time.perf_counter()
    nl = NeighborList(packing) if neighbors is None else neighbors
    cur = packing
    fire_its = newton_its = nfac = attempts = cleanup = 0
    newton_ok = False
    tol = max(switch, ftol)

    def fire(p: Packing, tol: float):
        nonlocal fire_its
        res = minimize(p, tol, max(int(max_iter) - fire_its, 0), fire_params, neighbors=nl)
        fire_its += res.iterations
        return res

    res = fire(cur, tol)
    cur = res.packing
    failures = 0
    while res.converged and res.max_force >= ftol and failures < params.max_attempts:
        # (terminates: tol reaches ftol geometrically, and FIRE to ftol ends the loop)
        attempts += 1
        pol = _polish(cur, nl, ftol, params)
        newton_its += pol.steps
        nfac += pol.factorisations
        cur = pol.packing
        if pol.factorisations:  # a hypostatic contact network costs nothing: not counted
            failures += 1
        if pol.ok:
            newton_ok = True
            e, f = energy_and_forces(cur, nl)
            if _max_norm(f) < ftol:
                res = None
            else:  # rattlers (held by Newton) still pushed: FIRE relaxes them
                cleanup += 1
                res = fire(cur, ftol)
                cur = res.packing
            break
        tol = max(tol * params.switch_factor, ftol)
        res = fire(cur, tol)
        cur = res.packing
    if res is not None and res.converged and res.max_force >= ftol:
        res = fire(cur, ftol)  # Newton gave up: plain FIRE to the end
        cur = res.packing
    e, f = energy_and_forces(cur, nl)
    fmax = _max_norm(f)
    return HybridResult(
        packing=cur,
        energy=float(e),
        max_force=fmax,
        iterations=fire_its + newton_its,
        fire_iterations=fire_its,
        newton_iterations=newton_its,
        n_factorisations=nfac,
        n_attempts=attempts,
        newton_ok=newton_ok,
        n_cleanup=cleanup,
        converged=bool(fmax < ftol),
        switch=tol,
        time=time.perf_counter() - t0,
        ftol=float(ftol),
    )
