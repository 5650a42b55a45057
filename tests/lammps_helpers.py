"""The benchmarks' LAMMPS helpers, for the LAMMPS-marked tests (LAMMPS is never a dependency).

``benchmark_module(name)`` loads ``benchmarks/<name>.py`` by path (the benchmarks are scripts,
not a package); ``LMP`` is ``(lmp, environment)`` from ``benchmarks/_lammps.py``'s
``find_lammps`` or ``None``; ``LAMMPS_MARKS`` is the ``pytestmark`` of a test module that needs it.
"""

from __future__ import annotations

import sys
from pathlib import Path
from types import ModuleType

import pytest

from script_helpers import load_by_path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def benchmark_module(name: str) -> ModuleType | None:
    """``benchmarks/<name>.py`` as a module (None if it is not there), loaded once."""
    path = BENCHMARKS / f"{name}.py"
    if not path.is_file():
        return None
    if str(BENCHMARKS) not in sys.path:  # the benchmarks import ``_lammps`` by name
        sys.path.insert(0, str(BENCHMARKS))
    key = f"jamlab_benchmarks_{name}"
    return load_by_path(path, key)


_helpers = benchmark_module("_lammps")
LMP = _helpers.find_lammps() if _helpers else None
LAMMPS_MARKS = [
    pytest.mark.lammps,
    pytest.mark.skipif(LMP is None, reason="LAMMPS not installed (LAMMPS_BIN, /tmp/lmpvenv)"),
]
