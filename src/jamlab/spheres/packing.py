"""Jammed and over-jammed (UNSAT) packings, and the coordination curve (paper Fig. 1).

Conventions are those of ``SPEC.md`` §3 (diameter 1, ``V(r) = (1 − r)²``, total energy ``E``,
pressure ``p = −(1/(d L^d)) Σ_{i<j} V'(r_ij) r_ij``, contacts ``r_ij < 1``, ``z = 2N_c/N``,
rattlers removed repeatedly when they have fewer than ``d + 1`` contacts, ``z_nr = 2N_c'/N'``).

A packing is *isostatic* when its rattler-free backbone has exactly the number of contacts needed
for rigidity in a periodic box, ``N_c' = d(N' − 1) + 1`` (``d(N'−1)`` non-trivial degrees of
freedom, plus one for the box volume / pressure); equivalently ``z_nr = z_iso(N')`` with

    z_iso(N') = 2 (d (N' − 1) + 1) / N'  →  2d  as  N' → ∞.

Minimisation (:func:`relax`): FIRE 2.0 from :mod:`jamlab.spheres.fire` with its defaults,
``Δt_max = 0.3`` (see :data:`JAM_FIRE`), until ``max_i |F_i| < ftol``.

The jamming protocol (:func:`jam`) and its stopping rule are documented in ``docs/packings.md``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from jamlab.spheres.box import Box, box_length_for
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.potential import (
    Packing,
    contacts,
    energy_and_forces,
    pressure,
    random_packing,
    remove_rattlers,
)

__all__ = [
    "RelaxResult",
    "PackingState",
    "PreparedPacking",
    "CoordinationCurve",
    "JAM_FIRE",
    "JammingError",
    "MinimizationStep",
    "SEARCHES",
    "rescale",
    "relax",
    "compress_to",
    "describe",
    "isostatic_contacts",
    "z_iso",
    "jam",
    "prepare",
    "coordination_curve",
    "fit_power_law",
    "fit_power_law_corrected",
]


# ------------------------------------------------------------------------------------------------
# affine rescaling and minimisation


def rescale(packing: Packing, phi: float) -> Packing:
    """Affine rescale to packing fraction ``φ``: ``L' = (N v_d(1/2)/φ)^(1/d)``, ``r_i → r_i L'/L``.

    Reduced coordinates and strain are kept.
    """
    if not (isinstance(phi, int | float | np.floating) and math.isfinite(phi) and phi > 0):
        raise ValueError(f"packing fraction must be finite and > 0, got phi={phi!r}")
    length = box_length_for(packing.n, packing.dim, float(phi))
    scale = length / packing.box.length
    return replace(
        packing,
        positions=packing.positions * scale,
        box=Box(length, packing.dim, packing.box.strain),
    )


JAM_FIRE = FireParameters()
"""FIRE parameters used here: the engine defaults, ``Δt_max = 0.3``. The largest pair stiffness is
``V'' = 2``, so the highest vibrational frequency of a packing is ``ω_max ≈ √(2·2z) ≈ 5–7`` and
semi-implicit Euler is stable only for ``Δt < 2/ω_max ≈ 0.3``; with ``Δt_max = 1`` (the engine
default until this was measured) FIRE oscillates and near jamming stalls (``docs/spheres.md``)."""


@dataclass(frozen=True, eq=False)
class RelaxResult:
    """Outcome of :func:`relax`: the minimum ``packing``, its total ``energy`` and ``pressure``,
    ``max_force = max_i |F_i|``, whether ``max_force < ftol`` (``converged``), FIRE ``iterations``
    and wall-clock ``time`` (s)."""

    packing: Packing
    energy: float
    pressure: float
    max_force: float
    converged: bool
    iterations: int
    time: float
    ftol: float


def relax(
    packing: Packing,
    ftol: float = 1e-12,
    max_iter: int = 1_000_000,
    params: FireParameters | None = None,
) -> RelaxResult:
    """Energy minimum at fixed box with FIRE (:func:`jamlab.spheres.fire.minimize`, parameters
    :data:`JAM_FIRE` unless given) until ``max_i |F_i| < ftol`` (a maximum over particles).

    Non-convergence is reported (``converged=False``), not raised.
    """
    r = minimize(packing, ftol=ftol, max_iter=max_iter, params=params or JAM_FIRE)
    return RelaxResult(
        packing=r.packing,
        energy=r.energy,
        pressure=pressure(r.packing),
        max_force=r.max_force,
        converged=r.converged,
        iterations=r.iterations,
        time=r.time,
        ftol=r.ftol,
    )


def compress_to(
    packing: Packing, phi: float, ftol: float = 1e-12, max_iter: int = 1_000_000
) -> RelaxResult:
    """The minimum at packing fraction ``φ`` reached from ``packing``: affine :func:`rescale` to
    ``φ`` (compression if ``φ`` is larger, decompression otherwise), then :func:`relax`."""
    return relax(rescale(packing, phi), ftol=ftol, max_iter=max_iter)


# ------------------------------------------------------------------------------------------------
# contact statistics


def isostatic_contacts(n_nonrattlers: int, dim: int) -> int:
    """``N_c,iso = d (N' − 1) + 1`` contacts for a rigid backbone of ``N'`` particles."""
    return dim * (n_nonrattlers - 1) + 1


def z_iso(n_nonrattlers: int | np.ndarray, dim: int) -> float | np.ndarray:
    """``z_iso(N') = 2(d(N' − 1) + 1)/N'``, the isostatic coordination at finite ``N'``."""
    n = np.asarray(n_nonrattlers, dtype=np.float64)
    out = 2.0 * (dim * (n - 1.0) + 1.0) / n
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True)
class PackingState:
    """Contact statistics of a minimum: ``phi``, total ``energy``, ``pressure``, ``z = 2N_c/N``,
    ``z_nr = 2N_c'/N'``, ``n_rattlers = N − N'``, ``n_contacts`` (N_c), ``n_contacts_nr`` (N_c'),
    ``n_contacts_iso = d(N'−1)+1``, ``isostatic`` (``N_c' == n_contacts_iso``)."""

    phi: float
    energy: float
    pressure: float
    z: float
    z_nr: float
    n_rattlers: int
    n_contacts: int
    n_contacts_nr: int
    n_contacts_iso: int
    isostatic: bool

    def as_attrs(self, prefix: str = "") -> dict[str, float | int | bool]:
        """The fields as a flat dict (HDF5 attributes)."""
        return {f"{prefix}{k}": v for k, v in self.__dict__.items()}


def describe(packing: Packing, energy: float | None = None) -> PackingState:
    """Contact statistics of ``packing`` (see :class:`PackingState`)."""
    ci, _, _ = contacts(packing)
    rr = remove_rattlers(packing)
    n_kept = packing.n - rr.n_rattlers
    n_iso = isostatic_contacts(n_kept, packing.dim) if n_kept > 0 else 0
    if energy is None:
        energy = energy_and_forces(packing)[0]
    return PackingState(
        phi=packing.phi,
        energy=float(energy),
        pressure=pressure(packing),
        z=2.0 * len(ci) / packing.n,
        z_nr=rr.z_nr,
        n_rattlers=rr.n_rattlers,
        n_contacts=len(ci),
        n_contacts_nr=rr.n_contacts_nr,
        n_contacts_iso=n_iso,
        isostatic=bool(n_kept > 0 and rr.n_contacts_nr == n_iso),
    )


# ------------------------------------------------------------------------------------------------
# jammed and UNSAT packings

ProgressCallback = Callable[[str], None]


class JammingError(RuntimeError):
    """Raised by :func:`jam` with ``strict=True`` when the protocol fails; carries ``result``."""

    def __init__(self, result: PreparedPacking) -> None:
        super().__init__(result.reason)
        self.result = result


@dataclass(frozen=True, eq=False)
class PreparedPacking:
    """A prepared packing and how it was made.

    ``protocol`` is ``"jamming"`` (:func:`jam`) or ``"direct"`` (:func:`prepare`). ``state`` holds
    the contact statistics; ``phi_j`` is ``φ_J`` (the final packing fraction of a jamming run, NaN
    for ``"direct"``). ``converged`` says the last minimisation met ``ftol``; ``ok`` says the
    packing satisfies its protocol's stopping rule; if not, ``reason`` says why. ``history`` lists
    ``(φ, p, jammed)`` for every minimisation in order (over all attempts), ``steps`` the same
    minimisations in full (:class:`MinimizationStep`: start, tolerances, role; :func:`jam` only);
    ``params`` the protocol parameters; ``n_restarts`` how many failed attempts :func:`jam`
    discarded.
    """

    packing: Packing
    state: PackingState
    protocol: str
    phi_j: float
    converged: bool
    ok: bool
    reason: str
    n_minimizations: int
    fire_iterations: int
    time: float
    params: dict[str, float | int | str] = field(default_factory=dict)
    history: tuple[tuple[float, float, bool], ...] = ()
    n_restarts: int = 0
    steps: tuple[MinimizationStep, ...] = ()

    def attrs(self) -> dict[str, float | int | str | bool]:
        """Flat HDF5 attributes: the state, ``phi_j``, flags, ``reason``, counts and
        ``param_*``."""
        out: dict[str, float | int | str | bool] = dict(self.state.as_attrs())
        out.pop("phi")
        out.update(
            protocol=self.protocol,
            phi_j=self.phi_j,
            converged=self.converged,
            ok=self.ok,
            reason=self.reason,
            n_minimizations=self.n_minimizations,
            fire_iterations=self.fire_iterations,
            n_restarts=self.n_restarts,
            time_seconds=self.time,
        )
        out.update({f"param_{k}": v for k, v in self.params.items()})
        return out


def _check_common(n: int, dim: int, seed: int, ftol: float) -> None:
    if not (isinstance(n, int | np.integer) and not isinstance(n, bool) and n >= 2):
        raise ValueError(f"number of particles must be an integer >= 2, got n={n!r}")
    if not (isinstance(dim, int | np.integer) and not isinstance(dim, bool) and dim >= 2):
        raise ValueError(f"dimension must be an integer >= 2, got dim={dim!r}")
    if not (isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got seed={seed!r}")
    if not (isinstance(ftol, int | float) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")


def _quench_seed(seed: int, attempt: int) -> int:
    """Seed of the random start of attempt ``attempt`` (0: ``seed`` itself; later attempts: an
    independent stream derived from ``(seed, attempt)`` with :class:`numpy.random.SeedSequence`)."""
    if attempt == 0:
        return int(seed)
    return int(np.random.SeedSequence([int(seed), int(attempt)]).generate_state(1, np.uint64)[0])


@dataclass(frozen=True)
class MinimizationStep:
    """One FIRE minimisation of :func:`jam`, enough to replay the schedule elsewhere (LAMMPS).

    ``start`` is the index (in :attr:`PreparedPacking.steps`) of the minimum this one starts
    from, affinely rescaled to ``phi``; ``-1`` means the random positions of ``attempt``
    (:func:`random_packing` with seed ``_quench_seed(seed, attempt)`` at ``phi``). ``ftol`` and
    ``max_iter`` are the minimiser's stopping rules; ``role`` says why the minimisation was run
    (``quench``, ``compress``, ``search``, ``polish``, ``recompress``); ``pressure``,
    ``excess = N_c' − N_c,iso``, ``jammed``, ``converged`` and ``iterations`` its outcome."""

    attempt: int
    role: str
    phi: float
    start: int
    ftol: float
    max_iter: int
    pressure: float
    excess: int
    jammed: bool
    converged: bool
    iterations: int


