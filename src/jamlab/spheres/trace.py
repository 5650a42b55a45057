"""The AQS trace: per-step record of an athermal quasi-static shear run, and its HDF5 file.

Rows ``n = 0 … M``: row 0 is the starting minimum (strain ``γ_0``, usually 0), row ``n ≥ 1`` the
minimum after the ``n``-th strain step ``γ_{n-1} → γ_n``. Columns (``SPEC.md`` §3, extensive
``E`` and ``Σ``):

- ``gamma``: accumulated strain ``γ_n``;
- ``energy``: total energy ``E_n``; ``shear_stress``: ``Σ_n = ∂E/∂γ``; ``pressure``: ``p_n``;
- ``z = 2 N_c/N``, ``z_nr = 2 N_c'/N'`` (rattlers removed);
- ``max_force``: ``max_i |F_i|`` of the recorded minimum (a value ``≥ ftol`` means the minimiser did
  not converge: recorded, never hidden);
- ``iterations``: minimiser iterations spent on the step (Newton + FIRE; row 0: the initial
  minimisation, 0 if the input already was a minimum);
- ``energy_jump``: ``ΔE = E_n − E_{n-1} − (γ_n − γ_{n-1}) Σ_{n-1}``, NaN in row 0;
- ``stress_jump``: ``ΔΣ = Σ_n − Σ_{n-1}``, NaN in row 0;
- ``plastic``: True when the minimum of row ``n`` is not the continuation of the minimum of row
  ``n − 1`` (see ``docs/aqs.md``); False in row 0;
- ``jammed`` (format version 2, optional): whether the minimum of row ``n`` is jammed
  (:mod:`jamlab.spheres.rigidity`: non-empty, at least isostatic backbone, ``p > p_floor(ftol)``);
  ``None`` when unknown (files of version 1);
- ``phi`` (format version 2, optional): packing fraction of the minimum (constant at constant
  volume, ``φ(γ)`` at fixed pressure); ``None`` when unknown.

At fixed pressure (``attrs["protocol"] == "fixed-pressure"``, ``attrs["energy_column"] ==
"enthalpy"``) the ``energy`` column holds the enthalpy ``H = E + p_t V`` and ``energy_jump`` is
``ΔH`` (``docs/aqs.md``, "At the jamming point").

So row ``n`` of ``energy_jump``/``stress_jump``/``plastic`` describes the step ``n−1 → n`` (the
paper's ``ΔE_{n-1}``). Files are written atomically (temporary file, fsync, ``os.replace``).

Optional group ``avalanches`` (``shear(..., keep_avalanches=True)``, :attr:`Trace.avalanches`):
one row per plastic step with its anatomy and the displacement field in CSR form
(``docs/formats.md``, :mod:`jamlab.spheres.aqs.anatomy`).

Optional group ``fixed_pressure`` (fixed-pressure runs, :attr:`Trace.fixed_pressure`): the
per-row columns of that protocol that the columns above do not hold — ``energy`` (``E``; the
trace's ``energy`` is ``H`` there), ``box_length``, ``volume_steps``, ``converged`` and
``confirmed`` (the plastic-flag confirmation of each step) and, from 2026-12-03, ``held`` (the
residual a candidate's piece held when redone smaller: ``jamlab.spheres.confirm.residual_held``),
one value per row. With them (and the
configuration group) a fixed-pressure run resumes bit for bit.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from jamlab.files import atomic_write_hdf5, check_links, open_hdf5

__all__ = [
    "FIXED_PRESSURE_COLUMNS",
    "FIXED_PRESSURE_OPTIONAL",
    "OPTIONAL_COLUMNS",
    "Trace",
    "TRACE_COLUMNS",
    "jump_columns",
    "write_trace",
    "read_trace",
    "read_trace_configuration",
]

FORMAT = "jamlab-aqs-trace"
FORMAT_VERSION = 2

TRACE_COLUMNS: tuple[str, ...] = (
    "gamma",
    "energy",
    "shear_stress",
    "pressure",
    "z",
    "z_nr",
    "max_force",
    "iterations",
    "energy_jump",
    "stress_jump",
    "plastic",
)

OPTIONAL_COLUMNS: tuple[str, ...] = ("jammed", "phi")
"""Columns of format version 2 that older files lack (read as ``None``)."""

_DTYPES = {"iterations": np.int64, "plastic": np.bool_, "jammed": np.bool_}

FIXED_PRESSURE_COLUMNS: tuple[str, ...] = (
    "energy", "box_length", "volume_steps", "converged", "confirmed",
)
"""Columns of the optional group ``fixed_pressure`` (module docstring)."""
FIXED_PRESSURE_OPTIONAL: tuple[str, ...] = ("held",)
"""Columns of the group ``fixed_pressure`` that traces made before them lack (absent: ``None``
in :attr:`Trace.fixed_pressure`)."""
_FIXED_PRESSURE_DTYPES = {"energy": np.float64, "box_length": np.float64,
                          "volume_steps": np.int64, "converged": np.bool_, "confirmed": np.bool_,
                          "held": np.float64}


def jump_columns(gamma, energy, stress) -> tuple[np.ndarray, np.ndarray]:
    """The per-step jumps of a trace, NaN in row 0: ``ΔE_n − (γ_n − γ_{n−1}) Σ_{n−1}`` (the
    energy change less its elastic work at the previous stress; ``energy`` may be the enthalpy
    at fixed pressure) and ``ΔΣ_n``. The one implementation of these columns."""
    g = np.asarray(gamma, dtype=np.float64)
    e = np.asarray(energy, dtype=np.float64)
    s = np.asarray(stress, dtype=np.float64)
    ej = np.full(g.shape, np.nan)
    sj = np.full(g.shape, np.nan)
    ej[1:] = np.diff(e) - np.diff(g) * s[:-1]
    sj[1:] = np.diff(s)
    return ej, sj


@dataclass(frozen=True, eq=False)
class Trace:
    """Per-step AQS record (1-D arrays of equal length ``M + 1``; see the module docstring).

    ``attrs`` holds the run parameters (``dgamma``, ``gamma_max``, ``ftol``, ``minimizer``,
    ``N``, ``dim``, ``phi``, ``seed``, ``jamlab_version``, ``source``, ...).
    """

    gamma: np.ndarray
    energy: np.ndarray
    shear_stress: np.ndarray
    pressure: np.ndarray
    z: np.ndarray
    z_nr: np.ndarray
    max_force: np.ndarray
    iterations: np.ndarray
    energy_jump: np.ndarray
    stress_jump: np.ndarray
    plastic: np.ndarray
    attrs: dict = field(default_factory=dict)
    jammed: np.ndarray | None = None
    phi: np.ndarray | None = None
    avalanches: dict | None = None
    fixed_pressure: dict | None = None

    def __post_init__(self) -> None:
        n = None
        for name in TRACE_COLUMNS + OPTIONAL_COLUMNS:
            if getattr(self, name) is None:
                continue
            arr = np.array(getattr(self, name), dtype=_DTYPES.get(name, np.float64))
            if arr.ndim != 1:
                raise ValueError(f"trace column {name} must be 1-D, got shape {arr.shape}")
            if n is None:
                n = arr.shape[0]
            elif arr.shape[0] != n:
                raise ValueError(f"trace column {name} has {arr.shape[0]} rows, expected {n}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if n == 0:
            raise ValueError("a trace needs at least row 0 (the starting minimum)")
        object.__setattr__(self, "attrs", dict(self.attrs))
        if self.avalanches is not None:
            object.__setattr__(self, "avalanches", dict(self.avalanches))
        if self.fixed_pressure is not None:
            group = {}
            for key in FIXED_PRESSURE_COLUMNS + FIXED_PRESSURE_OPTIONAL:
                if self.fixed_pressure.get(key) is None:
                    if key in FIXED_PRESSURE_OPTIONAL:
                        continue
                    raise ValueError(f"fixed_pressure lacks the column {key}")
                arr = np.array(self.fixed_pressure[key], dtype=_FIXED_PRESSURE_DTYPES[key])
                if arr.shape != (n,):
                    raise ValueError(f"fixed_pressure column {key} has shape {arr.shape}, "
                                     f"expected ({n},)")
                arr.setflags(write=False)
                group[key] = arr
            object.__setattr__(self, "fixed_pressure", group)

    def with_avalanches(self, avalanches: dict | None) -> Trace:
        """The same trace with the group ``avalanches`` (``shear(..., keep_avalanches=True)``;
        ``docs/formats.md``): 1-D datasets of one row per plastic step, the CSR displacement
        field, and an ``attrs`` dict."""
        return Trace(
            **self.columns(), **self.optional_columns(), attrs=self.attrs, avalanches=avalanches,
            fixed_pressure=self.fixed_pressure,
        )

    @property
    def n_steps(self) -> int:
        """Number of strain steps ``M`` (rows minus one)."""
        return int(self.gamma.shape[0] - 1)

    @property
    def residual(self) -> np.ndarray:
        """Trapezoid residual ``r = ΔE − ½ (γ_n − γ_{n−1}) ΔΣ`` per row (NaN in row 0).

        ``≈ 0`` (``O(δγ³)`` + noise) on an elastic step, ``≈ −S`` on a plastic one.
        """
        dg = np.concatenate([[np.nan], np.diff(self.gamma)])
        return self.energy_jump - 0.5 * dg * self.stress_jump

    @classmethod
    def from_rows(cls, rows: dict[str, list], attrs: dict | None = None) -> Trace:
        """Build from per-column lists (``energy_jump``, ``stress_jump`` are derived)."""
        ej, sj = jump_columns(rows["gamma"], rows["energy"], rows["shear_stress"])
        cols = {k: rows[k] for k in TRACE_COLUMNS if k not in ("energy_jump", "stress_jump")}
        extra = {k: rows.get(k) for k in OPTIONAL_COLUMNS}
        return cls(**cols, energy_jump=ej, stress_jump=sj, attrs=attrs or {}, **extra)

    def columns(self) -> dict[str, np.ndarray]:
        """The eleven required columns by name."""
        return {name: getattr(self, name) for name in TRACE_COLUMNS}

    def optional_columns(self) -> dict[str, np.ndarray]:
        """The optional columns (``jammed``, ``phi``) this trace has."""
        return {k: getattr(self, k) for k in OPTIONAL_COLUMNS if getattr(self, k) is not None}

    def head(self, rows: int) -> Trace:
        """The first ``rows`` rows (without the ``avalanches`` group)."""
        cols = {**self.columns(), **self.optional_columns()}
        fp = self.fixed_pressure
        return Trace(**{k: v[:rows] for k, v in cols.items()}, attrs=self.attrs,
                     fixed_pressure=None if fp is None else {k: v[:rows] for k, v in fp.items()})


def _attr_value(value: object) -> object:
    if value is None:
        return "none"
    if isinstance(value, Path):
        return str(value)
    return value


def write_trace(path: str | os.PathLike, trace: Trace, configuration: Any = None) -> Path:
    """Write ``trace`` atomically to HDF5: one 1-D dataset per column (names ``TRACE_COLUMNS``),
    ``trace.attrs`` as root attributes, plus ``format`` and ``format_version``.

    ``configuration`` (a :class:`jamlab.spheres.Packing`, optional): the configuration of the
    trace's last row, stored in the group ``configuration`` (``positions``, ``diameters``;
    attributes ``alpha``, ``box_length``, ``strain``, ``seed``, ``step``) of the same file, so
    that a checkpoint (trace + configuration) is written by one atomic rename
    (:func:`read_trace_configuration`)."""

    def fill(h5: h5py.File) -> None:
        for name in TRACE_COLUMNS:
            h5.create_dataset(name, data=getattr(trace, name))
        for name, column in trace.optional_columns().items():
            h5.create_dataset(name, data=column)
        if configuration is not None:
            group = h5.create_group("configuration")
            group.create_dataset(
                "positions", data=np.asarray(configuration.positions, dtype=np.float64)
            )
            group.create_dataset(
                "diameters", data=np.asarray(configuration.diameters, dtype=np.float64)
            )
            group.attrs["alpha"] = float(configuration.alpha)
            group.attrs["box_length"] = float(configuration.box.length)
            group.attrs["strain"] = float(configuration.box.strain)
            group.attrs["seed"] = int(-1 if configuration.seed is None else configuration.seed)
            group.attrs["step"] = int(trace.n_steps)
        if trace.fixed_pressure is not None:
            group = h5.create_group("fixed_pressure")
            for key, value in trace.fixed_pressure.items():
                group.create_dataset(key, data=value)
        if trace.avalanches is not None:
            group = h5.create_group("avalanches")
            for key, value in trace.avalanches.items():
                if key == "attrs":
                    for name, v in value.items():
                        group.attrs[name] = _attr_value(v)
                else:
                    group.create_dataset(key, data=np.asarray(value))
        for key, value in trace.attrs.items():
            h5.attrs[key] = _attr_value(value)
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION

    return atomic_write_hdf5(path, fill)


def read_trace_configuration(path: str | os.PathLike) -> dict[str, Any] | None:
    """The configuration stored with the trace by :func:`write_trace` (``positions``,
    ``diameters`` (absent in older files), ``alpha``, ``box_length``, ``strain``, ``seed``,
    ``step``), or ``None`` if the file has none. A dangling link there is a damaged file
    (:func:`jamlab.files.check_links`), not an absent member: ``group.get`` would return ``None``
    for it, and a resumed run would go on with diameters of 1."""
    try:
        with h5py.File(path, "r") as h5:
            check_links(h5, path)
            group = h5.get("configuration")
            if not isinstance(group, h5py.Group):
                return None
            check_links(group, path)
            positions = group.get("positions")
            if not isinstance(positions, h5py.Dataset) or positions.dtype.kind != "f":
                raise ValueError(f"damaged configuration group in {path}")
            out: dict[str, Any] = {"positions": np.asarray(positions[()], dtype=np.float64)}
            diameters = group.get("diameters")
            if diameters is not None:
                if not isinstance(diameters, h5py.Dataset) or diameters.dtype.kind != "f":
                    raise ValueError(f"damaged configuration group in {path}")
                out["diameters"] = np.asarray(diameters[()], dtype=np.float64)
            out["alpha"] = float(group.attrs.get("alpha", 2.0))
            for key in ("box_length", "strain", "seed", "step"):
                value = group.attrs[key]
                out[key] = value.item() if isinstance(value, np.generic) else value
            return out
    except (OSError, KeyError, TypeError) as exc:
        raise ValueError(f"unreadable configuration group in {path}: {exc}") from None


def read_trace(path: str | os.PathLike) -> Trace:
    """Read a trace written by :func:`write_trace`; ``ValueError`` if the file is not one."""
    path = Path(path)
    with open_hdf5(path, "trace", newest=FORMAT_VERSION, expected=FORMAT) as h5:
        check_links(h5, path)
        missing = [name for name in TRACE_COLUMNS if name not in h5]
        if missing:
            raise ValueError(f"not a jamlab AQS trace (missing {', '.join(missing)}): {path}")
        cols = {}
        for name in TRACE_COLUMNS + tuple(k for k in OPTIONAL_COLUMNS if k in h5):
            item = h5[name]
            numeric = isinstance(item, h5py.Dataset) and item.dtype.kind in "fiub"
            if not numeric or item.ndim != 1:
                raise ValueError(f"not a jamlab AQS trace ({name}: not 1-D numeric): {path}")
            cols[name] = item[()]
        attrs = {}
        for key, value in h5.attrs.items():
            if key in ("format", "format_version"):
                continue
            if isinstance(value, bytes):
                value = value.decode()
            elif isinstance(value, np.generic):
                value = value.item()
            attrs[key] = value
        avalanches = None
        group = h5.get("avalanches")
        if isinstance(group, h5py.Group):
            check_links(group, path)
            avalanches = {k: group[k][()] for k in group if isinstance(group[k], h5py.Dataset)}
            avalanches["attrs"] = {
                k: (v.item() if isinstance(v, np.generic) else v) for k, v in group.attrs.items()
            }
        fixed_pressure = None
        group = h5.get("fixed_pressure")
        if isinstance(group, h5py.Group):
            check_links(group, path)
            fixed_pressure = {}
            for key in FIXED_PRESSURE_COLUMNS + FIXED_PRESSURE_OPTIONAL:
                item = group.get(key)
                if item is None and key in FIXED_PRESSURE_OPTIONAL:
                    continue
                if not (isinstance(item, h5py.Dataset) and item.dtype.kind in "fiub"):
                    raise ValueError(f"not a jamlab AQS trace (fixed_pressure/{key}): {path}")
                fixed_pressure[key] = item[()]
    try:
        return Trace(**cols, attrs=attrs, avalanches=avalanches, fixed_pressure=fixed_pressure)
    except ValueError as exc:
        raise ValueError(f"invalid AQS trace {path}: {exc}") from None
