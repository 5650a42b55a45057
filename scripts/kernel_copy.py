"""A probe's copy of the compiled FIRE loop, made at run time from the kernel's own source.

A probe that needs FIRE with something added (counters, a line search) edits the text of
``jamlab/spheres/kernels/fire.py`` rather than keeping a hand copy of the loop: the copy *is* the
kernel (fused kick, branch-free forces, every later change), plus the probe's lines. Each edit
``(old, new)`` must match the kernel's text exactly once, or the copy fails loudly. ``extra``
names compiled functions the edits call (numba resolves a kernel's globals when it is first
compiled, so they are set before the first call). The copy is compiled without numba's cache.
"""

from __future__ import annotations

import importlib.util
import sys
import tempfile
from pathlib import Path

import jamlab.spheres.kernels as K

KERNEL = Path(K.__file__).resolve().parent / "fire.py"


def edited_fire(name: str, edits: list[tuple[str, str]], extra: dict | None = None):
    """The kernel's ``fire`` with ``edits`` applied, as module ``name`` (module docstring)."""
    text = KERNEL.read_text()
    text = text.replace("@njit(cache=True)", "@njit(cache=False)")  # every kernel of the copy
    for old, new in edits:
        if text.count(old) != 1:
            raise SystemExit(f"{name}: the FIRE kernel changed; cannot place {old!r}")
        text = text.replace(old, new)
    path = Path(tempfile.mkdtemp()) / f"{name}.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    for key, value in (extra or {}).items():
        setattr(module, key, value)
    return module.fire
