"""Which of the two 3D harmonic force kernels a list of a given length takes, measured on this
machine.

The branchy kernel (:func:`~jamlab.spheres.kernels.pairs.energy_forces_3d`: the contact test
``r² < σ²`` is a branch, and ``√``, ``/`` run for contacts only) and the branch-free one
(:func:`~jamlab.spheres.kernels.pairs.energy_forces_3d_masked`: the test is a select, every pair
does the same arithmetic) compute the same bits. Which is faster depends on the CPU: the branchy
kernel wins while the branch predictor can learn a list's contact pattern (it repeats from one
FIRE iteration to the next) and loses beyond what its history holds. The crossover is a property
of the machine, not of the physics — measured (``benchmarks/bench_force_kernel.py``, skin 0.1
near a minimum) at ≈ 8–9k pairs on the machine of the earlier sessions and at 18–36k pairs on an
AMD EPYC (there the branch-free kernel is 1.35× *slower* at 9–18k pairs, N = 2000–4000, and
1.4× faster at 36k). A constant threshold is therefore wrong somewhere by up to 1.4×.

:func:`calibration` measures it once per process, the first time a list long enough for the
choice to matter is evaluated (:data:`CALIBRATE_ABOVE` pairs): both kernels on uniformly random
configurations (φ = 0.645, the relaxations' skin ``RELAX_SKIN``: at 0.03 about 2.8 listed pairs
and 2.6 contacts per particle, against 3.75 and 3.0 near a jammed minimum at p = 1e-4; at the
earlier 0.1, 3.4 and 2.6: a contact pattern as irregular as near jamming's) from ``N = 2800`` to
``16000`` (≈ 8k–45k pairs), in short interleaved rounds, best of :data:`ROUNDS` (robust to a
second process on the machine: a round the scheduler interrupted is never the best). The threshold
is the geometric midpoint between the longest list on which the branchy kernel is still faster and
the next size, from which the branch-free one is faster by at least :data:`MARGIN` on every longer
list measured. It takes ≈ 0.5 s. Results never depend on the choice (same bits, tested); only the
time does.

``JAMLAB_FORCE_KERNEL`` overrides it: ``branchy`` (never branch-free), ``branch-free`` (every
list above :data:`CALIBRATE_ABOVE`), ``auto`` (default: measured). Anything else is an error.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CALIBRATE_ABOVE",
    "NEVER",
    "Calibration",
    "calibrate",
    "calibration",
    "choose_threshold",
    "environment_mode",
    "fixed",
    "threshold_for",
    "use",
]

NEVER = 2**62
"""A threshold no list reaches: the branchy kernel always."""

CALIBRATE_ABOVE = 6000
"""Lists up to this length take the branchy kernel without a measurement (both machines measured
favour it there by 5–35 %); the first longer list triggers :func:`calibrate`."""

SIZES = (2800, 4000, 5600, 8000, 11300, 16000)
"""Particle numbers of the calibration configurations (≈ 8.0k … 45k pairs at skin 0.03; every list
longer than :data:`CALIBRATE_ABOVE`; 2000 was the first size at skin 0.1, 6.8k pairs there)."""

ROUNDS = 9
MARGIN = 1.03
ENV = "JAMLAB_FORCE_KERNEL"


@dataclass(frozen=True)
class Calibration:
    """The measured threshold and the table behind it: ``(pairs, branchy s, branch-free s)``
    per size (seconds per evaluation, best of the rounds)."""

    threshold: int
    table: tuple[tuple[int, float, float], ...]

    def describe(self) -> str:
        """One line for benchmarks and logs."""
        if self.threshold >= NEVER:
            where = "never (the branchy kernel on every list)"
        else:
            where = f"on lists longer than {self.threshold} pairs"
        cells = ", ".join(f"{p}: {a / b:.2f}" for p, a, b in self.table)
        return f"branch-free force kernel {where}; branchy/branch-free time by pairs: {cells}"


def choose_threshold(table: list[tuple[int, float, float]] | tuple, margin: float = MARGIN) -> int:
    """The threshold from measured ``(pairs, t_branchy, t_branch_free)`` rows (any order): the
    geometric midpoint below the shortest list from which the branch-free kernel is faster by
    ``margin`` on every longer list; :data:`NEVER` when it is not faster on the longest."""
    rows = sorted(table)
    wins = [tb > margin * tm for _, tb, tm in rows]
    if not rows or not wins[-1]:
        return NEVER
    k = len(rows) - 1
    while k > 0 and wins[k - 1]:
        k -= 1
    if k == 0:
        return max(CALIBRATE_ABOVE, rows[0][0] // 2)
    return int(math.sqrt(rows[k - 1][0] * rows[k][0]))


def _time(fn: Callable[[], object], reps: int) -> float:
    t = time.perf_counter()
    for _ in range(reps):
        fn()
    return (time.perf_counter() - t) / reps


def calibrate(sizes: tuple[int, ...] = SIZES, rounds: int = ROUNDS) -> Calibration:
    """Time both kernels on random 3D configurations of ``sizes`` particles (module docstring)."""
    from jamlab.spheres.kernels import pairs as P
    from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
    from jamlab.spheres.state import random_packing

    table = []
    for n in sizes:
        pk = random_packing(n, 3, 0.645, 1)
        nl = NeighborList(pk, skin=RELAX_SKIN)
        pos = np.ascontiguousarray(nl.sorted(pk.positions))
        f = np.empty_like(pos)
        args = (pos, nl.start, nl.nbr, nl.shift, None)

        def branchy(args=args, f=f):
            return P.energy_forces_3d(*args, None, f)

        def masked(args=args, f=f):
            return P.energy_forces_3d_masked(*args, f)

        branchy()
        masked()
        # short rounds (≈ 0.5 ms at 20 ns per particle), many of them: on a loaded machine the
        # best round of each kernel is one the scheduler did not interrupt
        reps = max(1, 500_000 // (20 * n))
        tb = tm = math.inf
        for _ in range(rounds):
            tb = min(tb, _time(branchy, reps))
            tm = min(tm, _time(masked, reps))
        table.append((int(nl.nbr.size), tb, tm))
    return Calibration(choose_threshold(table), tuple(table))


_CALIBRATION: Calibration | None = None


MODES = ("auto", "branchy", "branch-free")


def environment_mode() -> str:
    """``JAMLAB_FORCE_KERNEL`` (default ``auto``), checked: ``ValueError`` for anything but
    :data:`MODES` (the command line checks it before any work starts)."""
    mode = os.environ.get(ENV, "auto").strip().lower() or "auto"
    if mode not in MODES:
        raise ValueError(f"{ENV} must be 'auto', 'branchy' or 'branch-free', got {mode!r}")
    return mode


def fixed(mode: str) -> Calibration:
    """The choice of a fixed ``mode``: ``branchy`` (never branch-free) or ``branch-free`` (every
    list above :data:`CALIBRATE_ABOVE`)."""
    if mode == "branchy":
        return Calibration(NEVER, ())
    if mode == "branch-free":
        return Calibration(CALIBRATE_ABOVE, ())
    raise ValueError(f"a fixed kernel choice is 'branchy' or 'branch-free', got {mode!r}")


def calibration() -> Calibration:
    """This process's choice (``JAMLAB_FORCE_KERNEL``, else measured once and kept)."""
    global _CALIBRATION
    if _CALIBRATION is None:
        mode = environment_mode()
        _CALIBRATION = calibrate() if mode == "auto" else fixed(mode)
    return _CALIBRATION


def use(choice: Calibration | None) -> None:
    """Make ``choice`` this process's choice (``None``: decide again at the next long list) —
    for benchmarks that time both kernels in one process."""
    global _CALIBRATION
    _CALIBRATION = choice


def threshold_for(n_pairs: int, dim: int = 3, alpha: float | None = None) -> int:
    """The threshold to hand a kernel about to evaluate a list of ``n_pairs`` pairs in ``dim``
    dimensions with the kernels' pair exponent ``alpha`` (``None``: harmonic). Only the 3D
    harmonic kernels have a branch-free twin; other lists, and lists within
    :data:`CALIBRATE_ABOVE`, need no measurement (and get :data:`NEVER`)."""
    if n_pairs <= CALIBRATE_ABOVE or dim != 3 or alpha is not None:
        return NEVER
    return calibration().threshold