@dataclass
class _Attempt:
    """Outcome of one quench + search (internal to :func:`jam`)."""

    last: RelaxResult
    state: PackingState
    ok: bool
    reason: str
    restartable: bool
    fire_iterations: int


@dataclass
class _Node:
    """A minimum reached by :func:`jam`: its index in the step list, result and statistics."""

    index: int
    r: RelaxResult
    state: PackingState
    jammed: bool

    @property
    def phi(self) -> float:
        return self.r.packing.phi

    @property
    def p(self) -> float:
        return self.r.pressure

    @property
    def excess(self) -> int:
        return self.state.n_contacts_nr - self.state.n_contacts_iso


class _Runner:
    """Runs and records the minimisations of one :func:`jam` attempt."""

    def __init__(
        self,
        steps: list[MinimizationStep],
        attempt: int,
        ftol: float,
        max_iter: int,
        p_jammed: float,
        progress: ProgressCallback | None,
    ) -> None:
        self.steps = steps
        self.attempt = attempt
        self.ftol = ftol
        self.max_iter = max_iter
        self.p_jammed = p_jammed
        self.progress = progress
        self.fire_iterations = 0
        self.count = 0  # minimisations of this attempt

    def jammed(self, r: RelaxResult, state: PackingState) -> bool:
        # a hypostatic backbone cannot carry a pressure: a residual p there is unrelaxed noise
        return r.pressure > self.p_jammed and state.n_contacts_nr >= state.n_contacts_iso

    def run(
        self,
        packing: Packing,
        phi: float,
        start: int,
        role: str,
        ftol: float | None = None,
        max_iter: int | None = None,
    ) -> _Node:
        """Minimise ``packing`` (already at ``phi``: the value its box was computed from) and
        record the step."""
        ftol = self.ftol if ftol is None else ftol
        max_iter = self.max_iter if max_iter is None else max_iter
        r = relax(packing, ftol, max_iter)
        self.fire_iterations += r.iterations
        self.count += 1
        state = describe(r.packing, r.energy)
        node = _Node(len(self.steps), r, state, self.jammed(r, state))
        self.steps.append(
            MinimizationStep(
                attempt=self.attempt,
                role=role,
                phi=float(phi),
                start=start,
                ftol=float(ftol),
                max_iter=int(max_iter),
                pressure=float(r.pressure),
                excess=node.excess,
                jammed=node.jammed,
                converged=r.converged,
                iterations=int(r.iterations),
            )
        )
        if self.progress is not None:
            self.progress(
                f"phi={phi:.10f} p={r.pressure:.3e} excess contacts {node.excess} "
                f"[{role}] ({len(self.steps)} minimisations)"
            )
        return node


