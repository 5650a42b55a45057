"""What one sample computes, and how its outcome travels back to the driving process.

A *task* is a function ``task(study, key, seed) -> SampleResult``; it runs on a worker (a local
process or a Dask worker) and must be deterministic in ``seed``. It never writes files: the worker
returns the arrays and only the driving process writes (:mod:`jamlab.runs.storage`).

- ``aqs`` (the physics): prepare a packing — ``φ = "jamming"`` →
  :func:`jamlab.spheres.packing.jam` ``(n, dim, seed, p_target)``; a number →
  :func:`jamlab.spheres.packing.prepare` ``(n, dim, phi, seed)`` — then shear it with
  :func:`jamlab.spheres.aqs.shear` ``(packing, dgamma, gamma_max)``.
- ``toy``: a cheap stand-in with the same trace fields, deterministic in ``seed``; it exercises the
  run machinery (storage, resume, Dask) without physics. ``JAMLAB_TOY_DELAY`` (seconds, default 0)
  makes each toy sample sleep, for tests that must interrupt a run mid-way.

A non-converged minimisation is a failure: the task raises :class:`SampleFailed` and the run
records it (``*.failed.json``) and carries on.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable

import numpy as np

from jamlab.provenance import here, segment
from jamlab.runs import physics
from jamlab.runs.results import TRACE_FIELDS, SampleFailed, SampleFailure, SampleResult
from jamlab.runs.study import SampleKey, Study

__all__ = [
    "TRACE_FIELDS",
    "SampleResult",
    "SampleFailure",
    "SampleFailed",
    "Task",
    "get_task",
    "run_sample",
    "toy_task",
    "aqs_task",
]

Task = Callable[[Study, SampleKey, int], SampleResult]


def toy_task(study: Study, key: SampleKey, seed: int) -> SampleResult:
    """A deterministic stand-in for prepare + shear: random-walk "traces" of
    ``round(gamma_max/dgamma)`` steps with the fields of :data:`TRACE_FIELDS`, drawn from
    ``numpy.random.default_rng(seed)`` with work proportional to ``N × steps``."""
    delay = float(os.environ.get("JAMLAB_TOY_DELAY", "0") or 0)
    if delay > 0:
        time.sleep(delay)
    rng = np.random.default_rng(seed)
    steps = study.n_steps
    gamma = study.dgamma * np.arange(steps + 1, dtype=np.float64)
    # N-dependent work so that timing scales like a real sample, and results depend on every draw
    kicks = rng.normal(size=(steps + 1, key.n)).sum(axis=1) / key.n
    stress = np.cumsum(kicks)
    energy = np.cumsum(stress * study.dgamma)
    # the trace's convention: row n describes the step n-1 -> n, NaN in row 0
    energy_jump = np.concatenate([[np.nan], np.diff(energy) - study.dgamma * stress[:-1]])
    traces = {
        "gamma": gamma,
        "energy": energy,
        "shear_stress": stress,
        "pressure": np.abs(stress) + 1.0,
        "z": np.full(steps + 1, 2.0 * study.dim),
        "z_nr": np.full(steps + 1, 2.0 * study.dim),
        "max_force": rng.uniform(0, study.force_tol, size=steps + 1),
        "iterations": rng.integers(1, 100, size=steps + 1),
        "energy_jump": energy_jump,
        "stress_jump": np.concatenate([[np.nan], np.diff(stress)]),
        "plastic": np.concatenate([[False], energy_jump[1:] < 0]),
    }
    phi_value = 0.64 if isinstance(key.phi, str) else float(key.phi)
    attrs = {"phi_actual": phi_value, "prep_converged": True}
    return SampleResult(traces, attrs, {"positions": rng.random((key.n, study.dim))})


def aqs_task(
    study: Study, key: SampleKey, seed: int, checkpoint: str | None = None
) -> SampleResult:
    """Prepare (``jam`` at ``φ = "jamming"``, ``prepare`` at a number) and shear one sample;
    ``checkpoint``: its checkpoint folder (``Study.checkpoint_every``; the only task that
    writes, and only there: :mod:`jamlab.runs.physics`)."""
    return physics.prepare_and_shear(study, key, seed, checkpoint=checkpoint)


_TASKS: dict[str, Task] = {"toy": toy_task, "aqs": aqs_task}


def get_task(name: str) -> Task:
    """The built-in task called ``name``."""
    try:
        return _TASKS[name]
    except KeyError:
        raise ValueError(f"unknown task {name!r}: valid tasks are {', '.join(_TASKS)}") from None


def run_sample(
    study: Study, key: SampleKey, seed: int, task: Task | None = None,
    checkpoint: str | None = None,
) -> SampleResult | SampleFailure:
    """Run one sample on a worker, turning any exception into a :class:`SampleFailure` so that
    one bad sample never stops a run. ``checkpoint``: the sample's checkpoint folder, passed to
    the ``aqs`` task (``Study.checkpoint_every``); a resumed sample's times include its earlier
    invocations'."""
    fn = task if task is not None else get_task(study.task)
    start = time.perf_counter()
    cpu_start = time.thread_time()
    try:
        result = fn(study, key, seed) if checkpoint is None else fn(
            study, key, seed, checkpoint=checkpoint
        )
    except Exception as exc:  # noqa: BLE001 - every failure is recorded, none stops the run
        return SampleFailure(
            type(exc).__name__, str(exc), traceback.format_exc(), time.perf_counter() - start,
            machine=here(), cpu_seconds=time.thread_time() - cpu_start,
        )
    result.seconds = result.earlier_seconds + time.perf_counter() - start
    result.cpu_seconds = result.earlier_cpu_seconds + time.thread_time() - cpu_start
    if not result.provenance:
        result.provenance = [segment(result.resumed_from)]
    return result
