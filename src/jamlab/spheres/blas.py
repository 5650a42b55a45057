"""The BLAS under CHOLMOD: cvxopt's bundled OpenBLAS, run with the kernels numpy's OpenBLAS chose.

CHOLMOD (SuiteSparse, through ``cvxopt``) does its supernodal Cholesky in dense BLAS blocks, with
the OpenBLAS that the cvxopt wheel bundles (0.3.15 for cvxopt 1.3.3). That OpenBLAS chooses its
kernels for the CPU when it is loaded, and a CPU newer than it falls back to generic ones:
on the Intel Xeon (Emerald Rapids, AVX-512) of 2026-11-30 it runs ``Prescott`` (SSE3) kernels,
while numpy's and scipy's OpenBLAS (0.3.30–0.3.31) run ``SkylakeX`` (measured with
``threadpoolctl``). There a factorisation of a backbone Hessian at N = 1000 took 1.6× as long as
with the ``SkylakeX`` kernels (``benchmarks/bench_blas_core.py``, docs/aqs.md).

:func:`import_cvxopt` therefore loads cvxopt with ``OPENBLAS_CORETYPE`` set, for the time of the
import only, to the core numpy's OpenBLAS chose — a newer OpenBLAS that knows the CPU (mapped to a
name the older one knows: :data:`OLDER_NAMES`; a core it would not know, e.g. on ARM, is not
set: :data:`KNOWN_CORES`). Where the bundled OpenBLAS knew the CPU already it
chooses the same core and nothing changes; where it fell back, its factorisations get the
kernels the CPU has. numpy's and scipy's own OpenBLAS are not touched (numpy's is loaded before,
scipy's is made to load before). The kernels change the rounding, so results on such a machine
differ in the last bits from those made before (where FIRE carries an avalanche, trajectories
part): every file records the cores in use (``jamlab.provenance``, field ``blas_cores``).

``JAMLAB_CHOLMOD_BLAS`` chooses: ``aligned`` (default, the above) or ``native`` (cvxopt's OpenBLAS
chooses alone: the results of the code before, bit for bit). A user's own ``OPENBLAS_CORETYPE`` is
always respected (nothing is set). Anything else is an error (the command line checks it first).
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["ENV", "KNOWN_CORES", "MODES", "OLDER_NAMES", "choice", "cores", "environment_mode",
           "import_cvxopt", "numpy_core"]

ENV = "JAMLAB_CHOLMOD_BLAS"
MODES = ("aligned", "native")
CORETYPE = "OPENBLAS_CORETYPE"

OLDER_NAMES = {"SapphireRapids": "Cooperlake"}
"""Cores of a newer OpenBLAS that the bundled one (0.3.15) does not know, and the nearest it
does (the same AVX-512 kernels for double precision)."""

KNOWN_CORES = frozenset(name.lower() for name in (
    "Prescott", "Atom", "Core2", "Penryn", "Dunnington", "Nehalem", "Opteron", "Opteron_SSE3",
    "Barcelona", "Nano", "Sandybridge", "Bobcat", "Bulldozer", "Piledriver", "Haswell",
    "Steamroller", "Excavator", "Zen", "SkylakeX", "Cooperlake"))
"""The x86-64 cores OpenBLAS 0.3.15 can be told (``OPENBLAS_CORETYPE``; it compares without
case). Any other name is not set: an OpenBLAS told a core it does not know falls back to a
generic one, which could be worse than its own choice."""

_CHOICE: dict[str, Any] = {}


def environment_mode() -> str:
    """``JAMLAB_CHOLMOD_BLAS`` (default ``aligned``), checked: ``ValueError`` for anything but
    :data:`MODES`."""
    mode = os.environ.get(ENV, "aligned").strip().lower() or "aligned"
    if mode not in MODES:
        raise ValueError(f"{ENV} must be 'aligned' or 'native', got {mode!r}")
    return mode


def cores() -> list[dict[str, Any]]:
    """Every BLAS loaded in this process (``threadpoolctl``): ``prefix`` (the library's file
    name's start), ``version``, ``architecture`` (OpenBLAS's core; MKL and others: ``""``),
    ``filepath``."""
    from threadpoolctl import threadpool_info

    return [{"prefix": str(info.get("prefix", "")), "version": str(info.get("version", "")),
             "architecture": str(info.get("architecture") or ""),
             "filepath": str(info.get("filepath", ""))}
            for info in threadpool_info() if info.get("user_api") == "blas"]


def _version_key(version: str) -> tuple[int, ...]:
    parts = []
    for part in version.split("."):
        digits = "".join(ch for ch in part if ch.isdigit())
        parts.append(int(digits) if digits else 0)
    return tuple(parts)


def numpy_core() -> str | None:
    """The core chosen for this CPU by the newest OpenBLAS loaded other than cvxopt's (numpy's,
    or scipy's: with wheels, numpy's is always loaded); ``None`` when there is none."""
    import numpy.linalg  # noqa: F401 - loads numpy's BLAS

    found = [lib for lib in cores() if lib["architecture"] and "cvxopt" not in lib["filepath"]]
    if not found:
        return None
    return max(found, key=lambda lib: _version_key(lib["version"]))["architecture"]


def choice() -> dict[str, Any]:
    """What :func:`import_cvxopt` did: ``mode``, ``coretype`` (the value set for the import,
    ``None`` when nothing was set) and ``reason``."""
    return dict(_CHOICE)


def import_cvxopt() -> Any:
    """``cvxopt`` with ``cvxopt.cholmod`` loaded (module docstring: the core its OpenBLAS runs).
    Once per process; later calls return the module already loaded."""
    import sys

    if "cvxopt" in sys.modules and _CHOICE:
        return sys.modules["cvxopt"]
    mode = environment_mode()
    coretype, reason = None, ""
    if "cvxopt" in sys.modules:
        reason = "cvxopt was loaded before jamlab could choose: its OpenBLAS chose alone"
    elif mode == "native":
        reason = f"{ENV}=native"
    elif os.environ.get(CORETYPE):
        reason = f"the user's {CORETYPE}={os.environ[CORETYPE]}"
    else:
        import scipy.linalg  # noqa: F401 - scipy's OpenBLAS loads now, not under the variable

        core = numpy_core()
        if core is None:
            reason = "numpy's BLAS names no OpenBLAS core"
        elif OLDER_NAMES.get(core, core).lower() not in KNOWN_CORES:
            reason = f"numpy's OpenBLAS runs {core}, a core cvxopt's may not know: left alone"
        else:
            coretype = OLDER_NAMES.get(core, core)
            reason = f"numpy's OpenBLAS runs {core}"
    if coretype is not None:
        os.environ[CORETYPE] = coretype
    try:
        import cvxopt
        import cvxopt.cholmod  # noqa: F401
    finally:
        if coretype is not None:
            del os.environ[CORETYPE]
    _CHOICE.update(mode=mode, coretype=coretype, reason=reason)
    return cvxopt