def _not_converged(node: _Node) -> str:
    r = node.r
    return (
        f"minimisation at phi={r.packing.phi:.10f} did not converge "
        f"(max force {r.max_force:.3e} >= ftol {r.ftol:.1e})"
    )


def _quench_and_compress(
    run: _Runner,
    n: int,
    dim: int,
    quench_seed: int,
    phi_init: float,
    compress_factor: float,
    max_minimizations: int,
    classify: Callable[[_Node], _Node],
) -> tuple[_Node, float, str, bool]:
    """Steps 1–2 of :func:`jam`: quench at ``φ_init`` and compress until jammed.

    Returns ``(node, lo_phi, reason, restartable)``: the first jammed minimum and the highest
    unjammed ``φ`` below it, or a failure ``reason``."""
    node = classify(run.run(random_packing(n, dim, phi_init, quench_seed), phi_init, -1, "quench"))
    lo_phi = -math.inf
    step = compress_factor - 1.0
    while True:
        if not node.r.converged:
            return node, lo_phi, _not_converged(node), False
        if node.jammed:
            return node, lo_phi, "", False
        lo_phi = node.phi
        nxt = lo_phi * (1.0 + step)
        step *= 2.0
        if nxt >= _PHI_MAX or run.count >= max_minimizations:
            return (
                node,
                lo_phi,
                f"not jammed after compressing from phi_init={phi_init} to phi={lo_phi:.6f} "
                f"(p={node.p:.3e}, {run.count} minimisations)",
                True,
            )
        node = classify(run.run(rescale(node.r.packing, nxt), nxt, node.index, "compress"))


