"""The caches of ``jamlab reproduce`` (in ``OUT/data``): coordination curves and the exact law.

A resumed reproduction (or ``jamlab figure fig1``) must not redo the compression of its packings,
so each :class:`jamlab.spheres.packing.CoordinationCurve` is stored as
``coordination_N{n}_seed{seed}_steps{steps}.npz`` (the name is the key: the packing's size, seed
and number of compression steps) with one array per field.

Nor must it rebuild the exact jump law (:func:`jamlab.reproduce.theory_checks.exact_law_checks`,
~20 s at every scale: it depends on no run). Its exponent checks and Fig. 3 tables are stored as
``exact_law_{key}.npz``, the key a SHA-256 of the code that computes them (``jamlab/theory``,
``plots/theory.py``, ``reproduce/theory_checks.py``, which holds its parameters, ``paper.py``,
which holds θ and so μ_J) and of the numpy and scipy versions: other code or libraries compute
afresh, and an entry is never read for a computation it does not describe.

A file is written under a temporary name and renamed, so an interrupted write never leaves a
truncated entry. Writing the exact law's entry removes the entries of other keys in the same
folder (they describe other code and would never be read again; without this, every upgrade left
one more file, ≈ 22 kB, behind); nothing else there is touched.
"""

from __future__ import annotations

import hashlib
import os
import re
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CURVE_ARRAYS", "EXACT_LAW_CODE", "cache_file", "exact_law_file", "load_curve",
           "load_exact_law", "save_curve", "save_exact_law"]

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


EXACT_LAW_CODE = ("theory/*.py", "plots/theory.py", "reproduce/theory_checks.py", "paper.py")
"""The sources (relative to the ``jamlab`` package) whose text keys the exact-law cache."""


def _exact_law_key() -> str:
    import scipy

    from jamlab.provenance import source_digest

    h = hashlib.sha256(f"numpy {np.__version__} scipy {scipy.__version__}\n".encode())
    h.update(source_digest(EXACT_LAW_CODE))
    return h.hexdigest()


def exact_law_file(cache: Path) -> Path:
    """The file of the exact law's checks and tables for this code (module docstring)."""
    return Path(cache) / f"exact_law_{_exact_law_key()[:20]}.npz"


def save_exact_law(path: Path, checks: tuple[Any, ...], tables: dict) -> None:
    """Store the result of ``exact_law_checks`` (``checks``: ``ExponentCheck`` instances;
    ``tables``: ``{μ: {δγ: {name: array}}}``) in ``path``, atomically; the floats of the keys are
    kept exactly (``repr``)."""
    from dataclasses import astuple, fields

    from jamlab.reproduce.theory_checks import ExponentCheck

    arrays: dict[str, np.ndarray] = {}
    for i, check in enumerate(checks):
        arrays[f"check|{i}"] = np.array(astuple(check), dtype=np.float64)
    arrays["check_fields"] = np.array([f.name for f in fields(ExponentCheck)])
    for mu, per_dg in tables.items():
        for dg, table in per_dg.items():
            for name, value in table.items():
                arrays[f"table|{float(mu)!r}|{float(dg)!r}|{name}"] = np.asarray(value)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)
    for stale in path.parent.glob("exact_law_*.npz"):
        if stale != path and re.fullmatch(r"exact_law_[0-9a-f]{20}\.npz", stale.name):
            stale.unlink(missing_ok=True)  # another code's entry (module docstring)


def load_exact_law(path: Path) -> tuple[tuple[Any, ...], dict]:
    """``(checks, tables)`` as :func:`save_exact_law` stored them, in their order (``ValueError``
    naming the file if it is not such an entry)."""
    from jamlab.reproduce.theory_checks import ExponentCheck

    try:
        with np.load(path) as z:
            names = [str(v) for v in z["check_fields"]]
            checks = tuple(ExponentCheck(**dict(zip(names, map(float, z[k]), strict=True)))
                           for k in z.files if k.startswith("check|"))
            tables: dict = {}
            for k in z.files:
                if k.startswith("table|"):
                    _, mu, dg, name = k.split("|", 3)
                    tables.setdefault(float(mu), {}).setdefault(float(dg), {})[name] = z[k]
        return checks, tables
    except (OSError, EOFError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as exc:
        raise ValueError(f"unreadable cached exact law {path} ({type(exc).__name__}: {exc}); "
                         "remove it to compute the law again") from None
