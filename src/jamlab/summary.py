"""The summary ``jamlab inspect`` prints, computed when a configuration is written and stored in it.

``inspect`` prints N, d, φ, strain, E, Σ, p, z, z_nr, the rattlers, the backbone contacts and
``max |F_i|`` (:data:`SUMMARY_KEYS`). Computing them needs the numba kernels, and any command that
touches a kernel pays numba's own start-up (importing numba ≈ 0.2 s, its first cached call ≈ 0.5 s;
``docs/spheres.md``, "First run"), whatever the size of the file. So
:func:`jamlab.spheres.io.write_packing` computes the summary once, with the same code, and stores
it in the file (root attributes ``summary``, JSON, and ``summary_key``); ``inspect`` prints the
stored one when it is valid and computes it otherwise.

Valid means: ``summary_key`` equals :func:`file_key`, the SHA-256 of the source files that compute
the summary (:data:`CODE`) and of everything else in the file — every dataset, every root
attribute, the summary text included. Any change to the file, to the stored numbers or to the
code that computes them makes the key differ, and the file is read and checked
(:func:`jamlab.spheres.io.read_packing`) and summarised anew: a stored number is always the one
the current code computes for the current contents (``tests/test_summary.py``).
Files without the attributes (older files, other programs') are computed as before.

This module imports neither numba nor :mod:`jamlab.spheres` until it has to compute (and numpy
and h5py only when used: the CLI imports it at start-up).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from pathlib import Path
from typing import Any

__all__ = ["CODE", "SUMMARY_KEYS", "compute_summary", "file_key", "stored_summary", "summary_text"]

SUMMARY_KEYS = (
    "n",
    "dim",
    "phi",
    "strain",
    "energy",
    "shear_stress",
    "pressure",
    "z",
    "z_nr",
    "n_rattlers",
    "n_contacts_nr",
    "max_force",
)
"""What ``jamlab inspect`` prints, in order."""

CODE = ("summary.py", "spheres/box.py", "spheres/pair.py", "spheres/state.py",
        "spheres/neighbors.py", "spheres/contacts.py", "spheres/potential.py",
        "spheres/kernels/*.py")
"""The source files (relative to the package) whose code computes the summary."""

_INTEGER_KEYS = ("n", "dim", "n_rattlers", "n_contacts_nr")


@functools.cache
def _code_digest() -> bytes:
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for pattern in CODE:
        for path in sorted(root.glob(pattern)):
            h.update(path.relative_to(root).as_posix().encode())
            h.update(path.read_bytes())
    return h.digest()


def file_key(h5: Any) -> str:
    """SHA-256 of the code digest and of everything in the open configuration file ``h5`` except
    the attribute ``summary_key`` itself: every dataset (name, dtype, shape, bytes), every other
    root attribute (the summary text included) and the names of any groups."""
    import h5py
    import numpy as np

    h = hashlib.sha256(_code_digest())
    for name in sorted(h5):
        item = h5[name]
        h.update(name.encode())
        if isinstance(item, h5py.Dataset):
            data = np.ascontiguousarray(item[()])
            h.update(f"{data.dtype.str}{data.shape}".encode())
            h.update(data.tobytes())
    for name in sorted(h5.attrs):
        if name == "summary_key":
            continue
        value = h5.attrs[name]
        if isinstance(value, np.ndarray):
            value = (value.dtype.str, value.shape, value.tobytes())
        elif isinstance(value, np.generic):
            value = (type(value).__name__, value.item())
        h.update(f"{name}={value!r};".encode())
    return h.hexdigest()


def compute_summary(packing: Any) -> dict[str, float | int]:
    """The numbers of :data:`SUMMARY_KEYS` for a :class:`jamlab.spheres.Packing`."""
    import jamlab.spheres as sp

    nl = sp.NeighborList(packing, skin=0.0)
    rattlers = sp.remove_rattlers(packing, nl)
    return {
        "n": packing.n,
        "dim": packing.dim,
        "phi": packing.phi,
        "strain": packing.strain,
        "energy": sp.energy(packing, nl),
        "shear_stress": sp.shear_stress(packing, nl),
        "pressure": sp.pressure(packing, nl),
        "z": sp.coordination(packing, nl),
        "z_nr": rattlers.z_nr,
        "n_rattlers": rattlers.n_rattlers,
        "n_contacts_nr": rattlers.n_contacts_nr,
        "max_force": sp.max_force(packing, nl),
    }


def summary_text(packing: Any) -> str:
    """The summary of ``packing`` as the JSON text stored in the root attribute ``summary``
    (:func:`jamlab.spheres.io.write_packing` adds ``summary_key = file_key(...)`` last)."""
    return json.dumps(compute_summary(packing))


def stored_summary(path: str | Path) -> dict[str, float | int] | None:
    """The summary stored in the configuration file ``path`` if it is valid for its contents and
    the current code (module docstring), else ``None`` (then compute it)."""
    import h5py

    try:
        with h5py.File(path, "r") as h5:
            text, key = h5.attrs.get("summary"), h5.attrs.get("summary_key")
            if not (isinstance(text, str) and isinstance(key, str)) or key != file_key(h5):
                return None
    except (OSError, KeyError, TypeError, ValueError):
        return None
    try:
        summary = json.loads(text)
    except ValueError:
        return None
    if not (isinstance(summary, dict) and list(summary) == list(SUMMARY_KEYS)):
        return None
    for k, v in summary.items():
        if isinstance(v, bool) or not isinstance(v, int | float):
            return None
        if k in _INTEGER_KEYS and not isinstance(v, int):
            return None
        if isinstance(v, float) and not math.isfinite(v):
            return None
    return summary
