"""Compile jamlab's numba kernels once, ahead of the first real run (``jamlab warmup``).

numba compiles every kernel on its first call and caches the machine code on disk
(``cache=True``; in ``__pycache__`` beside the sources, or under ``$NUMBA_CACHE_DIR``). On a fresh
install the first ``prepare`` + ``shear`` therefore spends ~15 s compiling for 0.5 s of work
(``benchmarks/bench_coldstart.py``). The cache is keyed by the source files and the CPU, so it
cannot be shipped; it can be filled at install time, which is what this module does.

Each :data:`TASKS` entry runs a small, real workflow (the same library calls a user's commands
make) in its own process, so the tasks compile in parallel on ``jobs`` cores. numba writes its
cache index atomically, but two processes adding *different* signatures of one kernel at the
same time can each keep only their own entry; a final pass therefore runs every task again in
one process and counts the kernels that still compile (normally none; any it finds are compiled
and cached then, in one process, so the pass repairs a lost entry). The result says how many it
had to compile, so a lost entry is reported, not hidden.

The tasks cover the paper's system (monodisperse harmonic spheres, d = 3): preparing packings
above and at jamming, the force kernels' per-machine choice, AQS shear at constant volume (lean
steps, the continuation, the FIRE fallback and the saddle check) and at fixed pressure,
inspecting and writing files, and the report's compiled fits. ``extra=True`` adds d = 2 and the
other pair laws (bidisperse, polydisperse, Hertzian).
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from jamlab import validation
from jamlab.threads import usable_cores

__all__ = ["TASKS", "EXTRA_TASKS", "WarmupResult", "count_compilations", "warmup"]


def _paper_above_jamming(tmp: Path) -> None:
    """``prepare --phi 0.8``, ``inspect``, ``shear`` (lean steps) with its trace file."""
    import jamlab.spheres as sp
    from jamlab.cli.spheres import inspect_packing
    from jamlab.spheres.aqs import shear
    from jamlab.spheres.io import write_packing

    prep = sp.prepare(64, 3, 0.8, seed=1)
    config = tmp / "above.h5"
    write_packing(config, prep.packing)
    inspect_packing(config)
    shear(prep.packing, 1e-4, 2e-3, out=tmp / "above-trace.h5", save_every=10)
    shear(prep.packing, 1e-4, n_steps=3, minimizer="fire")
    # the two 3D force kernels as the per-machine choice times them (kernel_choice), so that the
    # first list longer than its threshold does not compile them
    from jamlab.spheres.kernel_choice import calibrate

    calibrate(sizes=(2000,), rounds=1)


def _paper_at_jamming(tmp: Path) -> None:
    """``prepare --phi jamming``, constant-volume shear through plastic events (continuation,
    FIRE fallback, saddle check) and fixed-pressure shear."""
    import jamlab.spheres as sp
    from jamlab.spheres.aqs import shear

    prep = sp.jam(64, 3, seed=3, p_target=1e-6)
    shear(prep.packing, 1e-3, n_steps=40, out=tmp / "jam-trace.h5", keep_avalanches=True)
    shear(prep.packing, 1e-4, n_steps=3, pressure=1e-3)


def _other_systems(tmp: Path) -> None:
    """d = 2 bidisperse, polydisperse and Hertzian spheres (``--sizes``, ``--alpha``)."""
    import jamlab.spheres as sp
    from jamlab.spheres.aqs import shear

    for dim, sizes, alpha in ((2, "bidisperse", 2.0), (3, "polydisperse", 2.0),
                              (3, "mono", 2.5), (2, "mono", 2.0)):
        prep = sp.prepare(64, dim, 0.9 if dim == 2 else 0.8, seed=1, sizes=sizes, alpha=alpha)
        shear(prep.packing, 1e-4, n_steps=20, out=tmp / f"other-{dim}-{sizes}-{alpha}.h5")


def _report_fits(tmp: Path) -> None:
    """The report's compiled fits (``jamlab.analysis``): the joint finite-size likelihood and its
    search, ``log Γ(a, z)``, the truncated power law's score root."""
    import numpy as np

    from jamlab.analysis import fit_cutoff_power_law, fit_joint_scaling, fit_power_law

    rng = np.random.default_rng(0)
    sizes = {n: [1.0 + rng.pareto(0.5, 40) for _ in range(3)] for n in (100, 200)}
    fit_joint_scaling(sizes, 1.0, n_boot=2)
    x = np.concatenate(sizes[100])
    fit_cutoff_power_law(x, 1.0)
    fit_power_law(x, x_max=float(x.max()), min_tail=20)  # the truncated law's score root


