"""The search of :func:`jamlab.spheres.packing.jam`: one quench from random positions, then
compression, decompression and re-compression to an isostatic minimum in the pressure window
(``docs/packings.md``). Each minimisation is recorded as a :class:`MinimizationStep`."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jamlab.spheres.describe import PackingState, describe
from jamlab.spheres.relax import RelaxResult, relax, rescale
from jamlab.spheres.state import Packing, random_packing

__all__ = ["MinimizationStep", "Attempt", "ProgressCallback", "PHI_MAX", "quench_seed",
           "run_attempt"]

ProgressCallback = Callable[[str], None]


def quench_seed(seed: int, attempt: int) -> int:
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
    (:func:`random_packing` with seed ``quench_seed(seed, attempt)`` at ``phi``). ``ftol`` and
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
class Attempt:
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
    start: Packing,
    phi_init: float,
    compress_factor: float,
    max_minimizations: int,
    classify: Callable[[_Node], _Node],
) -> tuple[_Node, float, str, bool]:
    """Steps 1–2 of :func:`jam`: quench at ``φ_init`` and compress until jammed.

    Returns ``(node, lo_phi, reason, restartable)``: the first jammed minimum and the highest
    unjammed ``φ`` below it, or a failure ``reason``."""
    node = classify(run.run(start, phi_init, -1, "quench"))
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
        if nxt >= PHI_MAX or run.count >= max_minimizations:
            return (
                node,
                lo_phi,
                f"not jammed after compressing from phi_init={phi_init} to phi={lo_phi:.6f} "
                f"(p={node.p:.3e}, {run.count} minimisations)",
                True,
            )
        node = classify(run.run(rescale(node.r.packing, nxt), nxt, node.index, "compress"))


def run_attempt(
    n: int,
    dim: int,
    start_seed: int,
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
    confirm_ftol_factor: float,
    sizes: str = "mono",
    alpha: float = 2.0,
) -> Attempt:
    """One quench from random positions at ``φ_init`` (diameters ``sizes``, pair exponent
    ``alpha``) and the window search of :func:`jamlab.spheres.packing.jam` (``docs/packings.md``;
    the earlier ``search="halve"`` was removed: ``docs/packings.md`` keeps why)."""
    p_floor = p_target * p_floor_factor
    p_jammed = p_floor / 10.0
    lo_win, hi_win = 0.5 * p_target, 2.0 * p_target
    run = _Runner(steps, attempt, ftol, max_iter, p_jammed, progress)

    def out(node: _Node, ok: bool, reason: str, restartable: bool = False) -> Attempt:
        return Attempt(node.r, node.state, ok, reason, restartable, run.fire_iterations)

    def classify(node: _Node) -> _Node:
        # near the window a single contact decides: a pair whose overlap or gap is below the
        # position resolution of ftol is ambiguous, so the count is redone at ftol * factor
        if node.r.converged and p_jammed < node.p <= hi_win and abs(node.excess) <= 1:
            phi = run.steps[node.index].phi
            node = run.run(node.r.packing, phi, node.index, "polish", ftol * confirm_ftol_factor)
        return node

    def minimise(start: _Node, phi: float, role: str) -> _Node:
        return classify(run.run(rescale(start.r.packing, phi), phi, start.index, role))

    start = random_packing(n, dim, phi_init, start_seed, sizes=sizes, alpha=alpha)
    node, lo_phi, reason, restartable = _quench_and_compress(
        run, start, phi_init, compress_factor, max_minimizations, classify
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
        if hi.state.isostatic and hi.p <= hi_win:
            if hi.p >= lo_win:
                return out(hi, True, "")
            break  # isostatic below the window: re-compress (step 4)
        phi_hi, p_hi = hi.phi, hi.p
        if phi_hi - lo_phi <= 1e-13 * phi_hi and p_hi > 2 * p_target:
            # the bracket closed on a finite pressure: its lower end belongs to another branch
            # (the jammed state rearranged on decompression), so it bounds nothing here
            lo_phi = -math.inf
        # at most a factor _MAX_DROP in pressure per decompression: larger ones set off long
        # rearrangements near jamming
        p_aim = max(p_goal, p_hi / _MAX_DROP)
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
                if node.p < lo_win:
                    continue  # re-compress (step 4)
                return out(node, True, "")
            if not node.state.isostatic:
                if node.p * _SCAN_RATIO >= lo_win:
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

    # 4. re-compress the isostatic state found below the window, along its branch:
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


PHI_MAX = 0.95
"""Upper bound of the compression of an unjammed quench in :func:`jam`."""

_MAX_DROP = 10.0
"""A decompression aims at no less than ``1/_MAX_DROP`` of the pressure it
starts from."""

_SCAN_RATIO = 0.7
"""With excess contacts inside the window the goal pressure is lowered by
this factor (instead of halved) while it stays in the window."""

_RECOMPRESS_AIM = 1.25
"""The re-compression aims at ``_RECOMPRESS_AIM × p_target/2``, the lower
part of the window, because contacts are added as the pressure rises; once a minimum with excess
contacts (or above the window) is found, it bisects in ``φ``."""

_RECOMPRESS_TRIES = 10
"""At most this many re-compressions per attempt."""

