"""Reading and writing configurations (format documented in ``docs/formats.md``).

HDF5 configuration file, root group:

- dataset ``positions``: float64 ``(N, d)``, Cartesian, in the sheared (Lees–Edwards) frame;
- attributes ``box_length`` (float), ``strain`` (accumulated γ, float), ``dim`` (int),
  ``phi`` (``Σ_i v_d(D_i/2)/L^d``, float, redundant and checked on reading), ``seed`` (int, ``-1``
  when unknown), ``jamlab_version`` (str), ``format`` = ``"jamlab-configuration"`` and
  ``format_version`` = 1;
- the pair law (``SPEC.md`` §5): dataset ``diameters`` (float64 ``(N,)``) and attribute ``alpha``
  (float). Both are written always; a file without them (older jamlab) reads as monodisperse
  (``D = 1``) harmonic (``α = 2``).

Writes are atomic (:func:`jamlab.files.atomic_write_hdf5`: built in memory, written to a
temporary file in the destination directory, fsync'ed, renamed with ``os.replace``). Reading checks
every item: ``positions`` a numeric ``(N, d)`` dataset with ``d = dim``, finite, a valid box, a
finite strain ``|γ| <= 1e6`` (:mod:`jamlab.validation`), ``phi`` consistent.
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import h5py
import numpy as np

from jamlab import validation
from jamlab.files import atomic_write_hdf5, check_links, open_hdf5
from jamlab.spheres.box import Box
from jamlab.spheres.state import Packing

__all__ = ["write_packing", "read_packing", "failed_preparation", "read_lammps_positions"]

FORMAT = "jamlab-configuration"
FORMAT_VERSION = 1


def write_packing(path: str | os.PathLike, packing: Packing, **extra_attrs: object) -> Path:
    """Write ``packing`` to the HDF5 file ``path`` atomically; ``extra_attrs`` are stored as
    additional root attributes (numbers or strings). Returns the path.

    The file also stores the summary ``jamlab inspect`` prints (:mod:`jamlab.summary`: root
    attributes ``summary``, ``summary_key``), so that inspecting it needs no numba kernel."""
    from jamlab import __version__
    from jamlab.summary import file_key, summary_text

    try:
        summary = summary_text(packing)
    except (ValueError, FloatingPointError, MemoryError):  # inspect will compute (and report) it
        summary = None

    def fill(h5: h5py.File) -> None:
        h5.create_dataset("positions", data=np.asarray(packing.positions, dtype=np.float64))
        h5.create_dataset("diameters", data=np.asarray(packing.diameters, dtype=np.float64))
        h5.attrs["alpha"] = float(packing.alpha)
        h5.attrs["box_length"] = float(packing.box.length)
        h5.attrs["strain"] = float(packing.box.strain)
        h5.attrs["dim"] = int(packing.dim)
        h5.attrs["phi"] = float(packing.phi)
        h5.attrs["seed"] = int(-1 if packing.seed is None else packing.seed)
        h5.attrs["jamlab_version"] = str(__version__)
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION
        for key, value in extra_attrs.items():
            h5.attrs[key] = value
        if summary is not None:
            h5.attrs["summary"] = summary
            h5.attrs["summary_key"] = file_key(h5)  # last: it covers everything above

    return atomic_write_hdf5(path, fill)


def read_packing(path: str | os.PathLike) -> Packing:
    """Read a configuration written by :func:`write_packing`; ``ValueError`` if it is not one."""
    path = Path(path)
    with open_hdf5(path, "configuration", newest=FORMAT_VERSION, expected=FORMAT) as h5:
        check_links(h5, path)
        missing = [k for k in ("box_length", "strain", "dim") if k not in h5.attrs]
        if "positions" not in h5 or missing:
            what = ", ".join((["positions"] if "positions" not in h5 else []) + missing)
            raise ValueError(f"not a jamlab configuration (missing {what}): {path}")
        dataset = h5["positions"]
        if not isinstance(dataset, h5py.Dataset) or dataset.ndim != 2:
            raise ValueError(f"not a jamlab configuration (positions not an (N, d) array): {path}")
        if dataset.dtype.kind not in "fiu":
            raise ValueError(f"not a jamlab configuration (positions of {dataset.dtype}): {path}")
        try:
            positions = np.asarray(dataset[()], dtype=np.float64)
            length = float(h5.attrs["box_length"])
            strain = float(h5.attrs["strain"])
            dim = validation.integer("dim", h5.attrs["dim"], minimum=2)
            seed = validation.integer("seed", h5.attrs.get("seed", -1), minimum=-1)
            phi = float(h5.attrs["phi"]) if "phi" in h5.attrs else None
            diameters = None
            if "diameters" in h5:
                d_set = h5["diameters"]
                if not isinstance(d_set, h5py.Dataset) or d_set.dtype.kind not in "fiu":
                    raise ValueError("diameters is not a numeric dataset")
                diameters = np.asarray(d_set[()], dtype=np.float64)
            alpha = float(h5.attrs["alpha"]) if "alpha" in h5.attrs else 2.0
        except (TypeError, ValueError, OSError) as exc:
            raise ValueError(f"unreadable configuration {path}: {exc}") from None
    validation.strain(f"the strain of {path}", strain)
    if dim != positions.shape[1]:
        raise ValueError(f"inconsistent file {path}: dim={dim} but positions are {positions.shape}")
    try:
        packing = Packing(
            positions,
            Box(length, dim, strain),
            seed=None if seed < 0 else seed,
            diameters=diameters,
            alpha=alpha,
        )
    except ValueError as exc:
        raise ValueError(f"invalid configuration {path}: {exc}") from None
    if phi is not None and not np.isclose(phi, packing.phi, rtol=1e-10, atol=0):
        raise ValueError(
            f"inconsistent file {path}: phi={phi} but sum v_d(D_i/2)/L^d = {packing.phi}"
        )
    return packing


def failed_preparation(path: str | os.PathLike) -> str | None:
    """Why ``jamlab prepare`` flagged the configuration at ``path`` as failing its stopping rule
    (its attributes ``ok = False`` and ``reason``), or ``None`` when it is not so flagged (or
    is not an HDF5 file: :func:`read_packing` reports that)."""
    try:
        with h5py.File(path, "r") as h5:
            if bool(h5.attrs.get("ok", True)):
                return None
            return str(h5.attrs.get("reason", "")) or "no reason recorded"
    except OSError:
        return None


def positions_meta(path: str | os.PathLike, box_length: float | None = None) -> Path | None:
    """The ``meta.json`` that :func:`read_lammps_positions` reads for ``path`` (the one beside
    it when ``box_length`` is not given), else ``None``: an input no output may replace."""
    return Path(path).parent / "meta.json" if box_length is None else None


def read_lammps_positions(
    path: str | os.PathLike, box_length: float | None = None, strain: float = 0.0
) -> Packing:
    """Positions from a whitespace text file (one particle per line, ``#`` comments), as in
    ``reference/*/positions.txt``. The box side comes from ``box_length`` or, if omitted, from
    ``meta.json`` (key ``box_length``) in the same folder. Positions are taken as Cartesian in the
    sheared frame at ``strain``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such positions file: {path}")
    strain = validation.strain("strain", strain)
    seed = None
    meta = positions_meta(path, box_length)
    if meta is not None:
        if not meta.is_file():
            raise ValueError(f"box length not given and no meta.json beside {path}")
        try:
            info = json.loads(meta.read_text())
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise ValueError(f"cannot parse {meta}: {exc}") from None
        if not isinstance(info, dict) or "box_length" not in info:
            raise ValueError(f"{meta} has no key box_length")
        box_length = validation.positive(f"box_length in {meta}", info["box_length"])
        seed = info.get("seed_of_random_start")
        if seed is not None:
            seed = validation.seed(f"seed_of_random_start in {meta}", seed)
    else:
        box_length = validation.positive("box_length", box_length)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "input contained no data": refused just below
            positions = np.loadtxt(path, comments="#", dtype=np.float64, ndmin=2)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot parse positions file {path}: {exc}") from None
    if positions.size == 0:
        raise ValueError(f"no positions in {path}")
    if positions.shape[1] < 2:
        raise ValueError(f"positions file {path} has {positions.shape[1]} column(s), need d >= 2")
    try:
        return Packing(positions, Box(box_length, positions.shape[1], strain), seed=seed)
    except ValueError as exc:
        raise ValueError(f"invalid positions file {path}: {exc}") from None