def _jam_attempt(
    n: int,
    dim: int,
    quench_seed: int,
    p_target: float,
    phi_init: float,
    ftol: float,
    p_floor_factor: float,
    compress_factor: float,
    max_minimizations: int,
    max_iter: int,
    progress: ProgressCallback | None,
    steps: list[MinimizationStep],
    attempt: int,
    search: str,
    confirm_ftol_factor: float,
) -> _Attempt:
    """One quench from random positions at ``φ_init`` and the search of :func:`jam`.

    ``search="window"`` (the only one; ``"halve"`` was removed in issue 14) is the protocol of
    ``docs/packings.md``."""
    p_floor = p_target * p_floor_factor
    p_jammed = p_floor / 10.0
    lo_win, hi_win = 0.5 * p_target, 2.0 * p_target
    window = search == "window"
    run = _Runner(steps, attempt, ftol, max_iter, p_jammed, progress)

    def out(node: _Node, ok: bool, reason: str, restartable: bool = False) -> _Attempt:
        return _Attempt(node.r, node.state, ok, reason, restartable, run.fire_iterations)

    def classify(node: _Node) -> _Node:
        # near the window a single contact decides: a pair whose overlap or gap is below the
        # position resolution of ftol is ambiguous, so the count is redone at ftol * factor
        if window and node.r.converged and p_jammed < node.p <= hi_win and abs(node.excess) <= 1:
            phi = run.steps[node.index].phi
            node = run.run(node.r.packing, phi, node.index, "polish", ftol * confirm_ftol_factor)
        return node

    def minimise(start: _Node, phi: float, role: str) -> _Node:
        return classify(run.run(rescale(start.r.packing, phi), phi, start.index, role))

    node, lo_phi, reason, restartable = _quench_and_compress(
        run, n, dim, quench_seed, phi_init, compress_factor, max_minimizations, classify
    )
    if reason:
        return out(node, False, reason, restartable)

    # 3. secant / bisection between the highest unjammed and the last jammed phi
    hi = node
    slope = 1.0
    p_goal = p_target
    last = node
    max_down = math.inf  # largest decompression from hi allowed (halved after a saddle)
    while run.count < max_minimizations:
        if window and hi.state.isostatic and hi.p <= hi_win:
            if hi.p >= lo_win:
                return out(hi, True, "")
            break  # isostatic below the window: re-compress (step 4)
        phi_hi, p_hi = hi.phi, hi.p
        if phi_hi - lo_phi <= 1e-13 * phi_hi and p_hi > 2 * p_target:
            # the bracket closed on a finite pressure: its lower end belongs to another branch
            # (the jammed state rearranged on decompression), so it bounds nothing here
            lo_phi = -math.inf
        # (window) at most a factor _MAX_DROP in pressure per decompression: larger ones set off
        # long rearrangements near jamming
        p_aim = max(p_goal, p_hi / _MAX_DROP) if window else p_goal
        target = phi_hi + (p_aim - p_hi) / slope
        if not lo_phi < target:
            target = 0.5 * (lo_phi + phi_hi)
        target = max(target, phi_hi - max_down)
        node = minimise(hi, target, "search")
        last = node
        if not node.r.converged:
            return out(node, False, _not_converged(node))
        if not node.jammed:
            if node.p > p_jammed:
                # stressed but hypostatic: a saddle reached on decompression (seen at N = 16),
                # not an unjammed state; retry a smaller decompression from hi
                max_down = 0.5 * (phi_hi - target)
                if max_down < 1e-12 * phi_hi:
                    return out(
                        node,
                        False,
                        f"every decompression from the jammed state at phi={phi_hi:.12f} "
                        f"(p={p_hi:.3e}) ends on a stressed hypostatic saddle",
                        True,
                    )
            else:
                lo_phi = target
            continue
        max_down = math.inf
        if node.phi != phi_hi:
            k = (node.p - p_hi) / (node.phi - phi_hi)
            if k > 0 and math.isfinite(k):
                slope = k
        hi = node
        if node.p <= hi_win:
            if node.state.isostatic and (node.p >= lo_win or p_goal < lo_win):
                # (halve: below p_target/2 only when the search went on to remove excess contacts)
                if window and node.p < lo_win:
                    continue  # re-compress (step 4)
                return out(node, True, "")
            if not node.state.isostatic:
                if window and node.p * _SCAN_RATIO >= lo_win:
                    # excess contacts inside the window: a smaller decompression first
                    p_goal = node.p * _SCAN_RATIO
                else:
                    p_goal = min(p_goal, node.p) / 2
                if p_goal < p_floor:
                    return out(
                        node,
                        False,
                        f"still {node.excess} excess contacts at p={node.p:.3e} "
                        f"(p_floor={p_floor:.1e}): hyperstatic at jamming",
                        True,
                    )
    else:
        return out(
            last,
            False,
            f"no isostatic packing with p <= 2 p_target after {max_minimizations} minimisations",
            True,
        )

    # 4. (window) re-compress the isostatic state found below the window, along its branch:
    # secant towards _RECOMPRESS_AIM * p_target/2, then bisection between the highest isostatic
    # minimum below the window and the lowest one with excess contacts (or above the window)
    base = lo = hi
    k = 1.0
    bad_phi = math.inf
    why = f"none found in {_RECOMPRESS_TRIES} re-compressions"
    for _ in range(_RECOMPRESS_TRIES):
        if run.count >= max_minimizations:
            why = f"{max_minimizations} minimisations used"
            break
        if math.isinf(bad_phi):
            phi = lo.phi + (_RECOMPRESS_AIM * lo_win - lo.p) / k
        else:
            phi = 0.5 * (lo.phi + bad_phi)
        if not lo.phi < phi < bad_phi:
            why = "the bisection closed"
            break
        node = minimise(lo, phi, "recompress")
        if not node.r.converged:
            return out(node, False, _not_converged(node))
        if not node.jammed:
            why = "the branch rearranged on re-compression"
            break
        if node.p > lo.p:
            k = (node.p - lo.p) / (node.phi - lo.phi)
        if node.state.isostatic:
            if lo_win <= node.p <= hi_win:
                return out(node, True, "")
            if node.p < lo_win:
                lo = node
            else:
                bad_phi = phi
            continue
        if node.p < lo_win:
            why = f"a contact is added at p={node.p:.3e}, below the window"
            break
        bad_phi = phi
    return out(
        node,
        False,
        f"no isostatic state with p in [{lo_win:.2e}, {hi_win:.2e}] on the branch of the "
        f"isostatic minimum at phi={base.phi:.12f} (p={base.p:.3e}) re-compressed: {why}",
        True,
    )


