"""Where a computation ran: the machine and the software a result's bits depend on.

The same code and inputs give the same bits on the same machine and libraries, and in general
not across machines (measured: the same fixed-pressure study at p = 1e-6, N = 500 on two CPUs
parts after its first jumps; docs/runs.md, "Bit for bit, per machine"). The parts that choose
their code per CPU: numba compiles for the host CPU (LLVM's name for it), numpy dispatches its
loops by the SIMD extensions it finds, OpenBLAS and CHOLMOD (through cvxopt) pick kernels per CPU,
and the C library supplies ``exp`` and ``log``. Measured (``scripts/machine_bits_probe.py``): on
one machine, numpy without its AVX-512 loops, numba compiled for another CPU and BLAS on all cores
gave the same bits; OpenBLAS's kernels (``OPENBLAS_CORETYPE``) did not — hence ``blas_cores``,
the kernels every loaded BLAS runs (``jamlab.spheres.blas``).

:func:`machine` records these (cached per process), with jamlab's version and the git commit of
its source tree (``+dirty`` when ``src/jamlab`` differs from it; empty outside a checkout).
:func:`machine_key` is the part two computations must share to be expected to agree bit for bit
(the host name and the commit are not in it: a commit that changes no physics keeps the bits,
and one that does is a code change, not a machine's). :func:`segment` is one invocation's record,
``{"resumed_from": k, "host": ..., **machine()}``: ``k = -1`` for an invocation that started
afresh, else the saved step it resumed from; :func:`continued` appends it to the records of the
earlier invocations. A run sample's ``provenance`` attribute, and an AQS trace's, is the JSON
list of its invocations' records (``jamlab.runs``, ``jamlab.spheres.aqs``).
"""

from __future__ import annotations

import functools
import importlib.metadata
import json
import platform
import subprocess
from pathlib import Path
from typing import Any

__all__ = ["KEY_FIELDS", "UNRECORDED", "commit", "continued", "differ", "here", "machine",
           "machine_key", "provenance_json", "segment", "source_digest", "summary_text"]

KEY_FIELDS = ("cpu", "llvm_cpu", "numpy_simd", "blas", "blas_cores", "libc", "python", "numpy",
              "scipy", "numba", "llvmlite", "cvxopt")
"""The fields of :func:`machine` that decide the bits (everything but jamlab's commit)."""

UNRECORDED = {"resumed_from": -1, "recorded": False}
"""The first record of a computation resumed from a save written before invocations were
recorded: the invocations before are not known."""

_LIBRARIES = ("numpy", "scipy", "numba", "llvmlite", "cvxopt", "h5py")


@functools.cache
def source_digest(patterns: tuple[str, ...]) -> bytes:
    """SHA-256 of the ``jamlab`` package's source files matching ``patterns`` (globs relative to
    the package, e.g. ``"theory/*.py"``): each file's relative path and bytes, in pattern order
    and sorted within a pattern. The key of a result stored for the code that computed it
    (``jamlab.reproduce.cache``; ``jamlab.summary`` computes the same digest with its own copy of
    these lines, kept so: any edit of ``summary.py`` changes the key of every summary already
    stored in a file, and ``inspect`` then recomputes them, 0.9 s instead of 0.3 s)."""
    import hashlib

    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for pattern in patterns:
        for path in sorted(root.glob(pattern)):
            h.update(path.relative_to(root).as_posix().encode())
            h.update(path.read_bytes())
    return h.digest()


def _cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``; ``platform.processor()`` elsewhere)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return ""


def _numpy_build() -> tuple[str, str]:
    """(SIMD extensions numpy found on this CPU, its BLAS's name and version)."""
    import numpy as np

    try:
        config = np.show_config(mode="dicts")
    except (TypeError, ValueError):  # an old numpy without the dict form
        return "", ""
    simd = ",".join(config.get("SIMD Extensions", {}).get("found", []) or [])
    blas = config.get("Build Dependencies", {}).get("blas", {})
    return simd, " ".join(str(blas.get(k, "")) for k in ("name", "version")).strip()


def _llvm_cpu() -> str:
    """The CPU numba compiles for: ``NUMBA_CPU_NAME`` when set, else LLVM's host CPU."""
    import numba
    from llvmlite import binding

    return numba.config.CPU_NAME or binding.get_host_cpu_name()