TASKS: dict[str, Callable[[Path], None]] = {
    "above jamming (d = 3)": _paper_above_jamming,
    "at jamming (d = 3)": _paper_at_jamming,
    "the report's fits": _report_fits,
}
"""The paper's system; each runs in its own process (module docstring)."""

EXTRA_TASKS: dict[str, Callable[[Path], None]] = {"other systems": _other_systems}
"""Added by ``extra=True``."""


def count_compilations(fn: Callable[[], None]) -> int:
    """Run ``fn()`` and return how many numba compilations (not cache loads) it triggered."""
    from numba.core import event

    count = 0

    class _Counter(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            pass

        def on_end(self, ev: event.Event) -> None:
            nonlocal count
            count += 1

    listener = _Counter()
    event.register("numba:compile", listener)
    try:
        fn()
    finally:
        event.unregister("numba:compile", listener)
    return count


def _run(names: list[str]) -> tuple[float, int]:
    """Run the named tasks in this process: (seconds, numba compilations)."""
    table = {**TASKS, **EXTRA_TASKS}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="jamlab-warmup-") as tmp:
        def body() -> None:
            for name in names:
                table[name](Path(tmp))

        n = count_compilations(body)
    return time.perf_counter() - t0, n


@dataclass(frozen=True)
class WarmupResult:
    """``task_seconds``: wall time of each task in its process; ``compiled``: compilations in
    the parallel phase; ``check_seconds``, ``left``: the final pass and the kernels it still had
    to compile (0 when the parallel phase filled the cache; any it finds, it caches);
    ``seconds``: the whole warm-up."""

    task_seconds: dict[str, float]
    compiled: int
    check_seconds: float
    left: int
    seconds: float


def warmup(jobs: int | None = None, extra: bool = False,
           progress: Callable[[str], None] | None = None) -> WarmupResult:
    """Fill numba's cache for :data:`TASKS` (and :data:`EXTRA_TASKS` with ``extra``), running the
    tasks on ``jobs`` processes (default: the usable cores), then check it (module docstring)."""
    names = list(TASKS) + (list(EXTRA_TASKS) if extra else [])
    if jobs is None:
        jobs = usable_cores()
    if not (validation.is_integer(jobs) and jobs >= 1):
        raise ValueError(f"jobs must be an integer >= 1, got {jobs!r}")
    t0 = time.perf_counter()
    seconds: dict[str, float] = {}
    compiled = 0
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: nothing compiled yet
    with concurrent.futures.ProcessPoolExecutor(max_workers=min(jobs, len(names)),
                                                mp_context=context) as pool:
        futures = {pool.submit(_run, [name]): name for name in names}
        for future in concurrent.futures.as_completed(futures):
            name = futures[future]
            seconds[name], n = future.result()
            compiled += n
            if progress is not None:
                progress(f"{name}: {seconds[name]:.1f} s, {n} kernels compiled")
    with concurrent.futures.ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        check_seconds, left = pool.submit(_run, names).result()
    if progress is not None:
        progress(f"check: {check_seconds:.1f} s, {left} kernels compiled")
    return WarmupResult(seconds, compiled, check_seconds, left, time.perf_counter() - t0)