_PHI_MAX = 0.95
"""Upper bound of the compression of an unjammed quench in :func:`jam`."""

_MAX_DROP = 10.0
"""``search="window"``: a decompression aims at no less than ``1/_MAX_DROP`` of the pressure it
starts from."""

_SCAN_RATIO = 0.7
"""``search="window"``: with excess contacts inside the window the goal pressure is lowered by
this factor (instead of halved) while it stays in the window."""

_RECOMPRESS_AIM = 1.25
"""``search="window"``: the re-compression aims at ``_RECOMPRESS_AIM × p_target/2``, the lower
part of the window, because contacts are added as the pressure rises; once a minimum with excess
contacts (or above the window) is found, it bisects in ``φ``."""

_RECOMPRESS_TRIES = 10
"""``search="window"``: at most this many re-compressions per attempt."""

SEARCHES = ("window",)


def jam(
    n: int,
    dim: int = 3,
    seed: int = 0,
    p_target: float = 1e-7,
    phi_init: float = 0.66,
    ftol: float = 1e-12,
    p_floor_factor: float = 1e-3,
    compress_factor: float = 1.01,
    max_minimizations: int = 60,
    max_restarts: int = 10,
    max_iter: int = 1_000_000,
    strict: bool = False,
    progress: ProgressCallback | None = None,
    search: str = "window",
    confirm_ftol_factor: float = 0.1,
) -> PreparedPacking:
    """A packing at the jamming point by quench and decompression/compression steps.

    1. Uniformly random positions at ``φ_init`` (:func:`random_packing` with ``seed``), minimised
       (an infinitely fast quench, O'Hern et al. 2003).
    2. If that minimum is not jammed (small ``N`` jams over a wide range of ``φ``), compress it
       affinely and minimise again, ``φ_{k+1} = φ_k (1 + (compress_factor − 1) 2^k)``, until it is
       (or ``φ`` would exceed 0.95).
    3. Every later minimisation starts from the last *jammed* minimum (``p > p_target ×
       p_floor_factor / 10`` and a backbone that is not hypostatic), affinely rescaled to the next
       ``φ``, chosen by a secant step on ``p(φ) ≈ k (φ − φ_J)`` towards the goal pressure
       ``p_goal`` (slope ``k`` from the last two jammed minima; ``k = 1`` at first; with
       ``search="window"`` aiming at no less than a tenth of the current pressure), or by
       bisection between the last jammed and the highest unjammed ``φ`` when the secant step
       would leave that bracket. A decompression that ends on a *stressed* hypostatic minimum
       (``p > 0`` but ``N_c' < d(N'−1)+1``: a saddle, seen at ``N = 16``) does not bound
       ``φ_J``: the next decompression from the jammed state is halved. If the bracket closes on
       a finite pressure its lower end came from another branch (a rearrangement) and is
       dropped. With ``search="window"`` every converged minimum with ``p ≤ 2 p_target`` and
       ``|N_c' − N_c,iso| ≤ 1`` is first polished to ``ftol × confirm_ftol_factor`` (its
       contact count is decided there).
    4. Stop when ``p ∈ [p_target/2, 2 p_target]`` and the backbone is isostatic,
       ``N_c' = d(N' − 1) + 1``. With excess contacts inside the window, ``search="window"``
       lowers ``p_goal`` by 0.7 while it stays in the window, then halves it; an isostatic
       minimum found below the window is re-compressed along its branch (secant in ``φ``
       towards ``0.625 p_target``, then bisection between the highest isostatic minimum below
       the window and the lowest one with excess contacts) until an isostatic state inside the
       window is found; if a contact is added below ``p_target/2`` there is none and the
       attempt fails (restart).
    5. An attempt that fails for a structural reason — excess contacts that survive down to
       ``p_floor = p_target × p_floor_factor`` (a non-generic, hyperstatic jammed state, e.g.
       local crystalline order at small ``N``), only saddles below the jammed state, no jammed
       state below ``φ = 0.95``, no isostatic state in the window on the re-compressed branch,
       or ``max_minimizations`` used up — is discarded and the protocol
       restarts from new random positions (seed derived from ``(seed, attempt)``, see
       :func:`_quench_seed`), at most ``max_restarts`` times. The number of restarts is recorded
       (``n_restarts``).

    Every minimisation is listed in ``steps`` (:class:`MinimizationStep`), so the schedule can
    be replayed exactly.

    Returns a :class:`PreparedPacking` with ``ok=False`` and a ``reason`` if a minimisation does
    not converge (no restart: that is a numerical failure), or if every attempt fails
    (``strict=True`` raises :class:`JammingError` instead).
    """
    _check_common(n, dim, seed, ftol)
    if not (isinstance(p_target, int | float) and math.isfinite(p_target) and p_target > 0):
        raise ValueError(f"target pressure must be finite and > 0, got p_target={p_target!r}")
    if not (isinstance(phi_init, int | float) and 0 < phi_init < _PHI_MAX):
        raise ValueError(
            f"initial packing fraction must be in (0, {_PHI_MAX}), got phi_init={phi_init!r}"
        )
    if not 0 < p_floor_factor <= 0.5:
        raise ValueError(f"p_floor_factor must be in (0, 0.5], got {p_floor_factor!r}")
    if not (isinstance(compress_factor, int | float) and 1 < compress_factor < 2):
        raise ValueError(f"compress_factor must be in (1, 2), got {compress_factor!r}")
    if not (isinstance(max_restarts, int) and max_restarts >= 0):
        raise ValueError(f"max_restarts must be an integer >= 0, got {max_restarts!r}")
    if search not in SEARCHES:
        raise ValueError(f"search must be one of {', '.join(SEARCHES)}, got {search!r}")
    if not (isinstance(confirm_ftol_factor, int | float) and 0 < confirm_ftol_factor <= 1):
        raise ValueError(f"confirm_ftol_factor must be in (0, 1], got {confirm_ftol_factor!r}")
    t0 = time.perf_counter()
    params: dict[str, float | int | str] = dict(
        p_target=float(p_target),
        phi_init=float(phi_init),
        ftol=float(ftol),
        p_floor_factor=float(p_floor_factor),
        compress_factor=float(compress_factor),
        max_minimizations=int(max_minimizations),
        max_restarts=int(max_restarts),
        max_iter=int(max_iter),
        fire_dt_max=JAM_FIRE.dt_max,
        n=int(n),
        dim=int(dim),
        seed=int(seed),
        search=str(search),
    )
    if search == "window":
        params.update(confirm_ftol_factor=float(confirm_ftol_factor))
    steps: list[MinimizationStep] = []
    fire_it = 0
    reasons: list[str] = []
    for attempt in range(int(max_restarts) + 1):
        a = _jam_attempt(
            int(n),
            int(dim),
            _quench_seed(int(seed), attempt),
            float(p_target),
            float(phi_init),
            float(ftol),
            float(p_floor_factor),
            float(compress_factor),
            int(max_minimizations),
            int(max_iter),
            progress,
            steps,
            attempt,
            search,
            float(confirm_ftol_factor),
        )
        fire_it += a.fire_iterations
        reason = a.reason
        if not a.ok and a.restartable:
            reasons.append(f"attempt {attempt}: {a.reason}")
            if attempt < max_restarts:
                if progress is not None:
                    progress(f"restart {attempt + 1}: {a.reason}")
                continue
            reason = f"all {attempt + 1} attempts failed ({'; '.join(reasons)})"
        break
    res = PreparedPacking(
        packing=a.last.packing,
        state=a.state,
        protocol="jamming",
        phi_j=a.last.packing.phi,
        converged=a.last.converged,
        ok=a.ok,
        reason=reason,
        n_minimizations=len(steps),
        fire_iterations=fire_it,
        time=time.perf_counter() - t0,
        params=params,
        history=tuple((s.phi, s.pressure, s.jammed) for s in steps),
        n_restarts=attempt,
        steps=tuple(steps),
    )
    if strict and not res.ok:
        raise JammingError(res)
    return res


