"""Newton relaxation at fixed box from a nearby configuration, FIRE where Newton cannot.

The inner minimiser of fixed-pressure AQS (:mod:`jamlab.spheres.pressure_shear`) when
``minimizer="newton"``. Along an elastic stretch every inner problem starts next to a minimum
(the last one, sheared by ``δγ`` and rescaled by ``ΔL/L ~ 1e-6``), where a Newton iteration on
the pair potential converges in two or three steps while FIRE needs thousands
(``docs/aqs.md``, "Fixed pressure: the Newton inner minimiser").

**Iteration: an active set of contacts.** The harmonic pair energy is smooth only while the
set of overlapping pairs stays the same, and near jamming the affine step alone opens the
weakest contacts (overlaps ``≲ δγ``) that the minimum closes again, while a few gaps close. So:
(1) :func:`jamlab.spheres.aqs.newton.damped_newton` minimises the energy of the *network* of
the parent minimum's backbone contacts (every pair a spring, in tension too: smooth, two or
three Newton steps), on the free backbone (rattlers and one pinned particle held), each solve
PCG preconditioned by a stored factorisation (:func:`jamlab.spheres.aqs.linalg.factorise`,
CHOLMOD's Cholesky: it exists where the matrix is positive definite) of the backbone Hessian at
a parent minimum, corrected by
Woodbury terms for the pairs where the network differs from the factor's contacts
(:meth:`jamlab.spheres.aqs.linalg.Factor.update`, as the constant-volume fast path does); (2) the
network is replaced by the backbone pairs that overlap at that point, and (1) is repeated until
the network's minimum overlaps exactly its own pairs (``max_active_sets`` rounds) — then it is
a stationary point of the pair potential on the backbone; (3) the rattlers are moved out of
their overlaps (:func:`free_rattlers`; a rattler that cannot be freed — it joins the backbone
at the minimum — is left to FIRE from the backbone's minimum, "rattler polish"). The factor is
refreshed every ``refactor_every`` calls, after every FIRE fallback, and whenever the parent
minimum's backbone is not the factor's. **The parent matters:** the first active set decides
which minimum the iteration reaches, so it is the contact network of the minimum the start was
made from (``parent``, given by the fixed-pressure driver for every inner problem: the last
minimum for a step, the last substep's minimum for a substep of the plastic-flag
confirmation, the minimum being rescaled for a volume step) — not the last minimum returned,
which for a substep is the end of the whole step (a first version did that; its substeps
reached the post-event minimum in the first substep).

**Acceptance — when is the Newton point a minimum?** All of: each Newton iteration converged
(``max |F| < ftol/2`` on the free particles, contracting, inside the linear-response basin of
its first step), **every PCG solve met only positive curvature** (a direction of negative
curvature of ``K`` in a Krylov space preconditioned by a positive definite factor of a nearby
minimum fails the solve; the last solve is with the Hessian of the final contact set), the
factor positive definite, the rattlers freed, and an independent full evaluation
(:func:`jamlab.spheres.potential.evaluate`) giving ``max_i |F_i| < ftol`` over *all*
particles. Anything else — every plastic step, where the branch ends and no minimum is near, a
rattler caged by the step (it joins the backbone), a backbone particle left under-coordinated —
falls back to FIRE (:func:`jamlab.spheres.fire.minimize`) from the same start. Where both
apply they find the same minimum (``tests/spheres/test_newton_relax.py``; the statistics of
whole runs: ``docs/aqs.md``).

**A FIRE fallback finished by Newton** (``finish_below``, default :data:`FINISH_BELOW` = 1e-9):
FIRE carries the event to ``max_i |F_i| < 1e-9``, where the contact network has settled, and the
iteration above finishes from that point with the point as its own parent (its contacts the
first active set, a factor made there), accepted by the same tests; FIRE goes on to ``ftol``
from the loose point where it does not accept. FIRE's last decades of force are a slow approach
along the soft modes (35 % of its iterations at N = 1000, p = 1e-4); the minimum is the
same to ``ftol`` (positions up to the flat directions, ~1e-6), measured in ``docs/aqs.md``.

**State and resume.** The stored factor, the last minimum returned and a small cache of the
parents' contact networks are the state; :meth:`NewtonRelaxer.reset` drops them. The
fixed-pressure driver resets at every checkpoint, so a resumed run equals the uninterrupted one
bit for bit.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from jamlab.spheres.aqs.linalg import Factor, factorise
from jamlab.spheres.aqs.network import backbone_mask, contact_list, pair_keys
from jamlab.spheres.aqs.newton import NetworkModel, damped_newton
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.fire import FireParameters, MinimizeResult, minimize
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.pair import HARMONIC, contact_force, pair_energy, pair_sigmas
from jamlab.spheres.potential import Evaluation, Packing, evaluate

__all__ = [
    "FINISH_BELOW",
    "SETTLE_CAGED",
    "NewtonRelaxer",
    "RELAX_COUNTERS",
    "free_rattlers",
    "minimize_rattlers",
    "settle_rattlers",
]

FINISH_BELOW: float | None = 1e-9
"""Default ``finish_below`` of :class:`NewtonRelaxer` (read when one is made): a FIRE fallback
runs to ``max_i |F_i| < 1e-9`` and Newton finishes from there; ``None`` restores FIRE to
``ftol`` (``docs/aqs.md``, "A FIRE fallback finished by Newton")."""

SETTLE_CAGED: bool = True
"""Default ``settle_caged`` of :class:`NewtonRelaxer` (read when one is made): where a rattler
cannot be freed alone at the backbone's minimum, the rattlers are moved together
(:func:`minimize_rattlers`), and where one stays caged it is put on the backbone and Newton runs
once more, before FIRE polishes (``False``: FIRE polishes at once; ``docs/aqs.md``, "Caged
rattlers without FIRE")."""

RELAX_COUNTERS: tuple[str, ...] = (
    "n_newton_calls",
    "n_newton_accepted",
    "n_newton_iterations",
    "n_cg_iterations",
    "n_contact_changes",
    "n_fire_fallbacks",
    "n_rattler_polish",
    "n_factorisations",
    "n_fire_finished_by_newton",
    "n_rattler_rejoined",
    "n_rattlers_moved_together",
)


def _better(overlap, i: int, x: np.ndarray, step: np.ndarray, u: float):
    """``x + α step`` for the first ``α ∈ {1, ½, …, 1/32}`` that lowers the overlap energy below
    ``u``, with its overlaps; ``None`` if none does."""
    for alpha in (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125):
        trial = x + alpha * step
        dr, r, sig = overlap(i, trial)
        s = 1.0 - r / sig
        if 0.5 * float(s @ s) < u:
            return trial, dr, r, sig
    return None


def free_rattlers(
    packing: Packing, backbone: np.ndarray, max_iter: int = 40
) -> Packing | None:
    """Move every rattler (``~backbone``) that overlaps something to a place where it overlaps
    nothing, all other particles held; ``None`` if one cannot be freed (caged).

    Each such rattler in turn (Gauss–Seidel: a rattler's new place is seen by the next)
    minimises its own overlap energy ``U = Σ_c ½ (1 − r_c/σ_c)²`` (harmonic pair energy, up to
    the scale ``ε``) in its cage of fixed neighbours: a Gauss–Newton step (the least-squares
    move that clears every linearised overlap), and where that does not lower ``U`` (opposite
    overlaps: the pushes cancel and only the curvature of the cage walls leads out — the case
    where the averaged pushes of :func:`~jamlab.spheres.aqs.continuation.relax_rattlers`
    stall) a step along the lowest eigenvector of the Hessian of ``U``; each with
    backtracking until ``U`` decreases. Freed means ``U = 0`` exactly: no pair
    of the rattler overlaps, so it carries no force and exerts none."""
    moved, caged = settle_rattlers(packing, backbone, max_iter)
    return None if caged else moved


def _near(box, pos: np.ndarray, diam: np.ndarray, i: int, x: np.ndarray, margin: float):
    """The particles other than ``i`` closer to the point ``x`` (particle ``i``'s place) than
    ``σ_ij + margin``: their indices, the separations ``x − r_j`` (minimum image), the distances
    and ``σ_ij``. One particle against all: memory ``O(N)``."""
    dr = box.minimum_image(x - pos)
    r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
    sig = 0.5 * (diam[i] + diam)
    idx = np.flatnonzero(r < sig + margin)
    idx = idx[idx != i]
    return idx, dr[idx], r[idx], sig[idx]


def settle_rattlers(
    packing: Packing, backbone: np.ndarray, max_iter: int = 40
) -> tuple[Packing, bool]:
    """:func:`free_rattlers`' moves, with the rattlers that cannot be freed left where their
    overlap energy was lowest (in their cage: there they push on the walls that hold them, the
    contacts with which they join the backbone at the minimum); returns the configuration and
    whether any rattler is caged."""
    rattlers = np.flatnonzero(~backbone)
    if rattlers.size == 0:
        return packing, False
    pos = np.array(packing.positions)
    box, diam = packing.box, packing.diameters
    d = packing.dim

    def overlap(i: int, x: np.ndarray):
        return _near(box, pos, diam, i, x, 0.0)[1:]

    caged = False
    for i in rattlers:
        x = pos[i].copy()
        dr, r, sig = overlap(i, x)
        for _ in range(max_iter):
            if r.size == 0:
                break
            s = 1.0 - r / sig
            u = 0.5 * float(s @ s)
            n = dr / r[:, None]
            # Gauss–Newton: the least-squares move that makes every linearised overlap vanish
            step = np.linalg.lstsq(n, sig - r, rcond=None)[0]
            trial = _better(overlap, i, x, step, u)
            if trial is None:
                # the pushes cancel (opposite overlaps): out along the cage walls' curvature,
                # the lowest eigenvector of the Hessian of U, by the sideways distance that
                # would clear the largest overlap o (r grows as t²/2r: t = √(2 σ o)), twice
                h = np.zeros((d, d))
                for a in range(r.size):
                    nn = np.outer(n[a], n[a])
                    h += nn / sig[a] ** 2 - (s[a] / (sig[a] * r[a])) * (np.eye(d) - nn)
                v = np.linalg.eigh(h)[1][:, 0]
                t = 2.0 * float(np.sqrt(2.0 * np.max(sig * (sig - r))))
                trial = _better(overlap, i, x, v * t, u)
                if trial is None:
                    trial = _better(overlap, i, x, -v * t, u)
                if trial is None:
                    break
            x, dr, r, sig = trial
        caged = caged or r.size > 0
        pos[i] = x
    return packing.with_positions(pos), caged


def minimize_rattlers(
    packing: Packing, backbone: np.ndarray, ftol: float, max_iter: int = 200
) -> tuple[Packing, float]:
    """The rattlers (``~backbone``) moved together to a minimum of the energy with every
    backbone particle held (L-BFGS over their coordinates, from ``packing``); returns the
    configuration and the largest force a contact of a rattler carries there (not the net force
    on a rattler, which also vanishes where a caged one is balanced by its walls).

    Where :func:`settle_rattlers` cannot free a rattler one at a time, two rattlers often block
    each other (each held where the other stands): moved together they reach a place where
    their forces vanish (to ``ftol / 8`` per component), or, where the cage is really too small,
    the minimum over their places, whose forces stay large (the rattler joins the backbone).
    Each coordinate moves by at most ``0.04`` (bounds of the L-BFGS-B; a rattler's move is ~
    its overlaps, ≲ 1e-3 here, and L-BFGS's first trial step is of length 1), so a rattler moves
    by at most ``0.04 √d < 0.07`` and the partners it can reach are the particles within
    ``σ_ij + 0.15`` of it at the start (two rattlers approaching each other: ``< 0.14``).
    Harmonic law (the relaxer's)."""
    rat = np.flatnonzero(~backbone)
    pos = np.array(packing.positions)
    if rat.size == 0:
        return packing, 0.0
    box, diam = packing.box, packing.diameters
    d = packing.dim
    # partners: one rattler at a time against all particles (memory O(N), not O(rattlers × N))
    found = [_near(box, pos, diam, ri, pos[ri], 0.15)[0] for ri in rat]
    i = np.repeat(rat, [f.size for f in found])
    j = np.concatenate(found)
    rattler = ~backbone
    # each pair once: a rattler–rattler pair is found from both ends; keep i < j
    keep = ~rattler[j] | (i < j)
    i, j = i[keep], j[keep]
    sig = pair_sigmas(diam, i, j)
    row = np.full(packing.n, -1)
    row[rat] = np.arange(rat.size)

    def contacts(x: np.ndarray):
        """The rattlers placed at ``x``: the pairs' separations, distances and forces."""
        pos[rat] = x.reshape(-1, d)
        sep = box.minimum_image(pos[i] - pos[j])
        dist = np.sqrt(np.einsum("ij,ij->i", sep, sep))
        return sep, dist, contact_force(dist, sig, HARMONIC)  # the relaxer's law

    def energy_and_gradient(x: np.ndarray):
        sep, dist, force = contacts(x)
        # the energy's gradient on rattler i is −f n_ij, on j (a rattler too) +f n_ij
        push = (force / dist)[:, None] * sep
        g = np.zeros((rat.size, d))
        on_i, on_j = row[i], row[j]
        np.add.at(g, on_i, -push)
        sel = on_j >= 0
        np.add.at(g, on_j[sel], push[sel])
        return float(np.sum(pair_energy(dist, sig, HARMONIC))), g.ravel()

    import scipy.optimize  # here: a caged rattler is rare, and the import costs ~0.3 s per process

    x0 = pos[rat].ravel()
    res = scipy.optimize.minimize(
        energy_and_gradient, x0, jac=True, method="L-BFGS-B",
        bounds=scipy.optimize.Bounds(x0 - 0.04, x0 + 0.04),
        options={"maxiter": max_iter, "ftol": 0.0, "gtol": ftol / 8.0},
    )
    worst = float(np.max(contacts(res.x)[2], initial=0.0))
    return packing.with_positions(pos), worst


def _backbone_pairs(ci: np.ndarray, cj: np.ndarray, backbone: np.ndarray, n: int):
    """The pairs ``(ci, cj)`` with both ends on the backbone, and their sorted keys."""
    keep = backbone[ci] & backbone[cj]
    ci, cj = ci[keep], cj[keep]
    return ci, cj, np.sort(pair_keys(ci, cj, n))


def _usable(fac: Factor) -> bool:
    """A factor that can precondition: factorised, positive definite, something free."""
    return fac.lu is not None and fac.positive_definite and fac.free.size > 0


@dataclass(eq=False)
class NewtonRelaxer:
    """Fixed-box minimiser for a sequence of nearby configurations (module docstring).

    Call it as ``relaxer(packing, ftol, max_iter, params)`` (the signature of
    :func:`jamlab.spheres.fire.minimize`'s core arguments; ``params`` are FIRE's, for the
    fallback). ``counters`` (:data:`RELAX_COUNTERS`) accumulate over calls."""

    aqs_params: AQSParameters = field(default_factory=AQSParameters)
    refactor_every: int = 10
    max_active_sets: int = 8
    rattler_iterations: int = 40
    # a rattler not freed alone: rattlers moved together, then Newton with the caged ones on
    # the backbone, before FIRE polishes (False: FIRE at once)
    settle_caged: bool = field(default_factory=lambda: SETTLE_CAGED)
    forcing: float = 1e-3  # inexact Newton: each solve to 1e-3 of the force (then ftol/4)
    # a FIRE fallback stops at this force and Newton finishes (None: FIRE to ftol)
    finish_below: float | None = field(default_factory=lambda: FINISH_BELOW)
    fac: Factor | None = None
    age: int = 0
    reference: Packing | None = None  # the last minimum returned
    counters: dict = field(default_factory=lambda: dict.fromkeys(RELAX_COUNTERS, 0))
    _known: list = field(default_factory=list)  # [(minimum, its contacts and backbone)]

    def __post_init__(self) -> None:
        if not (isinstance(self.refactor_every, int) and self.refactor_every >= 1):
            raise ValueError(f"refactor_every must be an integer >= 1, got {self.refactor_every!r}")

    def reset(self) -> None:
        """Forget the stored factorisation and the known minima (a restart point)."""
        self.fac, self.age, self.reference = None, 0, None
        self._known.clear()

    def __call__(
        self,
        packing: Packing,
        ftol: float = 1e-12,
        max_iter: int = 1_000_000,
        params: FireParameters | None = None,
        parent: Packing | None = None,
    ) -> MinimizeResult:
        """The minimum reached from ``packing``. ``parent``: the minimum ``packing`` was made
        from (by an affine shear or rescaling); its contacts are the first active set and its
        backbone the free set. Without it, the last minimum returned is taken as the parent
        (a first call without either is FIRE's)."""
        t0 = time.perf_counter()
        result = self._attempt(packing, ftol, max_iter, params, parent, t0)
        if result is None or not result.converged:
            self.counters["n_fire_fallbacks"] += 1
            self.fac, self.age = None, 0
            result = self._fire(packing, ftol, max_iter, params, t0)
        self.reference = result.packing if result.converged else None
        return result

    def _fire(self, packing: Packing, ftol: float, max_iter: int,
              params: FireParameters | None, t0: float) -> MinimizeResult:
        """The fallback: FIRE from ``packing`` to ``max_i |F_i| < finish_below``, then Newton
        from that point (its own parent: its contacts the first active set, a factor made
        there) to ``ftol``, accepted as any Newton point is (module docstring); FIRE goes on
        from the loose point where Newton does not accept. Without ``finish_below`` (or at or
        below ``ftol``) FIRE to ``ftol``. Why: FIRE's last decades of force are a slow
        approach along the soft modes (``docs/aqs.md``, "A FIRE fallback finished by
        Newton")."""
        if self.finish_below is None or not self.finish_below > ftol:
            return minimize(packing, ftol=ftol, max_iter=max_iter, params=params,
                            skin=RELAX_SKIN)
        loose = minimize(packing, ftol=self.finish_below, max_iter=max_iter, params=params,
                         skin=RELAX_SKIN)
        if not loose.converged:
            return loose
        fin = self._attempt(loose.packing, ftol, max_iter, params, loose.packing, t0)
        if fin is not None and fin.converged:
            self.counters["n_fire_finished_by_newton"] += 1
        else:
            self.fac, self.age = None, 0
            fin = minimize(loose.packing, ftol=ftol, max_iter=max(0, max_iter - loose.iterations),
                           params=params, skin=RELAX_SKIN)
        return replace(fin, iterations=loose.iterations + fin.iterations,
                       time=time.perf_counter() - t0)

    def newton_only(
        self,
        packing: Packing,
        ftol: float = 1e-12,
        max_iter: int = 1_000_000,
        params: FireParameters | None = None,
        parent: Packing | None = None,
    ) -> MinimizeResult:
        """The minimum on ``parent``'s branch reached from ``packing`` by Newton alone, or a
        result with ``converged=False`` (``packing`` unchanged) where :meth:`__call__` would
        hand the problem to FIRE: a probe of whether the branch of ``parent`` continues to
        ``packing``'s strain (:func:`jamlab.spheres.confirm.jump_located`). A caged rattler is
        still polished by FIRE from the backbone's minimum (the backbone is on the branch).
        The stored factor is kept on failure (the branch ended; the parent is still a
        minimum)."""
        t0 = time.perf_counter()
        result = self._attempt(packing, ftol, max_iter, params, parent, t0)
        if result is not None and result.converged:
            self.reference = result.packing
            return result
        self.reference = None
        return MinimizeResult(packing=packing, energy=math.nan, max_force=math.inf,
                              iterations=0 if result is None else result.iterations,
                              converged=False, time=time.perf_counter() - t0, ftol=float(ftol))

    def _attempt(
        self, packing: Packing, ftol: float, max_iter: int, params: FireParameters | None,
        parent: Packing | None, t0: float,
    ) -> MinimizeResult | None:
        """Newton from ``packing`` on ``parent``'s network (the last minimum returned without
        it), counted as a call and, if it converged, as accepted; ``None`` where it does not
        apply (no parent, another law or size, no usable factor)."""
        self.counters["n_newton_calls"] += 1
        parent = self.reference if parent is None else parent
        result = (None if parent is None
                  else self._newton(packing, parent, ftol, t0, max_iter, params))
        if result is not None and result.converged:
            self.counters["n_newton_accepted"] += 1
        return result

    def _network(self, minimum: Packing) -> tuple:
        """``(ci, cj, backbone, separations, neighbour list)`` of a minimum (the last few are
        kept: a step's volume iterations and substeps ask for the same parents again)."""
        for known, data in self._known:
            if known is minimum:
                return data
        nl = NeighborList(minimum, skin=RELAX_SKIN)
        ci, cj, cd = contact_list(minimum, nl)
        data = (ci, cj, backbone_mask(ci, cj, minimum.n, minimum.dim), cd, nl)
        self._known.insert(0, (minimum, data))
        del self._known[4:]
        return data

    def _factor(self, parent: Packing) -> Factor | None:
        """A positive definite factor on ``parent``'s backbone: the stored one, or one made at
        ``parent`` (when there is none, it is ``refactor_every`` calls old, or its backbone is
        not the parent's)."""
        ci, cj, backbone, cd, nl = self._network(parent)
        if (self.fac is None or self.age >= self.refactor_every
                or not np.array_equal(self.fac.backbone, backbone)):
            self.fac = factorise(parent, nl, backbone, (ci, cj, cd), positive_only=True)
            self.age = 0
            self.counters["n_factorisations"] += 1
        self.age += 1
        return self.fac if _usable(self.fac) else None

    def _active_set(
        self, packing: Packing, fac: Factor, nl: NeighborList, pairs: tuple, ftol: float
    ) -> tuple[Packing | None, Evaluation | None, tuple | None]:
        """The minimum near ``packing`` on ``fac``'s backbone, starting from the network
        ``pairs``: the minimum of a contact network (smooth; Newton converges in two or three
        steps), then the network replaced by the backbone pairs that overlap there, until the
        network's minimum overlaps exactly its own pairs; then the rattlers are moved out of
        their overlaps (at a minimum they carry no force), one at a time and, where that does
        not free them, together (:func:`minimize_rattlers`). Returns ``(minimum, evaluation,
        None)`` (the evaluation where one was made here, else ``None``); ``(None, None, None)``
        when the iteration fails; ``(None, None, (network minimum, settled))`` when
        a rattler cannot be freed (caged: at the minimum it joins the backbone), ``settled`` the
        network minimum with the rattlers moved as far as they go (:func:`settle_rattlers`).
        A backbone particle that loses contacts in a round leaves the backbone (a new factor on
        the smaller one)."""
        bb = fac.backbone
        ci, cj, keys = _backbone_pairs(*pairs, bb, packing.n)
        start = packing
        # a margin below ftol for the free particles (the full evaluation decides)
        inner = 0.5 * ftol
        for _ in range(self.max_active_sets):
            # the factor corrected (Woodbury) for the network's pairs that are not its own
            dr = start.box.minimum_image(start.positions[ci] - start.positions[cj])
            fac.update(ci, cj, dr, self.aqs_params.max_corrections)
            res = damped_newton(start, fac.free, NetworkModel(ci, cj, fac), fac.solve, inner,
                                self.aqs_params, forcing=self.forcing)
            self.counters["n_newton_iterations"] += res.iterations
            self.counters["n_cg_iterations"] += res.cg_iterations
            if not res.ok:
                return None, None, None
            ci, cj, new_keys = _backbone_pairs(*contact_list(res.packing, nl)[:2], bb, packing.n)
            if np.array_equal(new_keys, keys):
                break
            self.counters["n_contact_changes"] += 1
            keys, start = new_keys, res.packing
            shrunk = backbone_mask(ci, cj, packing.n, packing.dim)
            if not np.array_equal(shrunk, bb):
                # a backbone particle lost contacts (it is a rattler now): factorise on the
                # smaller backbone at this point, whose Hessian is otherwise singular there
                bb = shrunk
                ci, cj, keys = _backbone_pairs(ci, cj, bb, packing.n)
                dr = start.box.minimum_image(start.positions[ci] - start.positions[cj])
                fac = self.fac = factorise(start, nl, bb, (ci, cj, dr), positive_only=True)
                self.age = 1
                self.counters["n_factorisations"] += 1
                if not _usable(fac):
                    return None, None, None
        else:
            return None, None, None
        moved, caged = settle_rattlers(res.packing, bb, self.rattler_iterations)
        if caged and self.settle_caged:
            # not freed one at a time: all rattlers together (two that block each other)
            moved, worst = minimize_rattlers(moved, bb, ftol)
            if worst < 0.125 * ftol:
                ev = evaluate(moved)
                if ev.max_force < ftol:
                    self.counters["n_rattlers_moved_together"] += 1
                    return moved, ev, None
        return (None, None, (res.packing, moved)) if caged else (moved, None, None)

    def _newton(
        self, packing: Packing, parent: Packing, ftol: float, t0: float, max_iter: int,
        params: FireParameters | None, rejoin: bool = True,
    ) -> MinimizeResult | None:
        if packing.alpha != 2.0:
            return None  # (α ≠ 2: the continued law's springs and tests assume the harmonic law)
        if parent.n != packing.n or parent.dim != packing.dim:
            return None
        fac = self._factor(parent)
        if fac is None:
            return None
        nl = NeighborList(packing, skin=RELAX_SKIN)
        ci, cj = self._network(parent)[:2]
        moved, ev, caged = self._active_set(packing, fac, nl, (ci, cj), ftol)
        if caged is not None:
            network_minimum, settled = caged
            if not rejoin:
                return None  # caged again: the first attempt's FIRE polish
            if self.settle_caged:
                # the backbone is at its minimum, a rattler is caged and pushes on its cage's
                # walls: Newton once more from there, with that point as its own parent (its
                # contacts, the caged rattler's among them, the first active set and a factor
                # made on its backbone, which the rattler joins), accepted as any Newton point
                again = self._newton(settled, settled, ftol, t0, max_iter, params, rejoin=False)
                if again is not None and again.converged:
                    self.counters["n_rattler_rejoined"] += 1
                    return again
            # FIRE from the backbone's minimum (it relaxes the rattler, and the backbone where
            # the rattler joins it; ≈ 1.4k iterations measured at N = 500, p = 1e-4, against
            # 2–3k from the start)
            self.counters["n_rattler_polish"] += 1
            return minimize(network_minimum, ftol=ftol, max_iter=max_iter, params=params,
                            skin=RELAX_SKIN)
        if moved is None:
            return None
        if ev is None:
            ev = evaluate(moved)
        if not ev.max_force < ftol:
            return None
        return MinimizeResult(
            packing=moved,
            energy=float(ev.energy),
            max_force=float(ev.max_force),
            iterations=0,
            converged=True,
            time=time.perf_counter() - t0,
            ftol=float(ftol),
        )
