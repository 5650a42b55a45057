"""What a run directory's finished samples cost, and what its unfinished ones will cost.

Per ``(φ, N)`` cell of a study: the CPU seconds every finished sample records (its ``cpu_seconds``
attribute: preparation and shear, summed over every resume of the sample), and the work left —
each pending, failed or corrupt sample counts as one sample, less the fraction of its steps a
checkpoint already holds (``physics.resume_step`` / the study's steps); and the failures the
run recorded (``RunDir.failures``: failed samples and those a retry finished) with the CPU
seconds their failing invocations spent, work that no finished sample's time includes. The
projection is the finished samples' mean times that count: an estimate for the machine the
samples were run on, with no model of how the cost varies between samples (at p = 1e-6 it
varies by ±15 %, docs/reproduce.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import h5py

from jamlab.runs.physics import resume_step
from jamlab.runs.storage import RunDir
from jamlab.runs.study import SampleKey, Study

__all__ = ["CellCost", "cell_costs", "cpu_seconds_value", "sample_cpu_seconds"]


@dataclass(frozen=True)
class CellCost:
    """The cost of one ``(φ, N)`` cell of a study."""

    phi: str
    n: int
    seconds: tuple[float, ...]
    """CPU seconds of the finished samples that record them (older files do not)."""
    done: int
    """Finished samples, with or without a recorded time."""
    to_do: float
    """Samples' worth of work left: unfinished samples less their checkpoints' steps."""
    failures: int = 0
    """Failures recorded for the cell's samples (each failed attempt, retried or not)."""
    failed_seconds: tuple[float, ...] = ()
    """CPU seconds of the failed attempts that record them (older records do not)."""

    @property
    def mean(self) -> float | None:
        """Mean CPU seconds per finished sample; ``None`` when none records it."""
        return sum(self.seconds) / len(self.seconds) if self.seconds else None

    @property
    def left(self) -> float | None:
        """Projected CPU seconds to finish the cell (``mean × to_do``); ``None`` without a
        mean, 0 when nothing is left."""
        if self.to_do == 0:
            return 0.0
        return None if self.mean is None else self.mean * self.to_do


def cpu_seconds_value(value: Any) -> float | None:
    """A ``cpu_seconds`` attribute as a float; ``None`` when absent or not finite."""
    if value is None or not math.isfinite(float(value)):
        return None
    return float(value)


def sample_cpu_seconds(run: RunDir, key: SampleKey) -> float | None:
    """The ``cpu_seconds`` a finished sample's file records; ``None`` if it has none."""
    try:
        with h5py.File(run.sample_path(key), "r") as h5:
            value = h5.attrs.get("cpu_seconds")
    except OSError:
        return None
    return cpu_seconds_value(value)


def cell_costs(
    run: RunDir, study: Study, states: Mapping[SampleKey, str] | None = None,
    attrs: Mapping[SampleKey, Mapping[str, Any]] | None = None,
    failures: Mapping[SampleKey, list[dict[str, Any]]] | None = None,
    checkpoints: Mapping[SampleKey, int | None] | None = None,
) -> list[CellCost]:
    """One :class:`CellCost` per ``(φ, N)`` of ``study``, in the study's order; ``states``: a
    :meth:`RunDir.scan` already made; ``attrs``: the finished samples' root attributes from
    :meth:`RunDir.survey` (then no file is opened again); ``failures``: every sample's
    :meth:`RunDir.failures`, already read; ``checkpoints``: the unfinished samples'
    :func:`jamlab.runs.physics.resume_step`, already read."""
    cells: dict[tuple[str, int], dict] = {}
    for key, state in (run.scan(study) if states is None else states).items():
        cell = cells.setdefault((key.phi_label, key.n),
                                {"seconds": [], "done": 0, "to_do": 0.0, "failed": []})
        past = run.failures(key) if failures is None else failures[key]
        cell["failed"] += [cpu_seconds_value(r.get("cpu_seconds")) for r in past]
        if state == "done":
            cell["done"] += 1
            seconds = (sample_cpu_seconds(run, key) if attrs is None
                       else cpu_seconds_value(attrs.get(key, {}).get("cpu_seconds")))
            if seconds is not None:
                cell["seconds"].append(seconds)
            continue
        saved = None
        if study.checkpoint_every:
            saved = resume_step(run, key, study) if checkpoints is None else checkpoints[key]
        cell["to_do"] += 1.0 - (max(saved, 0) / study.n_steps if saved is not None else 0.0)
    return [
        CellCost(phi=phi, n=n, seconds=tuple(c["seconds"]), done=c["done"], to_do=c["to_do"],
                 failures=len(c["failed"]),
                 failed_seconds=tuple(x for x in c["failed"] if x is not None))
        for (phi, n), c in cells.items()
    ]
