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

Writes are atomic: a temporary file in the destination directory is written, flushed, fsync'ed
and renamed over the destination with ``os.replace``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import numpy as np

from jamlab._atomic import atomic_write
from jamlab.spheres.box import Box
from jamlab.spheres.state import Packing

__all__ = ["write_packing", "read_packing", "read_lammps_positions"]

FORMAT = "jamlab-configuration"
FORMAT_VERSION = 1


def write_packing(path: str | os.PathLike, packing: Packing, **extra_attrs: object) -> Path:
    """Write ``packing`` to the HDF5 file ``path`` atomically; ``extra_attrs`` are stored as
    additional root attributes (numbers or strings). Returns the path."""
    from jamlab import __version__

    def write(tmp: str) -> None:
        with h5py.File(tmp, "w") as h5:
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
            h5.flush()

    return atomic_write(path, write)


def read_packing(path: str | os.PathLike) -> Packing:
    """Read a configuration written by :func:`write_packing`; ``ValueError`` if it is not one."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such configuration file: {path}")
    try:
        h5 = h5py.File(path, "r")
    except OSError:
        raise ValueError(f"not an HDF5 file: {path}") from None
    with h5:
        missing = [k for k in ("box_length", "strain", "dim") if k not in h5.attrs]
        if "positions" not in h5 or missing:
            what = ", ".join((["positions"] if "positions" not in h5 else []) + missing)
            raise ValueError(f"not a jamlab configuration (missing {what}): {path}")
        positions = np.asarray(h5["positions"][()], dtype=np.float64)
        length = float(h5.attrs["box_length"])
        strain = float(h5.attrs["strain"])
        dim = int(h5.attrs["dim"])
        seed = int(h5.attrs["seed"]) if "seed" in h5.attrs else -1
        phi = float(h5.attrs["phi"]) if "phi" in h5.attrs else None
        diameters = np.asarray(h5["diameters"][()], np.float64) if "diameters" in h5 else None
        alpha = float(h5.attrs["alpha"]) if "alpha" in h5.attrs else 2.0
    packing = Packing(
        positions,
        Box(length, dim, strain),
        seed=None if seed < 0 else seed,
        diameters=diameters,
        alpha=alpha,
    )
    if phi is not None and not np.isclose(phi, packing.phi, rtol=1e-10, atol=0):
        raise ValueError(
            f"inconsistent file {path}: phi={phi} but sum v_d(D_i/2)/L^d = {packing.phi}"
        )
    return packing


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
    seed = None
    if box_length is None:
        meta = path.parent / "meta.json"
        if not meta.is_file():
            raise ValueError(f"box length not given and no meta.json beside {path}")
        info = json.loads(meta.read_text())
        box_length = float(info["box_length"])
        seed = info.get("seed_of_random_start")
    try:
        positions = np.loadtxt(path, comments="#", dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"cannot parse positions file {path}: {exc}") from None
    return Packing(positions, Box(box_length, positions.shape[1], strain), seed=seed)
