"""Loading a run: every sample's trace in one ``xarray.Dataset``.

Why xarray rather than pandas: the data are a dense hyper-rectangle ``φ × N × sample × step`` of
several per-step quantities; xarray keeps that shape (``ds.energy.sel(phi="jamming", N=500)`` is a
``sample × step`` array ready for :mod:`jamlab.analysis`), whereas a long pandas table would repeat
four index columns for every number. ``ds.to_dataframe()`` gives the pandas view when wanted.

Dataset returned by :func:`open_run`:

- dimensions ``phi`` (labels: ``"jamming"`` or the float's ``repr``, e.g. ``"0.75"``), ``N``,
  ``sample`` (``0 .. samples−1``), ``step`` (``0 .. longest trace − 1``);
- coordinate ``phi_value`` (``phi``): the number, NaN for ``"jamming"``;
- per-step variables ``gamma, energy, shear_stress, pressure, z, z_nr, max_force, iterations,
  energy_jump, stress_jump, plastic`` (``phi, N, sample, step``), all float64 with NaN where a
  sample is missing (failed/pending) or its trace is shorter (``plastic`` is 1.0/0.0/NaN;
  ``iterations`` is exact, being below 2⁵³); and, when at least one sample stored them, the
  optional ``jammed`` (1.0/0.0/NaN, NaN also for a sample without the column) and ``phi_step``
  (the per-step packing fraction, stored as ``phi`` in the sample; renamed because ``phi`` is a
  dimension here);
- per-sample variables ``status`` (``"done"``, ``"failed"``, ``"corrupt"``, ``"pending"``),
  ``seed`` (uint64, the derived seed, known for every sample), ``n_steps`` (0 if missing),
  ``failures`` (how many failures the run recorded for the sample: a finished sample with
  ``failures > 0`` was finished by a retry, ``RunDir.failures``, docs/runs.md) and the
  numeric attributes the task stored (e.g. ``phi_actual``: φ of the prepared packing, φ_J at
  jamming; ``seconds``: the worker's wall time; ``cpu_seconds``: its CPU time), NaN where missing;
- ``attrs``: the manifest's ``study`` (JSON), ``master_seed``, ``jamlab_version``, ``created``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import xarray as xr

from jamlab.files import check_links
from jamlab.runs.results import OPTIONAL_TRACE_FIELDS, TRACE_FIELDS
from jamlab.runs.seeds import sample_seed
from jamlab.runs.storage import RunDir
from jamlab.runs.study import SampleKey, phi_label

__all__ = ["open_run", "read_sample"]

_SKIP_ATTRS = {"format", "format_version", "phi", "n", "index", "seed", "master_seed", "complete"}


def read_sample(path: str | os.PathLike) -> dict[str, Any]:
    """One sample file as ``{"attrs": {...}, "trace": {name: array}, "packing": {...}}``;
    ``ValueError`` ("damaged file") for a dangling link among them (:func:`_check_sample_links`)."""
    with h5py.File(path, "r") as h5:
        _check_sample_links(h5, path)
        return {
            "attrs": {k: _plain(v) for k, v in h5.attrs.items()},
            "trace": {k: h5["trace"][k][()] for k in h5["trace"]},
            "packing": {k: h5["packing"][k][()] for k in h5.get("packing", {})},
        }


def prepared_packing(path: str | os.PathLike, gamma: float = 0.0) -> Any:
    """The prepared packing a sample file keeps, as a :class:`~jamlab.spheres.state.Packing`
    placed at strain ``gamma``: ``packing/positions`` (and ``packing/diameters`` where stored),
    the box side ``box_length``, and the pair exponent of the run's study (the file must sit in
    its run directory, ``RUN/samples/phi=…/N=…/sample-*.h5``). It is the start of the sample's
    shear, not its last minimum: a sample is replayed from it, not continued."""
    from jamlab.spheres.box import Box
    from jamlab.spheres.state import Packing

    path = Path(path)
    study = RunDir(path.parents[3]).study()
    with h5py.File(path, "r") as h5:
        _check_sample_links(h5, path)
        pos = h5["packing/positions"][()]
        dia = h5["packing/diameters"][()] if "diameters" in h5["packing"] else None
        length = float(h5.attrs["box_length"])
    return Packing(pos, Box(length, pos.shape[1], float(gamma)), diameters=dia,
                   alpha=study.alpha)


def _check_sample_links(h5: h5py.File, path: str | os.PathLike) -> None:
    """:func:`jamlab.files.check_links` on the groups a sample reader reads (the root, ``trace``
    and ``packing``): a dangling link is a damaged file, not h5py's ``KeyError`` (nor, through
    ``h5.get``, a member taken for absent). :func:`open_run` reads only samples that
    ``RunDir.state`` found whole, which opened every member: a damaged one is ``"corrupt"``."""
    check_links(h5, path)
    for name in ("trace", "packing"):
        group = h5.get(name)
        if isinstance(group, h5py.Group):
            check_links(group, path)


def _plain(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def open_run(path: str | os.PathLike, fields: tuple[str, ...] | None = None) -> xr.Dataset:
    """The traces of the run directory ``path`` as an :class:`xarray.Dataset` (module docstring).

    Parameters
    ----------
    path : path
        A run directory made by :func:`jamlab.runs.run_study` / ``jamlab run``.
    fields : tuple of str, optional
        The per-step variables to load (default: all of ``TRACE_FIELDS`` and of
        ``OPTIONAL_TRACE_FIELDS`` present).

    Returns
    -------
    xarray.Dataset
        Dimensions ``(phi, N, sample, step)``; per-step variables (``gamma``, ``energy``, …,
        NaN where a sample is not done), per-sample ``status`` (``done``, ``pending``,
        ``failed``, ``corrupt``), ``seed`` and scalar attributes; the study in ``attrs``.

    Examples
    --------
    >>> from jamlab.runs import Execution, Study, open_run, run_study
    >>> study = Study(phi=[0.8], n=[32], samples=2, dgamma=1e-3, gamma_max=5e-3, seed=1)
    >>> _ = run_study(study, "r", Execution(workers=0))
    >>> ds = open_run("r")
    >>> dict(ds.sizes)
    {'phi': 1, 'N': 1, 'sample': 2, 'step': 6}
    >>> ds["status"].values.ravel().tolist(), float(ds["gamma"][0, 0, 1, -1])
    (['done', 'done'], 0.005)
    """
    run = RunDir(Path(path))
    manifest = run.read_manifest()
    study = run.study()
    valid = TRACE_FIELDS + OPTIONAL_TRACE_FIELDS
    fields = tuple(valid if fields is None else fields)
    unknown = sorted(set(fields) - set(valid))
    if unknown:
        raise ValueError(f"unknown trace field(s) {', '.join(unknown)}; valid: {valid}")
    shape3 = (len(study.phi), len(study.n), study.samples)
    status = np.full(shape3, "pending", dtype=object)
    seeds = np.zeros(shape3, dtype=np.uint64)
    n_steps = np.zeros(shape3, dtype=np.int64)
    failures = np.zeros(shape3, dtype=np.int64)
    traces: dict[tuple[int, int, int], dict[str, np.ndarray]] = {}
    scalars: dict[str, np.ndarray] = {}
    for key in study.keys():
        idx = (study.phi.index(key.phi), study.n.index(key.n), key.index)
        seeds[idx] = sample_seed(study.seed, key)
        state = run.state(key, study)
        status[idx] = state
        failures[idx] = len(run.failures(key))
        if state != "done":
            continue
        with h5py.File(run.sample_path(key), "r") as h5:
            traces[idx] = {f: np.asarray(h5["trace"][f][()]) for f in fields if f in h5["trace"]}
            for name, value in h5.attrs.items():
                value = _plain(value)
                if name in _SKIP_ATTRS or isinstance(value, str) or not _is_number(value):
                    continue
                scalars.setdefault(name, np.full(shape3, np.nan))[idx] = float(value)
        n_steps[idx] = max(
            (len(v) for k, v in traces[idx].items() if k not in OPTIONAL_TRACE_FIELDS), default=0
        )
    n_max = int(n_steps.max(initial=0))
    data_vars: dict[str, Any] = {}
    for f in fields:
        if f in OPTIONAL_TRACE_FIELDS and not any(f in tr for tr in traces.values()):
            continue
        arr = np.full((*shape3, n_max), np.nan)
        for idx, tr in traces.items():
            if f in tr:
                arr[idx][: len(tr[f])] = tr[f].astype(np.float64)
        data_vars["phi_step" if f == "phi" else f] = (("phi", "N", "sample", "step"), arr)
    dims3 = ("phi", "N", "sample")
    data_vars["status"] = (dims3, status.astype(str))
    data_vars["seed"] = (dims3, seeds)
    data_vars["n_steps"] = (dims3, n_steps)
    data_vars["failures"] = (dims3, failures)
    for name, arr in scalars.items():
        data_vars[name] = (dims3, arr)
    coords = {
        "phi": [phi_label(p) for p in study.phi],
        "phi_value": ("phi", [math.nan if isinstance(p, str) else float(p) for p in study.phi]),
        "N": list(study.n),
        "sample": np.arange(study.samples),
        "step": np.arange(n_max),
    }
    attrs = {
        "study": json.dumps(study.to_dict()),
        "master_seed": study.seed,
        "jamlab_version": str(manifest.get("jamlab_version", "")),
        "created": str(manifest.get("created", "")),
        "run_directory": str(run.path),
    }
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating | bool)


def sample_key(phi: str | float, n: int, index: int) -> SampleKey:
    """A :class:`SampleKey` from user-facing values (``phi`` may be a label string)."""
    from jamlab.runs.study import parse_phi

    return SampleKey(parse_phi(phi), int(n), int(index))
