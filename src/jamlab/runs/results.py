"""What travels back from a worker to the driving process: a finished sample's arrays, or the
record of its failure (shared by :mod:`jamlab.runs.tasks`, :mod:`jamlab.runs.physics` and
:mod:`jamlab.runs.storage`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from jamlab.spheres.trace import OPTIONAL_COLUMNS, TRACE_COLUMNS

__all__ = ["OPTIONAL_TRACE_FIELDS", "TRACE_FIELDS", "SampleResult", "SampleFailure", "SampleFailed"]

TRACE_FIELDS = TRACE_COLUMNS
"""The per-step arrays of :class:`jamlab.spheres.trace.Trace` that every sample stores."""

OPTIONAL_TRACE_FIELDS = OPTIONAL_COLUMNS
"""Per-step arrays stored when the trace has them (``jammed``, ``phi``: AQS samples written since
trace format 2; absent in earlier run directories and in the ``toy`` task)."""


class SampleFailed(Exception):
    """A sample that ran but whose result must not be used (e.g. a non-converged minimisation)."""


@dataclass
class SampleResult:
    """A finished sample: equal-length 1-D ``traces``, scalar ``attrs`` (numbers/strings/bools)
    and other ``arrays`` (e.g. the prepared packing's positions)."""

    traces: dict[str, np.ndarray]
    attrs: dict[str, Any] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    seconds: float = 0.0
    # CPU time of the thread that ran it (the workers are single-threaded; NaN: not measured)
    cpu_seconds: float = math.nan
    # a sample resumed from a checkpoint (Study.checkpoint_every): the step it resumed from (-1:
    # it was not), and the wall and CPU seconds its earlier invocations spent up to that save
    # (added to ``seconds`` and ``cpu_seconds``, which then cover the whole sample)
    resumed_from: int = -1
    earlier_seconds: float = 0.0
    earlier_cpu_seconds: float = 0.0
    # where each invocation ran (jamlab.provenance.segment): one record per invocation, oldest
    # first; a task may fill it (a resumed sample keeps its earlier invocations' records),
    # run_sample fills it otherwise. Written as the sample file's ``provenance`` (JSON)
    provenance: list[dict[str, Any]] = field(default_factory=list)


@dataclass
class SampleFailure:
    """A failed sample: the error's type and message, the traceback, the worker's wall and CPU
    time in the failing invocation (``cpu_seconds``: ``None`` when not measured; a sample
    resumed from a checkpoint spent more in its earlier invocations) and where it failed (the
    worker's :func:`jamlab.provenance.here`; ``None`` for a failure found after the task, e.g.
    an invalid result)."""

    error_type: str
    message: str
    traceback: str
    seconds: float = 0.0
    machine: dict[str, Any] | None = None
    cpu_seconds: float | None = None
