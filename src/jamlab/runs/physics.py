"""The ``aqs`` task: one sample = prepare a packing + AQS shear. The physics modules are imported
inside :func:`prepare_and_shear`, so that the run machinery imports none until a worker needs it.

With ``Study.checkpoint_every = k`` the sample is saved as it goes, in a folder of its own that
the driver names (``RunDir.checkpoint_dir``) and removes once the sample file is written:

- ``prepared.h5``: the prepared packing (``write_packing``) with the preparation's attributes
  (JSON in the root attribute ``prep_attrs``) and the sample's seed (``sample_seed``), written
  once the preparation passed its checks;
  the shear always starts from this file's packing, read back, so that every invocation starts
  from the same bits;
- ``trace.h5`` (with ``trace.last.h5``, ``trace.configs/``): ``shear(out=..., save_every=k)``,
  the run so far and its configuration, saved atomically every ``k`` steps;
- ``times.json``: the sample's wall and CPU seconds so far at the preparation, at each save and
  at the last step, so that a resumed sample's ``seconds`` and ``cpu_seconds`` cover all its
  invocations;
- ``provenance.json``: one record per invocation (``jamlab.provenance.segment``: the step it
  resumed from, the host, the machine and libraries), appended as each starts; the sample
  file's ``provenance`` attribute. A checkpoint from before these records starts its list
  with ``{"resumed_from": -1, "recorded": false}``: the invocations before are not known.

A later invocation resumes from the last save (``shear(previous=...)``): the result is the one
an uninterrupted sample of the same study computes, bit for bit (each save is a restart point of
the solver state in both). A checkpoint that cannot be read, or that is not this sample's, is
removed and the sample starts afresh. A saved trace with a step that did not converge (a sample
that ran to its end and was recorded as failed, then retried: ``jamlab run`` retries failed
samples by default) is not resumed: the shear is redone from ``prepared.h5`` — with code that
has changed since, the failure is computed again, not read back.
"""

from __future__ import annotations

import json
import math
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from jamlab.provenance import continued
from jamlab.runs.results import TRACE_FIELDS, SampleFailed, SampleResult
from jamlab.runs.storage import CHECKPOINT_PREPARED as PREPARED
from jamlab.runs.storage import CHECKPOINT_TRACE as TRACE
from jamlab.runs.storage import RunDir, write_json
from jamlab.runs.study import SampleKey, Study

TIMES = "times.json"
PROVENANCE = "provenance.json"


def scalars(prefix: str, obj: Any) -> dict[str, Any]:
    """Numeric/bool/str attributes of a result object (dataclass fields or a dict), prefixed."""
    items = obj.items() if isinstance(obj, dict) else getattr(obj, "__dict__", {}).items()
    out = {}
    for name, value in items:
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, bool | int | float | str) and not name.startswith("_"):
            out[f"{prefix}{name}"] = value
    return out


