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

from jamlab.provenance import differ, machine_key, summary_text
from jamlab.runs.storage import RunDir
from jamlab.runs.study import SampleKey, Study

__all__ = [
    "MachineCensus", "census_lines", "machine_census", "provenance_records", "sample_provenance",
]


def sample_provenance(run: RunDir, key: SampleKey) -> list[dict[str, Any]] | None:
    """The invocation records of a finished sample's file; ``None`` when it has none (or cannot
    be read)."""
    try:
        with h5py.File(run.sample_path(key), "r") as h5:
            text = h5.attrs.get("provenance")
    except OSError:
        return None
    return provenance_records(text)


def provenance_records(text: Any) -> list[dict[str, Any]] | None:
    """A ``provenance`` attribute's invocation records; ``None`` when absent or not a JSON
    list."""
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
    """Samples whose invocations ran on more than one machine (records that differ in a field
    both hold: :func:`jamlab.provenance.differ`; a record from before a field was recorded is
    grouped apart in ``machines`` but is not a difference)."""
    partly_unknown: list[SampleKey] = field(default_factory=list)
    """Samples resumed from a checkpoint written before the records: earlier machines unknown."""
    unrecorded: list[SampleKey] = field(default_factory=list)
    """Finished samples whose file records no invocation (written before the records)."""


def machine_census(
    run: RunDir, study: Study, states: Mapping[SampleKey, str] | None = None,
    census: MachineCensus | None = None,
    attrs: Mapping[SampleKey, Mapping[str, Any]] | None = None,
) -> MachineCensus:
    """The :class:`MachineCensus` of ``study``'s finished samples in ``run``; ``states``: a
    :meth:`RunDir.scan` already made; ``census``: add to this one (several runs, as the
    report's) instead of a new one; ``attrs``: the finished samples' root attributes from
    :meth:`RunDir.survey` (then no file is opened again)."""
    census = MachineCensus() if census is None else census
    for key, state in (run.scan(study) if states is None else states).items():
        if state != "done":
            continue
        records = (sample_provenance(run, key) if attrs is None
                   else provenance_records(attrs.get(key, {}).get("provenance")))
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
        known = [r for r in records if r.get("recorded", True) is not False]
        if any(differ(a, b) for i, a in enumerate(known) for b in known[i + 1:]):
            census.mixed.append(key)
    return census


def _key_list(keys: list[SampleKey]) -> str:
    """Sample keys grouped by (φ, N): ``phi=jamming N=500 samples 12, 13``."""
    groups: dict[tuple[str, int], list[int]] = {}
    for key in keys:
        groups.setdefault((key.phi_label, key.n), []).append(key.index)
    return "; ".join(f"phi={phi} N={n} sample{'s' if len(ix) > 1 else ''} "
                     f"{', '.join(str(i) for i in sorted(ix))}" for (phi, n), ix in groups.items())


def census_lines(census: MachineCensus, keys: bool = True) -> list[str]:
    """The census for people (``jamlab status``, the report's header): the machines the
    finished samples ran on, and the samples that ran on more than one, that a checkpoint from
    before the records left partly unknown, or that record nothing — named when ``keys``
    (one run's samples), counted otherwise. Empty when no sample is finished."""
    n_machines = len(census.machines)
    if not n_machines and not census.unrecorded:
        return []

    def which(found: list[SampleKey]) -> str:
        return f"({len(found)})" + (f": {_key_list(found)}" if keys else "")

    lines = [f"machines: {n_machines} recorded (a sample's bits are reproducible on its own "
             "machine and libraries; docs/runs.md)"]
    for i, (mk, record) in enumerate(census.machines.items(), 1):
        lines.append(f"  machine {i}, {len(census.samples[mk])} samples: {summary_text(record)}")
    if census.mixed:
        lines.append(f"  ran on more than one machine {which(census.mixed)}")
    if census.partly_unknown:
        lines.append("  resumed from a checkpoint older than the records, earlier machine "
                     f"unknown {which(census.partly_unknown)}")
    if census.unrecorded:
        lines.append(f"  {len(census.unrecorded)} finished samples record no machine "
                     "(written before jamlab recorded it)")
    return lines
