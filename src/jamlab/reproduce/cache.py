"""The cache of coordination curves: one ``.npz`` file per jammed packing.

A resumed reproduction (or ``jamlab figure fig1``) must not redo the compression of its packings,
so each :class:`jamlab.spheres.packing.CoordinationCurve` is stored as
``coordination_N{n}_seed{seed}_steps{steps}.npz`` (the name is the key: the packing's size, seed
and number of compression steps) with one array per field. A file is written under a temporary
name and renamed, so an interrupted write never leaves a truncated entry.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CURVE_ARRAYS", "cache_file", "load_curve", "save_curve"]

CURVE_ARRAYS = ("phi", "dphi", "z", "z_nr", "z_iso", "n_rattlers", "energy", "pressure",
                "converged")
"""The array fields of a coordination curve, stored as they are (scalars: ``phi_j, dim, n``)."""


def cache_file(
    cache: Path, n: int, seed: int, steps: int, sizes: str = "mono", alpha: float = 2.0
) -> Path:
    """The file of the curve of the packing of ``n`` spheres, ``seed``, ``steps`` compressions
    (the pair law, when not the paper's, is part of the name: ``…_sizes{s}_alpha{a}.npz``)."""
    law = ""
    if sizes != "mono" or alpha != 2.0:
        law = f"_sizes{sizes.replace(':', '-')}_alpha{alpha:g}"
    return Path(cache) / f"coordination_N{n}_seed{seed}_steps{steps}{law}.npz"


def load_curve(path: Path) -> Any:
    """The :class:`~jamlab.spheres.packing.CoordinationCurve` stored in ``path``
    (``ValueError`` naming the file if it is not one: written by something else, or damaged)."""
    from jamlab.spheres.packing import CoordinationCurve

    try:
        with np.load(path) as z:
            d = {k: z[k] for k in z.files}
        return CoordinationCurve(phi_j=float(d.pop("phi_j")), dim=int(d.pop("dim")),
                                 n=int(d.pop("n")), **{k: v for k, v in d.items()})
    except (OSError, EOFError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as exc:
        raise ValueError(f"unreadable cached coordination curve {path} ({type(exc).__name__}: "
                         f"{exc}); remove it to compute the curve again") from None


def save_curve(path: Path, curve: Any) -> None:
    """Store ``curve`` in ``path`` (atomically: temporary file, then rename)."""
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, phi_j=curve.phi_j, dim=curve.dim, n=curve.n,
             **{k: getattr(curve, k) for k in CURVE_ARRAYS})
    os.replace(tmp, path)