def prepare_and_shear(
    study: Study,
    key: SampleKey,
    seed: int,
    checkpoint: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> SampleResult:
    """``jam``/``prepare`` with ``seed``, then ``shear``; :class:`SampleFailed` if a minimisation
    did not converge. ``checkpoint``: the sample's checkpoint folder (used when the study has
    ``checkpoint_every``; module docstring). ``progress(step, steps)``: called after every
    strain step."""
    from jamlab.spheres import aqs

    wall0, cpu0 = time.perf_counter(), time.thread_time()
    folder = Path(checkpoint) if checkpoint is not None and study.checkpoint_every else None
    saved = None if folder is None else _read_checkpoint(folder, study, key, seed)
    previous = start = None
    resumed_from, earlier = -1, (0.0, 0.0)
    if saved is None:
        config, attrs = _prepare(study, key, seed)
        if folder is not None:
            config, times = _save_prepared(folder, config, attrs, seed, (wall0, cpu0))
    else:
        config, attrs, previous, start, times = saved
        resumed_from = 0 if previous is None else previous.n_steps
        # the times of the last record not beyond the save resumed from
        steps = [int(k) for k in times if k != "prepared" and int(k) <= resumed_from]
        earlier = tuple(times[str(max(steps))] if steps else times["prepared"])
    provenance = continued(None if folder is None else _earlier_records(folder), resumed_from)
    if folder is not None:
        write_json(folder / PROVENANCE, provenance)
    params = None if study.pressure is not None else aqs.AQSParameters(floppy=study.floppy)
    options = {"ftol": study.force_tol, "pressure": study.pressure, "params": params,
               "volume_guess": study.volume_guess}
    if folder is None:
        result = aqs.shear(config, study.dgamma, study.gamma_max, progress=progress, **options)
    else:
        every = study.checkpoint_every
        n_steps = aqs.n_steps_for(study.dgamma, study.gamma_max)

        def tick(n: int, total: int) -> None:
            # the times at a save (and at the last step), written before it: a kill in between
            # leaves an entry that is not used
            if n % every == 0 or n == total:
                times[str(n)] = [earlier[0] + time.perf_counter() - wall0,
                                 earlier[1] + time.thread_time() - cpu0]
                write_json(folder / TIMES, times)
            if progress is not None:
                progress(n, total)

        if previous is not None and previous.n_steps >= n_steps:
            # the run was finished and saved, the process ended before the sample was written
            result = aqs.ShearResult.of_trace(previous, start)
        else:
            result = aqs.shear(
                config if previous is None else start, study.dgamma, n_steps=n_steps,
                save_every=every, out=folder / TRACE, previous=previous, progress=tick,
                **options,
            )  # fmt: skip
    trace = getattr(result, "trace", result)
    traces = {name: np.asarray(getattr(trace, name)) for name in TRACE_FIELDS}
    for name, column in trace.optional_columns().items():  # jammed, phi
        traces[name] = np.asarray(column)
    attrs.update(scalars("shear_", result) if trace is not result else {})
    attrs.pop("shear_time", None)  # wall time: not reproducible, kept out of the sample's data
    if study.floppy != "fire":  # the protocol of the floppy steps, and what it did (FIRE samples
        # keep their earlier attributes, bit for bit)
        attrs["shear_floppy"] = study.floppy
        for name in ("n_projected", "n_projection_failed"):
            attrs[f"shear_{name}"] = int(trace.attrs.get(name, 0))
    if study.pressure is not None:  # the fixed-pressure run's own counters (saddles pushed off,
        # unjammed minima, candidates, the relaxer's work) and its plastic threshold; constant
        # volume samples keep their earlier attributes, bit for bit
        for name, value in trace.attrs.items():
            if name.startswith("n_") and isinstance(value, int | np.integer):
                attrs.setdefault(f"shear_{name}", int(value))
        attrs["shear_plastic_threshold"] = float(trace.attrs.get("plastic_threshold", math.nan))
    n_bad = int(attrs.get("shear_n_not_converged", 0))
    if n_bad:
        raise SampleFailed(f"AQS minimisation did not converge at {n_bad} step(s) (max |F_i|)")
    attrs["phi_actual"] = float(config.phi)
    attrs["box_length"] = float(config.box.length)
    arrays = {"positions": np.asarray(config.positions)}
    if not config.monodisperse:  # (mono samples keep their earlier layout, bit for bit)
        arrays["diameters"] = np.asarray(config.diameters)
    return SampleResult(
        traces, attrs, arrays, resumed_from=resumed_from, earlier_seconds=earlier[0],
        earlier_cpu_seconds=earlier[1], provenance=provenance,
    )


def _earlier_records(folder: Path) -> Any:
    """The records in a checkpoint's ``provenance.json``, ``None`` when it has none (a
    checkpoint from before the records; :func:`jamlab.provenance.continued` then starts the
    list with ``UNRECORDED``)."""
    try:
        return json.loads((folder / PROVENANCE).read_text())
    except (OSError, ValueError):
        return None


def failed_steps(trace, ftol: float) -> int:
    """The steps of a (saved) trace that did not converge: its ``n_not_converged`` attribute, or
    the rows with ``max|F_i| ≥ ftol``, whichever counts more."""
    bad = int(np.count_nonzero(np.asarray(trace.max_force) >= ftol))
    return max(int(trace.attrs.get("n_not_converged", 0)), bad)


def _prepare(study: Study, key: SampleKey, seed: int) -> tuple[Any, dict[str, Any]]:
    """The prepared packing (``jam`` at ``φ = "jamming"``, ``prepare`` at a number) and the
    preparation's attributes (``prep_*``); :class:`SampleFailed` if it did not converge or failed
    its stopping rule."""
    from jamlab.spheres import packing

    if isinstance(key.phi, str):
        prepared = packing.jam(
            key.n,
            study.dim,
            seed,
            p_target=study.p_target,
            ftol=study.force_tol,
            sizes=study.sizes,
            alpha=study.alpha,
        )
    else:
        prepared = packing.prepare(
            key.n,
            study.dim,
            float(key.phi),
            seed,
            ftol=study.force_tol,
            sizes=study.sizes,
            alpha=study.alpha,
        )
    info = prepared.attrs() if hasattr(prepared, "attrs") else scalars("", prepared)
    # wall-clock times are not reproducible: kept out of the sample's data
    attrs: dict[str, Any] = {
        f"prep_{k}": (v.item() if isinstance(v, np.generic) else v)
        for k, v in info.items()
        if not k.startswith("time")
    }
    if not prepared.converged:
        raise SampleFailed(f"preparation did not converge: {prepared.reason or 'FIRE'}")
    if not prepared.ok:
        raise SampleFailed(f"preparation failed its stopping rule: {prepared.reason}")
    return prepared.packing, attrs


def _save_prepared(folder: Path, config: Any, attrs: dict[str, Any], seed: int,
                   started: tuple[float, float]) -> tuple[Any, dict[str, list[float]]]:
    """Write the prepared packing with its attributes and the sample's ``seed``
    (``prepared.h5``) and the times so far; return the packing read back from the file (the
    start of every invocation) and the times."""
    from jamlab.spheres.io import read_packing, write_packing

    folder.mkdir(parents=True, exist_ok=True)
    times = {"prepared": [time.perf_counter() - started[0], time.thread_time() - started[1]]}
    write_json(folder / TIMES, times)
    write_packing(folder / PREPARED, config, prep_attrs=json.dumps(attrs), sample_seed=str(seed))
    return read_packing(folder / PREPARED), times


class _Unusable(Exception):
    """A checkpoint that cannot be read or is not the sample's (:func:`_load_checkpoint`)."""


def _load_checkpoint(folder: Path, study: Study, key: SampleKey, seed: int) -> tuple | None:
    """``(prepared packing, preparation attributes, trace to resume or None, configuration at its
    end, times)`` from the sample's checkpoint ``folder``; ``None`` when nothing is saved;
    :class:`_Unusable` for a checkpoint that cannot be read or is not this sample's. Writes
    nothing: the one verdict of :func:`prepare_and_shear` (which acts on it) and of
    :func:`checkpoint_step` (``jamlab status``, the cost lines)."""
    import h5py

    from jamlab.spheres.aqs import resume_configuration
    from jamlab.spheres.io import read_packing
    from jamlab.spheres.trace import read_trace

    if not (folder / PREPARED).is_file():
        return None
    try:
        config = read_packing(folder / PREPARED)
        with h5py.File(folder / PREPARED, "r") as h5:
            attrs = json.loads(h5.attrs["prep_attrs"])
            saved_seed = str(h5.attrs["sample_seed"])
        times = json.loads((folder / TIMES).read_text())
        previous = start = None
        if (folder / TRACE).is_file():
            previous = read_trace(folder / TRACE)
            start = resume_configuration(folder / TRACE, previous)
        ours = saved_seed == str(seed) and config.n == key.n and config.dim == study.dim and (
            previous is None
            or (previous.attrs.get("dgamma") == study.dgamma
                and previous.attrs.get("ftol") == study.force_tol
                and previous.attrs.get("save_every") == study.checkpoint_every)
        )  # fmt: skip
        times["prepared"]  # noqa: B018 - a KeyError if the times were not written
    except (OSError, ValueError, KeyError, TypeError):
        ours = False
    if not ours:
        raise _Unusable(folder)
    if previous is not None and failed_steps(previous, study.force_tol):
        # a saved trace with a step that did not converge holds the sample's failure (it was
        # recorded as failed): resumed, it would only fail again. The shear is redone from the
        # prepared packing (docs/runs.md: a retried failure); the saves in between are not
        # resume points (the run's counters at them are not kept), nor are their times
        previous = start = None
        times = {"prepared": times["prepared"]}
    return config, attrs, previous, start, times


def _read_checkpoint(folder: Path, study: Study, key: SampleKey, seed: int) -> tuple | None:
    """:func:`_load_checkpoint`, a checkpoint it finds unusable removed (then ``None``: the
    sample starts afresh)."""
    try:
        return _load_checkpoint(folder, study, key, seed)
    except _Unusable:
        shutil.rmtree(folder, ignore_errors=True)
        return None


def checkpoint_step(folder: Path, study: Study, key: SampleKey, seed: int) -> int | None:
    """The step the sample's next invocation resumes from (``0``: from the prepared packing, the
    shear redone), ``None`` without a checkpoint, ``-1`` for one it removes, starting afresh.
    Reads what a resume reads (the prepared packing, the trace and its configuration)."""
    try:
        saved = _load_checkpoint(folder, study, key, seed)
    except _Unusable:
        return -1
    if saved is None:
        return None
    return 0 if saved[2] is None else saved[2].n_steps


def resume_step(run: RunDir, key: SampleKey, study: Study) -> int | None:
    """:func:`checkpoint_step` of ``key``'s checkpoint folder in the run directory ``run``: the
    step its sample resumes from at the next ``jamlab run`` (``jamlab status``, the cost lines)."""
    from jamlab.runs.seeds import sample_seed

    return checkpoint_step(run.checkpoint_dir(key), study, key, sample_seed(study.seed, key))
