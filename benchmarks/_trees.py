"""Run code against another source tree of jamlab, in a child process (shared by the benchmarks).

A before/after benchmark times two versions of the code in one run, side by side: each in its own
Python process whose ``PYTHONPATH`` is that tree's ``src``. The child gets one BLAS, OpenMP and
numba thread, so that its CPU time measures the work and not threads spinning (and so that the
supernodal factorisations round the same way every time: traces compare bit for bit).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

SINGLE_THREAD = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}
"""The environment of every child: one thread of each threading library."""


def run_in_tree(src: str | Path, code: str, args: Sequence[object] = (), *, text: bool = True):
    """Run ``python -c code args…`` (each argument as ``str``) with ``src`` (resolved) on
    ``PYTHONPATH``.

    Returns the child's stdout (``str``, or ``bytes`` with ``text=False``); a child that fails
    has its stderr printed and raises :class:`subprocess.CalledProcessError`.
    """
    env = dict(os.environ, PYTHONPATH=str(Path(src).resolve()), **SINGLE_THREAD)
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], env=env,
                         capture_output=True, text=text)
    if out.returncode != 0:
        err = out.stderr if text else out.stderr.decode(errors="replace")
        print(f"child in {src} failed:\n{err}", file=sys.stderr)  # (the traceback hides it)
        raise subprocess.CalledProcessError(out.returncode, f"child in {src}", out.stdout, err)
    return out.stdout