@functools.cache
def commit() -> str:
    """The git commit of the imported jamlab's source tree, with ``+dirty`` when the package's
    files differ from it; ``""`` when the package is not in a git checkout or git is missing."""
    package = Path(__file__).resolve().parent

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(package), *args], capture_output=True,
                              text=True, timeout=10, check=False)

    try:
        head = git("rev-parse", "HEAD")
        if head.returncode != 0:
            return ""
        dirty = git("diff", "--quiet", "HEAD", "--", ".").returncode != 0
    except (OSError, subprocess.SubprocessError):
        return ""
    return head.stdout.strip() + ("+dirty" if dirty else "")


def _blas_cores() -> str:
    """Every BLAS loaded once CHOLMOD (``jamlab.spheres.blas``) and scipy's linear algebra are:
    library, version and the kernels (OpenBLAS's core) it runs, sorted. scipy's is loaded here so
    that the list is the same in every process, whatever it imported before (with
    ``JAMLAB_CHOLMOD_BLAS=native`` a process that had not used scipy yet listed one BLAS less)."""
    import scipy.linalg  # noqa: F401 - scipy's OpenBLAS

    from jamlab.spheres import blas

    blas.import_cvxopt()
    return "; ".join(sorted(f"{lib['prefix']} {lib['version']} {lib['architecture']}".strip()
                            for lib in blas.cores()))


@functools.cache
def _machine() -> tuple[tuple[str, str], ...]:
    from jamlab import __version__

    simd, blas = _numpy_build()
    record = {
        "cpu": _cpu_model(),
        "llvm_cpu": _llvm_cpu(),
        "numpy_simd": simd,
        "blas": blas,
        "blas_cores": _blas_cores(),
        "libc": " ".join(platform.libc_ver()).strip(),
        "os": platform.platform(),
        "python": platform.python_version(),
        **{name: _version(name) for name in _LIBRARIES},
        "jamlab": __version__,
        "jamlab_commit": commit(),
    }
    return tuple(record.items())


def machine() -> dict[str, str]:
    """This process's machine and software (module docstring); computed once per process."""
    return dict(_machine())


def machine_key(record: dict[str, Any]) -> str:
    """The fields of ``record`` that decide the bits (:data:`KEY_FIELDS`), as one string: two
    records with the same key are the same machine and libraries."""
    return "|".join(f"{name}={record.get(name, '')}" for name in KEY_FIELDS)


def differ(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two records are known to be different machines: a field of :data:`KEY_FIELDS`
    that both hold differs. A field one of them lacks (a record written before jamlab recorded
    it, e.g. ``blas_cores``) is unknown, not a difference."""
    return any(a[name] != b[name] for name in KEY_FIELDS if name in a and name in b)


def here() -> dict[str, Any]:
    """This process's host and :func:`machine`."""
    return {"host": platform.node(), **machine()}


def segment(resumed_from: int = -1) -> dict[str, Any]:
    """One invocation's record: the step it resumed from (``-1``: started afresh), the host and
    :func:`machine`."""
    return {"resumed_from": int(resumed_from), **here()}


def provenance_json() -> str:
    """The ``provenance`` attribute (JSON) of a file one invocation computed afresh (a packing
    of ``jamlab prepare`` or ``jamlab minimize``): ``[segment(-1)]``."""
    return json.dumps([segment(-1)])


def continued(earlier: Any, resumed_from: int) -> list[dict[str, Any]]:
    """The records of a computation after this invocation: none before it when it starts
    afresh (``resumed_from = -1``), else the earlier invocations' (``earlier``: their list or its
    JSON text; ``[UNRECORDED]`` when missing or unreadable), then this invocation's
    :func:`segment`."""
    records: list[dict[str, Any]] = []
    if resumed_from >= 0:
        if isinstance(earlier, bytes | str):
            try:
                earlier = json.loads(earlier)
            except ValueError:
                earlier = None
        ok = isinstance(earlier, list) and all(isinstance(r, dict) for r in earlier)
        records = list(earlier) if ok and earlier else [dict(UNRECORDED)]
    return records + [segment(resumed_from)]


def summary_text(record: dict[str, Any]) -> str:
    """A one-line description of a record for people: CPU, LLVM's CPU, the libraries, commit."""
    libs = ", ".join(f"{name} {record.get(name, '?')}" for name in ("numpy", "scipy", "numba",
                                                                     "cvxopt"))
    code = str(record.get("jamlab_commit", ""))
    code = (code[:12] + ("+dirty" if code.endswith("+dirty") else "")) if code else "no commit"
    if "blas_cores" not in record:
        libs += "; BLAS kernels not recorded"
    return (f"{record.get('cpu', '?')} ({record.get('llvm_cpu', '?')}; "
            f"{record.get('numpy_simd', '?') or 'no SIMD list'}); {libs}; "
            f"BLAS {record.get('blas_cores') or record.get('blas') or 'unknown'}; jamlab {code}")