def prepare(
    n: int, dim: int, phi: float, seed: int, ftol: float = 1e-12, max_iter: int = 1_000_000
) -> PreparedPacking:
    """An UNSAT packing: uniformly random positions at ``φ`` (:func:`random_packing` with
    ``seed``) minimised directly there. ``ok`` iff FIRE converged and the packing is jammed
    (``p > 0`` with a non-empty backbone)."""
    _check_common(n, dim, seed, ftol)
    if not (isinstance(phi, int | float | np.floating) and 0 < phi < 1):
        raise ValueError(f"packing fraction must be in (0, 1), got phi={phi!r}")
    r = relax(random_packing(int(n), int(dim), float(phi), int(seed)), ftol, max_iter)
    state = describe(r.packing, r.energy)
    reason = ""
    if not r.converged:
        reason = f"minimisation did not converge (max force {r.max_force:.3e} >= ftol {ftol:.1e})"
    elif state.n_contacts_nr == 0:
        reason = f"not jammed at phi={phi} (p={state.pressure:.3e}): below jamming"
    return PreparedPacking(
        packing=r.packing,
        state=state,
        protocol="direct",
        phi_j=math.nan,
        converged=r.converged,
        ok=not reason,
        reason=reason,
        n_minimizations=1,
        fire_iterations=r.iterations,
        time=r.time,
        params=dict(
            phi=float(phi),
            ftol=float(ftol),
            max_iter=int(max_iter),
            n=int(n),
            dim=int(dim),
            seed=int(seed),
            fire_dt_max=JAM_FIRE.dt_max,
        ),
        history=((r.packing.phi, state.pressure, state.n_contacts_nr > 0),),
    )


