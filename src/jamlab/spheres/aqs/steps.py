"""The step strategies of :func:`~jamlab.spheres.aqs.driver.shear` and the state they carry
from one strain step to the next (:class:`Stepper`).

A step from the minimum ``cur`` to the strain ``target`` is taken by one of

- :meth:`Stepper.projected`: from an unjammed minimum with ``floppy="project"``: the
  overlap-free configuration nearest to the affine start (:mod:`~jamlab.spheres.aqs.projection`),
  where there is one; the step is elastic (nothing can jump between floppy states);
- :meth:`Stepper.unjammed`: no rigid backbone (every particle a rattler, ``E ≈ 0``): FIRE
  removes the overlaps; nothing can jump, the step is elastic;
- :meth:`Stepper.lean`: the lean elastic step (:func:`~jamlab.spheres.aqs.lean.lean_step`),
  when the contact flags are consistent with the factor and nothing unusual happens;
- :meth:`Stepper.continuation`: the event-driven continuation of the branch; where it ends the
  step is plastic and FIRE carries the avalanche;
- :meth:`Stepper.classified_fire`: plain FIRE (``minimizer="fire"``), classified by running the
  continuation beside it when ``classify``;

then :meth:`Stepper.settle` measures the row (FIRE relaxes any force left on rattlers) and
:meth:`Stepper.advance` updates the predictor, the factorisation and the contact flags.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamlab.spheres.aqs.classify import same_minimum
from jamlab.spheres.aqs.continuation import Branch, continue_network
from jamlab.spheres.aqs.lean import consistent_flags, lean_step
from jamlab.spheres.aqs.linalg import Factor, factorise
from jamlab.spheres.aqs.network import affine_to, contact_keys
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.aqs.predictor import BranchPath, Secants
from jamlab.spheres.aqs.projection import project
from jamlab.spheres.aqs.record import jammed_flag, observe
from jamlab.spheres.aqs.saddle import descend
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.potential import NeighborList, Packing


@dataclass(eq=False)
class Step:
    """What a strategy returns: the new minimum ``packing`` (before any rattler cleanup), the
    affinely sheared start ``affine``, the iterations spent, the verdict ``plastic``, the
    continuation ``branch`` if one ran, the row and backbone of ``packing`` if already measured
    (``observed``), and for the lean step ``lean=True`` and ``change`` (``(flags, contact
    keys)`` of a new contact set, or ``None``)."""

    packing: Packing
    affine: Packing
    iterations: int
    plastic: bool = False
    branch: Branch | None = None
    observed: tuple[Packing, dict[str, float], np.ndarray] | None = None
    lean: bool = False
    change: tuple | None = None


class Stepper:
    """The strategies of a run (module docstring) and the state carried between steps: the
    factorisation ``fac`` and its ``age`` in steps, the ``backbone`` of the current minimum,
    the ``predictor`` of the next step (from ``path`` and ``secants``), the last row ``prev``,
    and for the fast path the contact keys and per-slot contact ``flags`` of the current
    minimum (valid for neighbour-list build
    ``flags_build``)."""

    def __init__(
        self,
        cur: Packing,
        backbone: np.ndarray,
        prev: dict[str, float],
        nl: NeighborList,
        dgamma: float,
        ftol: float,
        minimizer: str,
        classify: bool,
        params: AQSParameters,
        fire_params: FireParameters,
        counters: dict[str, int],
        fac: Factor | None = None,
    ) -> None:
        self.nl, self.dgamma, self.ftol = nl, dgamma, ftol
        self.linear, self.classify = minimizer == "linear", classify
        self.params, self.fire_params, self.counters = params, fire_params, counters
        self.backbone = backbone
        # (``fac``: the caller's factorisation of ``cur``, e.g. from the saddle test)
        self.fac = factorise(cur, nl, backbone) if fac is None else fac
        self.age = 0
        self.predictor: np.ndarray | None = None
        self.path = BranchPath(params.path_depth, params.path_degree, params.path_floor)
        self.secants = Secants(params.secant_depth) if params.secant_depth else None
        self.prev = prev
        self.checked: tuple[Packing, object] | None = None  # (minimum, its factor) from settle
        self.keys = contact_keys(cur, nl) if self.linear else None
        self.flags, self.flags_build = (
            consistent_flags(cur, nl, self.fac, params) if self.linear else (None, -1)
        )
        self.project = self.linear and params.floppy == "project"
        if self.project:
            counters.setdefault("n_projected", 0)
            counters.setdefault("n_projection_failed", 0)

    # -- the strategies -------------------------------------------------------------------------

    def take(self, cur: Packing, target: float) -> Step:
        """One step from the minimum ``cur`` to the strain ``target`` by the first strategy that
        applies (module docstring)."""
        affine = affine_to(cur, target)
        if self.linear and self.flags is not None and self.nl.n_builds != self.flags_build:
            self.flags, self.flags_build = consistent_flags(cur, self.nl, self.fac, self.params)
        if self.project and not _jammed(self.prev, self.ftol):
            step = self.projected(cur, affine)
            if step is not None:
                return step
        if self.fac.free.size == 0:
            return self.unjammed(affine)
        if not self.linear:
            return self.classified_fire(cur, target, affine)
        step = self.lean(cur, target, affine)
        return step if step is not None else self.continuation(cur, target, affine)

    def fire(self, start: Packing) -> tuple[Packing, int]:
        """FIRE from ``start`` to ``max |F| < ftol``: the minimum and the iterations."""
        res = minimize(
            start, self.ftol, self.params.max_fire_iter, self.fire_params, neighbors=self.nl
        )
        return res.packing, res.iterations

    def projected(self, cur: Packing, affine: Packing) -> Step | None:
        """The overlap-free configuration nearest to ``affine`` (elastic), or ``None`` where
        there is none nearby (the step jams) or it was not found. ``iterations``: the
        linearisations."""
        res = project(affine, self.nl, parent=cur)
        if not res:
            self.counters["n_projection_failed"] += 1
            return None
        self.counters["n_projected"] += 1
        return Step(res.packing, affine, res.sqp)

    def unjammed(self, affine: Packing) -> Step:
        """No rigid backbone: FIRE removes the overlaps; elastic."""
        new, iterations = self.fire(affine)
        return Step(new, affine, iterations)

    def lean(self, cur: Packing, target: float, affine: Packing) -> Step | None:
        """The lean elastic step, or ``None`` (flags not consistent, or it handed over)."""
        if self.flags is None or self.nl.n_builds != self.flags_build:
            return None
        lean = lean_step(
            cur,
            target,
            self.predictor,
            self.nl,
            self.fac,
            self.flags,
            self.prev,
            self.ftol,
            self.params,
            self.secants,
            affine,
        )
        if not lean:
            return None
        new, row, iterations, change = lean
        self.counters["n_lean"] += 1
        if change is not None:
            self.flags = change[0]
        return Step(
            new, affine, iterations, observed=(new, row, self.backbone), lean=True, change=change
        )

    def continuation(self, cur: Packing, target: float, affine: Packing) -> Step:
        """The event-driven continuation from ``cur``; a one-substep step whose trapezoid
        residual exceeds ``energy_tol · δγ²`` is redone from substeps of ``δγ/8`` (a contact
        opening or closing inside the step makes ``E(γ)`` a kink, not a parabola). Where the
        branch ends the step is plastic and FIRE minimises from ``affine``."""
        params, counters, prev = self.params, self.counters, self.prev
        iterations = 0
        observed = None
        branch = continue_network(
            cur, self.fac, target, self.nl, self.ftol, params, predictor=self.predictor
        )
        if branch.packing is not None and branch.substeps == 1:
            observed = (branch.packing, *observe(branch.packing, self.nl))
            row = observed[1]
            r = (
                row["energy"]
                - prev["energy"]
                - 0.5 * (target - prev["gamma"]) * (prev["shear_stress"] + row["shear_stress"])
            )
            if abs(r) > params.energy_tol * self.dgamma**2:
                counters["n_factorisations"] += branch.refactorised
                iterations += branch.iterations
                branch = continue_network(
                    cur, branch.factor, target, self.nl, self.ftol, params, first_substep=0.125
                )
        iterations += branch.iterations
        counters["n_factorisations"] += branch.refactorised
        new = branch.packing
        if new is not None:
            if branch.substeps > 1:
                counters["n_substepped"] += 1
            return Step(new, affine, iterations, branch=branch, observed=observed)
        counters["n_fallback"] += 1
        new, fire_iterations = self.fire(affine)
        return Step(new, affine, iterations + fire_iterations, plastic=True, branch=branch)

    def classified_fire(self, cur: Packing, target: float, affine: Packing) -> Step:
        """Plain FIRE from ``affine``; with ``classify``, plastic unless the continuation of
        ``cur`` reaches ``target`` and lands in FIRE's minimum (rattlers relaxed first, as the
        fast path records them, or their overlaps alone make the energies differ)."""
        new, iterations = self.fire(affine)
        if not self.classify:
            return Step(new, affine, iterations)
        branch = continue_network(cur, self.fac, target, self.nl, self.ftol, self.params)
        self.counters["n_factorisations"] += branch.refactorised
        continued = branch.packing
        if continued is not None and observe(continued, self.nl)[0]["max_force"] >= self.ftol:
            continued = self.fire(continued)[0]
        plastic = continued is None or not same_minimum(new, continued, self.nl, self.params)
        return Step(new, affine, iterations, plastic=plastic, branch=branch)

    # -- after the step -------------------------------------------------------------------------

    def settle(self, step: Step) -> tuple[Packing, dict[str, float], np.ndarray, int, bool]:
        """The recorded minimum, its row and backbone, the iterations and whether FIRE had to
        relax forces left on rattlers (the continuation holds them where the affine step put
        them; ``n_cleanup``)."""
        new, iterations = step.packing, step.iterations
        self.checked = None
        if step.observed is not None and step.observed[0] is new:
            row, backbone = step.observed[1], step.observed[2]
        else:
            row, backbone = observe(new, self.nl)
        cleaned = False
        if row["max_force"] >= self.ftol:
            self.counters["n_cleanup"] += 1
            new, fire_iterations = self.fire(new)
            row, backbone = observe(new, self.nl)
            iterations += fire_iterations
            cleaned = True
        if step.plastic:
            # FIRE took the step from the affine start: it may have stopped on a saddle
            # (saddle.py); the factorisation of the minimum, which tests it, is the next
            # step's (advance)
            new, row, backbone, fac, fire_iterations, made = descend(
                new, row, backbone, self.nl, self.ftol, self.params.max_fire_iter,
                self.fire_params,
            )  # fmt: skip
            self.counters["n_factorisations"] += made
            iterations += fire_iterations
            self.checked = (new, fac)
        return new, row, backbone, iterations, cleaned

    def advance(
        self,
        step: Step,
        new: Packing,
        row: dict[str, float],
        backbone: np.ndarray,
        cleaned: bool,
        target: float,
        last: bool,
    ) -> None:
        """Carry the state to the recorded minimum ``new``: the predictor of the next step (the
        path restarts after a contact change, a plastic step or a cleanup), the factorisation
        (taken over from the continuation; redone after a plastic step, a cleanup, a backbone
        change, slow solves or every ``refactor_every`` steps — not after the ``last`` step),
        and the contact flags of the new minimum."""
        params, nl = self.params, self.nl
        self.predictor = None
        kinked = True
        if self.linear and not step.lean:
            # did a contact open or close in this step? then u(γ) has a kink inside it
            old_keys, self.keys = self.keys, contact_keys(new, nl)
            kinked = old_keys is None or not np.array_equal(self.keys, old_keys)
        elif self.linear:
            kinked = step.change is not None
            if kinked:
                self.keys = step.change[1]
        if self.linear and not step.plastic and not cleaned:
            u = new.box.minimum_image(new.positions - step.affine.positions)
            self.path.add(u, row["max_force"], kinked)
            self.predictor = self.path.predict()
        else:
            self.path.reset()
        self.age += 1
        branch = step.branch
        if branch is not None and branch.factor is not None and not step.plastic:
            if branch.refactorised:
                self.age = 0
            self.fac = branch.factor
        stale = (
            step.plastic
            or (cleaned and self.linear)
            or self.fac.lu is None
            or not np.array_equal(self.fac.backbone, backbone)
            or self.age >= params.refactor_every
            or (self.linear and not step.lean and self.age >= params.refactor_missed)
            or (branch is not None and branch.cg_iterations > params.stale_cg)
        )
        if stale and self.checked is not None and self.checked[0] is new:
            self.fac, self.age = self.checked[1], 0  # made by settle at this minimum
        elif stale and not last:
            # the previous preconditioner is useless after an avalanche, and the regular
            # refactorisation re-checks positive definiteness exactly (LDLᵀ pivots)
            self.fac = factorise(new, nl, backbone)
            self.counters["n_factorisations"] += 1
            self.age = 0
        self.prev = {"gamma": target, **row}
        self.backbone = backbone
        if self.linear and (not step.lean or stale):
            # contacts of the new minimum, per neighbour-list slot, for the next lean step
            self.flags, self.flags_build = consistent_flags(new, nl, self.fac, params)


def _jammed(prev: dict, ftol: float) -> bool:
    """Whether the minimum of the row ``prev`` is jammed: ``record.jammed_flag`` of its
    rigidity counts (a running row) or of its recorded flag (a resumed row); unknown counts as
    jammed (the usual strategies)."""
    flag = jammed_flag(prev.get("rigidity", prev.get("jammed")), ftol)
    return True if flag is None else flag
