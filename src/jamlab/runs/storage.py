"""The run directory: manifest, one atomically written HDF5 file per sample, failure records.

Layout (``docs/runs.md``)::

    RUN/manifest.json                                    parameters, version, seed, creation time
    RUN/run.lock                                         held (flock) by the driving process
    RUN/samples/phi=<φ>/N=<N>/sample-<index:05d>.h5      a finished sample
    RUN/samples/phi=<φ>/N=<N>/sample-<index:05d>.failed.json   a failed sample's error
    RUN/samples/phi=<φ>/N=<N>/sample-<index:05d>.failed.h5     its checkpoint's trace then
    RUN/samples/phi=<φ>/N=<N>/sample-<index:05d>.retried.json  the failures of a sample that
                                                               a retry finished (and .retried.h5)

A failure is never erased: a failure record keeps the earlier failures of the sample
(``earlier``, oldest first) and where each happened (``machine``); when a retry finishes the
sample, the record becomes ``.retried.json`` (``failures``, oldest first) and the failure's trace
``.retried.h5``, so a finished sample says it was retried, on what and why.

Sample file (root of the HDF5 file): group ``trace`` with the 1-D per-step datasets
(:data:`jamlab.runs.tasks.TRACE_FIELDS`); group ``packing`` with the prepared configuration's
``positions``; root attributes ``format = "jamlab-sample"``, ``format_version``, ``phi`` (label),
``n``, ``index``, ``seed`` (the sample's 64-bit seed, as a decimal string), ``master_seed``,
``task``, ``jamlab_version``, ``seconds`` (worker wall time), ``cpu_seconds`` (CPU time of the
worker thread that ran the sample; absent in samples written before it existed), ``provenance``
(JSON: one record per invocation of the sample, where it ran — ``jamlab.provenance.segment``;
absent in samples written before it existed), the task's own attributes, and ``complete = True``
written last.

Atomicity: a file is written under a temporary name (``.sample-…h5.XXXX.tmp``) in its final
directory, flushed, fsync'ed, closed and renamed with ``os.replace`` (atomic on POSIX), then the
directory is fsync'ed. A reader therefore sees either no file or a whole one; a temporary file is a
leftover of an interrupted write and is deleted on resume. A sample file that cannot be opened, or
lacks ``complete`` or its identity attributes, is *corrupt* and is redone.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import fcntl
import hashlib
import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from jamlab import validation
from jamlab.files import (
    RUN_FORMAT,
    RUN_MEMBERS,
    atomic_write,
    atomic_write_hdf5,
    check_new_run_directory,
)
from jamlab.runs.results import TRACE_FIELDS, SampleFailure, SampleResult
from jamlab.runs.study import SampleKey, Study, phi_label

__all__ = [
    "MANIFEST",
    "RUN_FORMAT",
    "SAMPLE_FORMAT",
    "RunDir",
    "RunError",
    "check_sample",
    "check_sample_data",
    "sample_state",
]

# the run directory's own entries (named in jamlab.files, whose output guard protects them)
MANIFEST, LOCK, SAMPLES, CHECKPOINTS = RUN_MEMBERS
CHECKPOINT_PREPARED = "prepared.h5"  # in a sample's checkpoint folder (jamlab.runs.physics)
CHECKPOINT_TRACE = "trace.h5"
SAMPLE_FORMAT = "jamlab-sample"
FORMAT_VERSION = 1
SEED_RULE = (
    "numpy.random.SeedSequence(entropy=master_seed, spawn_key=(kind, phi_bits, N, index)); "
    "kind=0, phi_bits=0 for phi='jamming'; kind=1, phi_bits=IEEE-754 bits of float64 phi; "
    "sample seed = generate_state(1, uint64)[0]"
)
STATES = ("done", "failed", "corrupt", "pending")


class RunError(ValueError):
    """A run directory that cannot be used as asked (reported as a one-line user error)."""


def write_json(path: Path, data: dict[str, Any]) -> None:
    """``data`` as indented JSON at ``path``, atomically (:func:`jamlab.files.atomic_write`)."""

    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            json.dump(data, fh, indent=2, sort_keys=False)
            fh.write("\n")
            fh.flush()

    atomic_write(path, write, make_parents=True)


def _is_manifest_tmp(path: Path) -> bool:
    return path.name.startswith(f".{MANIFEST}.") and path.name.endswith(".tmp")


_INTEGER_FIELDS = {"iterations"}
_BOOL_FIELDS = {"plastic"}
_NAN_ROW0_FIELDS = {"energy_jump", "stress_jump"}


def _digest(values: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()


def check_sample_data(
    traces: Mapping[str, Any],
    arrays: Mapping[str, Any],
    key: SampleKey,
    study: Study | None = None,
) -> None:
    """``ValueError`` unless ``traces`` and ``arrays`` are a whole sample of ``key``: every trace
    field present, 1-D, of one length (``M + 1`` with ``M`` the study's step count), of its
    dtype (float, integer ``iterations``, bool ``plastic``), finite (``energy_jump`` and
    ``stress_jump``: except row 0), ``gamma`` increasing; ``positions`` a finite ``(N, d)`` float
    array. Applied to a task's result before it is written and to a file when a run is scanned."""
    rows = None
    if study is not None:
        rows = validation.strain_steps(study.dgamma, study.gamma_max) + 1
    for name in TRACE_FIELDS:
        if name not in traces:
            raise ValueError(f"trace {name} is missing")
        values = np.asarray(traces[name])
        kind = "iu" if name in _INTEGER_FIELDS else ("b" if name in _BOOL_FIELDS else "f")
        if values.dtype.kind not in kind:
            raise ValueError(f"trace {name} has dtype {values.dtype}")
        if values.ndim != 1 or values.shape[0] < 1:
            raise ValueError(f"trace {name} has shape {values.shape}")
        if rows is None:
            rows = values.shape[0]
        if values.shape[0] != rows:
            raise ValueError(f"trace {name} has {values.shape[0]} rows, expected {rows}")
        if kind == "f":
            check = values[1:] if name in _NAN_ROW0_FIELDS else values
            if not np.all(np.isfinite(check)):
                raise ValueError(f"trace {name} is not finite")
            if name == "gamma" and not np.all(np.diff(values) > 0):
                raise ValueError("trace gamma is not increasing")
    if "positions" not in arrays:
        raise ValueError("positions are missing")
    positions = np.asarray(arrays["positions"])
    dim = None if study is None else study.dim
    if positions.dtype.kind != "f":
        raise ValueError(f"positions have dtype {positions.dtype}")
    if positions.ndim != 2 or positions.shape[0] != key.n or (dim and positions.shape[1] != dim):
        raise ValueError(f"positions have shape {positions.shape}")
    if not np.all(np.isfinite(positions)):
        raise ValueError("positions are not finite")


def _read_checked(group: Any, where: str) -> dict[str, np.ndarray]:
    """Every dataset of an HDF5 group, each checked against its ``sha256`` attribute."""
    if not isinstance(group, h5py.Group):
        raise ValueError(f"no {where} group")
    out = {}
    for name, ds in group.items():
        if not isinstance(ds, h5py.Dataset):
            raise ValueError(f"{where}/{name} is not a dataset")
        values = ds[()]
        recorded = ds.attrs.get("sha256")
        if recorded is not None:
            recorded = recorded.decode() if isinstance(recorded, bytes) else str(recorded)
            if recorded != _digest(np.asarray(values)):
                raise ValueError(f"{where}/{name} does not match its checksum")
        out[name] = values
    return out


def check_sample(h5: h5py.File, key: SampleKey, study: Study | None = None) -> None:
    """``ValueError`` unless the open sample file ``h5`` is a whole sample of ``key``: identity
    attributes and ``complete``, each dataset matching its ``sha256`` attribute (when present;
    files written before it lack it), and the data passing :func:`check_sample_data`."""
    a = h5.attrs
    if a.get("format") != SAMPLE_FORMAT or not bool(a.get("complete", False)):
        raise ValueError("not a complete sample file")
    identity = (a.get("phi"), int(a.get("n", -1)), int(a.get("index", -1)))
    if identity != (key.phi_label, key.n, key.index):
        raise ValueError("another sample's file")
    traces = _read_checked(h5.get("trace"), "trace")
    arrays = _read_checked(h5.get("packing"), "packing")
    check_sample_data(traces, arrays, key, study)


def sample_state(path: Path, key: SampleKey, study: Study | None = None) -> str:
    """``"done"`` if ``path`` is a whole sample file for ``key`` (:func:`check_sample`);
    ``"corrupt"`` if it exists but is unreadable, damaged, incomplete or another sample's;
    ``"pending"`` if it does not exist."""
    return sample_state_attrs(path, key, study)[0]


def sample_state_attrs(
    path: Path, key: SampleKey, study: Study | None = None, names: tuple[str, ...] = ()
) -> tuple[str, dict[str, Any]]:
    """:func:`sample_state` and, for a ``"done"`` file, the root attributes ``names`` it has,
    read while the file is open for the check (one open per file); ``{}`` otherwise."""
    if not path.exists():
        return "pending", {}
    try:
        with h5py.File(path, "r") as h5:
            check_sample(h5, key, study)
            attrs = {name: h5.attrs[name] for name in names if name in h5.attrs}
    except Exception:  # noqa: BLE001 - any failure to read means the file must be redone
        return "corrupt", {}
    return "done", attrs


class RunDir:
    """A run directory; :meth:`open` validates it against a study before anything is written."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)

    # -- paths --------------------------------------------------------------------------------

    @property
    def manifest_path(self) -> Path:
        return self.path / MANIFEST

    def sample_path(self, key: SampleKey) -> Path:
        return self.path / key.relpath()

    def checkpoint_dir(self, key: SampleKey) -> Path:
        """The folder where a sample of a study with ``checkpoint_every`` is saved as it goes
        (:mod:`jamlab.runs.physics`): ``checkpoints/phi=…/N=…/sample-XXXXX/``."""
        inside = Path(key.relpath()).relative_to(SAMPLES).with_suffix("")
        return self.path / CHECKPOINTS / inside

    def remove_checkpoints(self, keys: list[SampleKey]) -> None:
        """Delete the checkpoint folders of ``keys`` (their samples are written)."""
        for key in keys:
            folder = self.checkpoint_dir(key)
            if folder.is_dir():
                shutil.rmtree(folder)

    def prune_checkpoints(self) -> None:
        """Remove the empty folders left in ``checkpoints/`` (at the end of a run: a worker may
        be creating its folder while the run goes on)."""
        root = self.path / CHECKPOINTS
        if not root.is_dir():
            return
        for folder in sorted(root.rglob("*"), key=lambda p: len(p.parts), reverse=True):
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()
        if not any(root.iterdir()):
            root.rmdir()

    def failure_path(self, key: SampleKey) -> Path:
        return self._beside(key, ".failed.json")

    def failure_trace_path(self, key: SampleKey) -> Path:
        """The trace of ``key``'s checkpoint when it last failed (module docstring)."""
        return self._beside(key, ".failed.h5")

    def retried_path(self, key: SampleKey) -> Path:
        """The failures of a sample that a retry finished (module docstring)."""
        return self._beside(key, ".retried.json")

    def _beside(self, key: SampleKey, suffix: str) -> Path:
        p = self.sample_path(key)
        return p.with_name(p.stem + suffix)

    # -- manifest -----------------------------------------------------------------------------

    def read_manifest(self) -> dict[str, Any]:
        """The manifest as a dict; :class:`RunError` if missing or unreadable."""
        if not self.manifest_path.is_file():
            raise RunError(f"not a jamlab run directory (no {MANIFEST}): {self.path}")
        try:
            manifest = json.loads(self.manifest_path.read_text())
        except (OSError, ValueError) as exc:
            raise RunError(f"unreadable manifest {self.manifest_path}: {exc}") from None
        if not isinstance(manifest, dict) or manifest.get("format") != RUN_FORMAT:
            raise RunError(f"{self.manifest_path} is not a jamlab run manifest")
        try:
            validation.format_version(self.manifest_path, manifest.get("format_version"),
                                      FORMAT_VERSION, "run directories")
        except ValueError as exc:
            raise RunError(str(exc)) from None
        return manifest

    def study(self) -> Study:
        """The study recorded in the manifest. A fixed-pressure study recorded without
        ``volume_guess`` was run by the rule of its time, ``"always"``."""
        manifest = self.read_manifest()
        try:
            recorded = dict(manifest["study"])
            if recorded.get("pressure") is not None:
                recorded.setdefault("volume_guess", validation.VOLUME_GUESS_BEFORE)
            return Study.from_dict(recorded)
        except (KeyError, TypeError, ValueError) as exc:
            raise RunError(f"invalid study in {self.manifest_path}: {exc}") from None

    @classmethod
    def open(cls, path: str | os.PathLike, study: Study) -> RunDir:
        """Check that ``path`` can hold ``study`` — a new or empty directory, or an existing run of
        the same study — and create the directory. Raises :class:`RunError` — before writing
        anything — for an unwritable location, a non-run directory or a mismatch. The manifest
        is written by :meth:`start`, under :meth:`lock`."""
        run = cls(path)
        p = run.path
        check_new_run_directory("run directory", p)
        if p.exists() and not p.is_dir():
            raise RunError(f"output path exists and is not a directory: {p}")
        if run.manifest_path.exists():
            run._check_study(study)
            run._check_writable(p)
            return run
        run._check_empty()
        existing = p
        while not existing.exists():
            existing = existing.parent
        if not existing.is_dir():
            raise RunError(f"cannot create output directory {p}: {existing} is not a directory")
        run._check_writable(existing)
        try:
            p.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RunError(f"cannot create output directory {p}: {exc.strerror}") from None
        return run

    def _check_study(self, study: Study) -> None:
        diffs = self.study().differences(study)
        if diffs:
            raise RunError(
                f"{self.path} holds a different study ({'; '.join(diffs)}; recorded != "
                "requested); use another --out or the recorded parameters"
            )

    def _check_empty(self) -> None:
        # a run killed while writing its manifest leaves only a temporary manifest behind, and a
        # driver that took the lock first leaves run.lock
        p = self.path
        if p.is_dir() and any(
            not (_is_manifest_tmp(e) or e.name == LOCK) for e in p.iterdir()
        ):
            raise RunError(f"output directory is not empty and has no {MANIFEST}: {p}")

    def start(self, study: Study) -> None:
        """Write the manifest of ``study`` if there is none, else check it records ``study``;
        call only while holding :meth:`lock` (two drivers started together: the one that gets
        the lock writes the manifest, the other is refused and writes nothing)."""
        if self.manifest_path.exists():
            self._check_study(study)
            return
        self._check_empty()
        from jamlab import __version__

        manifest = {
            "format": RUN_FORMAT,
            "format_version": FORMAT_VERSION,
            "study": study.to_dict(),
            "master_seed": study.seed,
            "jamlab_version": __version__,
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            "seed_derivation": SEED_RULE,
            "layout": "samples/phi=<phi>/N=<N>/sample-<index:05d>.h5",
        }
        write_json(self.manifest_path, manifest)

    @staticmethod
    def _check_writable(directory: Path) -> None:
        try:
            fd, tmp = tempfile.mkstemp(prefix=".jamlab-write-test.", dir=directory)
        except OSError as exc:
            raise RunError(
                f"output directory is not writable: {directory} ({exc.strerror})"
            ) from None
        os.close(fd)
        os.remove(tmp)

    # -- locking ------------------------------------------------------------------------------

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold an exclusive ``flock`` on ``run.lock`` (released by the kernel even on SIGKILL),
        so that two drivers never write the same run."""
        fh = open(self.path / LOCK, "a")  # noqa: SIM115 - held for the whole block
        try:
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                    raise RunError(f"another jamlab process is running in {self.path}") from None
                raise
            yield
        finally:
            fh.close()

    def remove_temporaries(self) -> list[Path]:
        """Delete leftovers of interrupted writes (call only while holding :meth:`lock`)."""
        removed = []
        for folder in (self.path / SAMPLES, self.path / CHECKPOINTS):
            if folder.is_dir():
                for tmp in folder.rglob(".*.tmp"):
                    tmp.unlink(missing_ok=True)
                    removed.append(tmp)
        for tmp in self.path.glob(f".{MANIFEST}.*.tmp"):
            tmp.unlink(missing_ok=True)
            removed.append(tmp)
        return removed

    # -- samples ------------------------------------------------------------------------------

    def state(self, key: SampleKey, study: Study | None = None) -> str:
        """``done``, ``failed`` (no whole file but a failure record), ``corrupt`` or ``pending``
        (with ``study``: the trace length and dimension are checked too)."""
        return self.state_attrs(key, study)[0]

    def state_attrs(
        self, key: SampleKey, study: Study | None = None, names: tuple[str, ...] = ()
    ) -> tuple[str, dict[str, Any]]:
        """:meth:`state` and, for a finished sample, its root attributes ``names``, read in the
        same open (:func:`sample_state_attrs`)."""
        state, attrs = sample_state_attrs(self.sample_path(key), key, study, names)
        if state == "pending" and self.failure_path(key).exists():
            return "failed", {}
        return state, attrs

    def scan(self, study: Study) -> dict[SampleKey, str]:
        """The state of every sample of ``study``."""
        return {key: self.state(key, study) for key in study.keys()}

    def survey(
        self, study: Study, names: tuple[str, ...]
    ) -> tuple[dict[SampleKey, str], dict[SampleKey, dict[str, Any]]]:
        """:meth:`scan` and the root attributes ``names`` of every finished sample, each file
        opened once (``jamlab status``: its costs and machines)."""
        states: dict[SampleKey, str] = {}
        attrs: dict[SampleKey, dict[str, Any]] = {}
        for key in study.keys():
            states[key], found = self.state_attrs(key, study, names)
            if states[key] == "done":
                attrs[key] = found
        return states, attrs

    def write_sample(self, key: SampleKey, result: SampleResult, seed: int, study: Study) -> Path:
        """Write ``result`` atomically as ``key``'s sample file; removes a failure record."""
        from jamlab import __version__

        lengths = {np.asarray(v).shape for v in result.traces.values()}
        if len(lengths) > 1:
            raise ValueError(f"trace arrays of unequal shapes {sorted(lengths)}")

        def dataset(group: h5py.Group, name: str, values: Any) -> None:
            values = np.asarray(values)
            group.create_dataset(name, data=values).attrs["sha256"] = _digest(values)

        def fill(h5: h5py.File) -> None:
            h5.attrs["format"] = SAMPLE_FORMAT
            h5.attrs["format_version"] = FORMAT_VERSION
            h5.attrs["phi"] = key.phi_label
            h5.attrs["n"] = key.n
            h5.attrs["index"] = key.index
            h5.attrs["seed"] = str(seed)
            h5.attrs["master_seed"] = study.seed
            h5.attrs["task"] = study.task
            h5.attrs["jamlab_version"] = __version__
            h5.attrs["seconds"] = float(result.seconds)
            if math.isfinite(result.cpu_seconds):
                h5.attrs["cpu_seconds"] = float(result.cpu_seconds)
            if result.provenance:
                h5.attrs["provenance"] = json.dumps(result.provenance)
            for name, value in result.attrs.items():
                h5.attrs[name] = value
            trace = h5.create_group("trace")
            for name, values in result.traces.items():
                dataset(trace, name, values)
            packing = h5.create_group("packing")
            for name, values in result.arrays.items():
                dataset(packing, name, values)
            h5.attrs["complete"] = True

        path = self.sample_path(key)
        atomic_write_hdf5(path, fill, make_parents=True)
        if self.failure_path(key).exists():
            # the sample failed before and a retry finished it: its failures are kept, and the
            # trace of the last one that had a checkpoint (the record owning it names it). The
            # kept record is written first, then the trace renamed, then the record removed: an
            # interruption in between leaves the record beside its copy (counted twice by
            # failures(), never lost)
            past = self.failures(key)
            trace, kept = self.failure_trace_path(key), self._beside(key, ".retried.h5")
            if trace.exists():
                owner = max((i for i, r in enumerate(past) if r.get("trace")), default=-1)
                for i, record in enumerate(past):
                    record["trace"] = kept.name if i == owner else None
            write_json(self.retried_path(key), {"failures": past})
            if trace.exists():
                os.replace(trace, kept)
            self.failure_path(key).unlink()
        return path

    def write_failure(self, key: SampleKey, failure: SampleFailure, seed: int) -> Path:
        """Record ``key``'s failure (a sample file, if any, is left alone), with the failures
        recorded before it (``earlier``) and a copy of its checkpoint's trace, if it has one
        (``trace``: the copy's file name, else ``None``)."""
        path = self.failure_path(key)
        earlier = self._open_failures(key)
        saved = self.checkpoint_dir(key) / CHECKPOINT_TRACE
        trace = None
        if saved.is_file():
            copy = atomic_write(self.failure_trace_path(key),
                                lambda tmp: shutil.copyfile(saved, tmp), make_parents=True)
            trace = copy.name
            for record in earlier:  # their copy, if any, is replaced by this one
                record["trace"] = None
        record = {
            "phi": key.phi_label,
            "n": key.n,
            "index": key.index,
            "seed": str(seed),
            "error_type": failure.error_type,
            "message": failure.message,
            "traceback": failure.traceback,
            "seconds": failure.seconds,
            "cpu_seconds": failure.cpu_seconds,
            "time": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            "machine": failure.machine,
            "trace": trace,
        }
        write_json(path, {**record, "earlier": earlier} if earlier else record)
        return path

    def read_failure(self, key: SampleKey) -> dict[str, Any]:
        return json.loads(self.failure_path(key).read_text())

    def failures(self, key: SampleKey) -> list[dict[str, Any]]:
        """Every failure recorded for ``key``, oldest first: those a retry already finished
        (``.retried.json``), then the current record's ``earlier`` and the record itself."""
        found: list[dict[str, Any]] = []
        if self.retried_path(key).exists():
            found += json.loads(self.retried_path(key).read_text()).get("failures", [])
        return found + self._open_failures(key)

    def _open_failures(self, key: SampleKey) -> list[dict[str, Any]]:
        """The failures since the sample was last finished: the record's ``earlier`` and the
        record itself, oldest first (none without a record)."""
        if not self.failure_path(key).exists():
            return []
        record = self.read_failure(key)
        return list(record.pop("earlier", [])) + [record]

    def summary(
        self, study: Study, states: Mapping[SampleKey, str] | None = None
    ) -> dict[tuple[str, int], dict[str, int]]:
        """Counts of each state per ``(φ label, N)``; ``states``: a :meth:`scan` already made."""
        counts: dict[tuple[str, int], dict[str, int]] = {
            (phi_label(phi), n): dict.fromkeys(STATES, 0) for phi in study.phi for n in study.n
        }
        for key, state in (self.scan(study) if states is None else states).items():
            counts[(key.phi_label, key.n)][state] += 1
        return counts