# ------------------------------------------------------------------------------------------------
# coordination curve (paper Fig. 1)


@dataclass(frozen=True, eq=False)
class CoordinationCurve:
    """Minima along a compression from a jammed packing, one entry per step.

    ``phi``, ``dphi = φ − φ_J``, ``z``, ``z_nr``, ``z_iso = 2(d(N'−1)+1)/N'``, ``n_rattlers``,
    total ``energy``, ``pressure``, ``converged``; ``phi_j`` and ``dim`` of the start.
    """

    phi_j: float
    dim: int
    n: int
    phi: np.ndarray
    dphi: np.ndarray
    z: np.ndarray
    z_nr: np.ndarray
    z_iso: np.ndarray
    n_rattlers: np.ndarray
    energy: np.ndarray
    pressure: np.ndarray
    converged: np.ndarray

    def as_columns(self) -> dict[str, np.ndarray]:
        """The per-step arrays by name (for CSV output)."""
        names = ("phi", "dphi", "z", "z_nr", "z_iso", "n_rattlers", "energy", "pressure")
        return {k: getattr(self, k) for k in names} | {"converged": self.converged.astype(int)}


def coordination_curve(
    packing: Packing,
    phi_j: float | None = None,
    dphi_min: float = 1e-6,
    dphi_max: float = 0.3,
    steps: int = 40,
    ftol: float = 1e-12,
    max_iter: int = 1_000_000,
    progress: ProgressCallback | None = None,
) -> CoordinationCurve:
    """Compress a jammed packing to ``φ_k = φ_J + Δφ_k`` with ``Δφ_k`` logarithmically spaced
    from ``dphi_min`` to ``dphi_max`` (``steps`` values); each minimum starts from the previous
    one, affinely rescaled (:func:`compress_to`). ``φ_J`` defaults to the packing's ``φ``."""
    if not (0 < dphi_min < dphi_max):
        raise ValueError(f"need 0 < dphi_min < dphi_max, got {dphi_min!r}, {dphi_max!r}")
    if not (isinstance(steps, int | np.integer) and steps >= 2):
        raise ValueError(f"steps must be an integer >= 2, got steps={steps!r}")
    phi_j = packing.phi if phi_j is None else float(phi_j)
    dphi = np.geomspace(dphi_min, dphi_max, int(steps))
    if phi_j + dphi[-1] >= 1.0:
        raise ValueError(f"phi_J + dphi_max = {phi_j + dphi[-1]} must stay below 1")
    rows = []
    pk = packing
    for k, dp in enumerate(dphi):
        r = compress_to(pk, phi_j + dp, ftol=ftol, max_iter=max_iter)
        pk = r.packing
        s = describe(pk, r.energy)
        rows.append(
            (s.z, s.z_nr, pk.n - s.n_rattlers, s.n_rattlers, s.energy, s.pressure, r.converged)
        )
        if progress is not None:
            progress(f"step {k + 1}/{len(dphi)}: dphi={dp:.2e} p={s.pressure:.3e} z={s.z:.4f}")
    z, z_nr, n_kept, n_ratt, e, p, conv = (np.array(c) for c in zip(*rows, strict=True))
    return CoordinationCurve(
        phi_j=phi_j,
        dim=packing.dim,
        n=packing.n,
        phi=phi_j + dphi,
        dphi=dphi,
        z=z.astype(np.float64),
        z_nr=z_nr.astype(np.float64),
        z_iso=np.where(n_kept > 0, z_iso(np.maximum(n_kept, 1), packing.dim), np.nan),
        n_rattlers=n_ratt.astype(np.int64),
        energy=e.astype(np.float64),
        pressure=p.astype(np.float64),
        converged=conv.astype(bool),
    )


