"""Which machines computed a run's samples (``jamlab status``).

Every sample file written since jamlab recorded it has a ``provenance`` attribute: the JSON list
of its invocations (``jamlab.provenance.segment``; a sample resumed from a checkpoint has one
per invocation). Bits are reproducible per machine and libraries (``provenance.machine_key``),
so :func:`machine_census` groups a run's finished samples by the machines they ran on, and names
the samples that ran on more than one (resumed elsewhere: from the resume on, such a sample
follows the second machine's arithmetic from the first one's state, so bit for bit it is in
general neither machine's uninterrupted sample), those whose earlier invocations a checkpoint
from before the records could not name, and those that record nothing (written before).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import h5py

from jamlab.provenance import machine_key
from jamlab.runs.storage import RunDir
from jamlab.runs.study import SampleKey, Study

__all__ = ["MachineCensus", "machine_census", "sample_provenance"]


def sample_provenance(run: RunDir, key: SampleKey) -> list[dict[str, Any]] | None:
    """The invocation records of a finished sample's file; ``None`` when it has none (or cannot
    be read)."""
    try:
        with h5py.File(run.sample_path(key), "r") as h5:
            text = h5.attrs.get("provenance")
    except OSError:
        return None
    if text is None:
        return None
    try:
        records = json.loads(str(text))
    except ValueError:
        return None
    return records if isinstance(records, list) else None


@dataclass
class MachineCensus:
    """A run's finished samples by the machines they ran on."""

    machines: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Machine key → a record of that machine (the first seen)."""
    samples: dict[str, list[SampleKey]] = field(default_factory=dict)
    """Machine key → the finished samples with an invocation on it."""
    mixed: list[SampleKey] = field(default_factory=list)
    """Samples whose invocations ran on more than one machine."""
    partly_unknown: list[SampleKey] = field(default_factory=list)
    """Samples resumed from a checkpoint written before the records: earlier machines unknown."""
    unrecorded: list[SampleKey] = field(default_factory=list)
    """Finished samples whose file records no invocation (written before the records)."""


def machine_census(
    run: RunDir, study: Study, states: Mapping[SampleKey, str] | None = None
) -> MachineCensus:
    """The :class:`MachineCensus` of ``study``'s finished samples in ``run``; ``states``: a
    :meth:`RunDir.scan` already made."""
    census = MachineCensus()
    for key, state in (run.scan(study) if states is None else states).items():
        if state != "done":
            continue
        records = sample_provenance(run, key)
        if not records:
            census.unrecorded.append(key)
            continue
        keys = []
        for record in records:
            if record.get("recorded", True) is False:
                census.partly_unknown.append(key)
                continue
            mk = machine_key(record)
            census.machines.setdefault(mk, record)
            if mk not in keys:
                keys.append(mk)
        for mk in keys:
            census.samples.setdefault(mk, []).append(key)
        if len(keys) > 1:
            census.mixed.append(key)
    return census