def fit_power_law(
    x: np.ndarray, y: np.ndarray, xmin: float = 1e-4, xmax: float = 1e-1
) -> tuple[float, float, float]:
    """Least-squares fit of ``log y = log c + a log x`` over ``xmin <= x <= xmax`` (and ``y > 0``).

    Returns ``(a, σ_a, c)``; ``σ_a`` is the standard error of the slope from the residual
    scatter (ordinary least squares, ``σ_a² = s² / Σ(log x − mean)²``).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    sel = (x >= xmin) & (x <= xmax) & (y > 0) & np.isfinite(y)
    if sel.sum() < 3:
        raise ValueError(f"need at least 3 points with y > 0 in [{xmin}, {xmax}], got {sel.sum()}")
    lx, ly = np.log(x[sel]), np.log(y[sel])
    a, b = np.polyfit(lx, ly, 1)
    resid = ly - (a * lx + b)
    s2 = float(resid @ resid) / max(len(lx) - 2, 1)
    sa = math.sqrt(s2 / float(((lx - lx.mean()) ** 2).sum()))
    return float(a), sa, float(math.exp(b))


def fit_power_law_corrected(
    x: np.ndarray, y: np.ndarray, xmin: float = 1e-4, xmax: float = 1e-1
) -> tuple[float, float, float, float, float]:
    """Least-squares fit with the leading correction to scaling, ``y = A x^b (1 + c x)``, in
    log space (``log y = log A + b log x + log(1 + c x)``) over ``xmin <= x <= xmax``.

    Returns ``(b, σ_b, A, c, σ_c)``; the standard errors come from the Jacobian at the optimum
    and the residual scatter (as :func:`scipy.optimize.curve_fit`). Starts from the plain fit
    (:func:`fit_power_law`) and ``c = 0``; ``ValueError`` with fewer than 4 points or if the fit
    does not converge.
    """
    from scipy.optimize import curve_fit

    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    sel = (x >= xmin) & (x <= xmax) & (y > 0) & np.isfinite(y)
    if sel.sum() < 4:
        raise ValueError(f"need at least 4 points with y > 0 in [{xmin}, {xmax}], got {sel.sum()}")
    lx, ly = np.log(x[sel]), np.log(y[sel])
    b0, _, a0 = fit_power_law(x, y, xmin, xmax)

    def model(lx: np.ndarray, log_a: float, b: float, c: float) -> np.ndarray:
        return log_a + b * lx + np.log1p(c * np.exp(lx))

    c_min = -0.999 / float(np.exp(lx.max()))  # keeps 1 + c x > 0 over the range
    try:
        popt, pcov = curve_fit(
            model,
            lx,
            ly,
            p0=(math.log(a0), b0, 0.0),
            bounds=((-np.inf, -np.inf, c_min), (np.inf, np.inf, np.inf)),
        )
    except (RuntimeError, ValueError) as exc:
        raise ValueError(f"corrected power-law fit failed: {exc}") from None
    err = np.sqrt(np.clip(np.diag(pcov), 0.0, None))
    return float(popt[1]), float(err[1]), float(math.exp(popt[0])), float(popt[2]), float(err[2])
