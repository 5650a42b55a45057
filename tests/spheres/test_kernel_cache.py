"""Stale numba caches are dropped (:mod:`jamlab.spheres.kernels.cache`): numba keys a cached
kernel on its own file only, so a change to a file it inlines (``spheres/pair.py``) must clear it.

The end-to-end test runs a copy of the package in fresh processes with a private cache
(``NUMBA_CACHE_DIR``): a kernel compiled once loads from the cache the next time (the control),
and compiles again once ``pair.py``, which it inlines but numba does not track, is newer."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from jamlab.spheres.kernels.cache import (
    MARKER,
    drop_stale,
    fingerprint,
    kernel_cache_dir,
    kernel_sources,
)


def _files(where: Path, names: list[str]) -> list[Path]:
    out = []
    for name in names:
        p = where / name
        p.write_text("x")
        out.append(p)
    return out


def test_drop_stale_removes_the_caches_when_a_source_changes(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    sources = _files(tmp_path, ["pairs.py", "pair.py"])
    # no marker yet (caches of unknown sources): dropped, marker written
    kernels = _files(cache, ["fire.fire-30.py311.nbi", "fire.fire-30.py311.1.nbc"])
    other = _files(cache, ["pairs.cpython-311.pyc"])
    assert drop_stale(cache, sources) == 2
    assert not any(p.exists() for p in kernels) and all(p.exists() for p in other)
    assert (cache / MARKER).read_text() == fingerprint(sources)
    # the same sources: kept
    kernels = _files(cache, ["fire.fire-30.py311.nbi", "pairs.energy-28.py311.nbi"])
    assert drop_stale(cache, sources) == 0 and all(p.exists() for p in kernels)
    # one source touched (a later time, even one in the future), or resized: dropped
    later = time.time() + 3600
    os.utime(sources[1], (later, later))
    assert drop_stale(cache, sources) == 2
    kernels = _files(cache, ["fire.fire-30.py311.nbi"])
    assert drop_stale(cache, sources) == 0  # and then stable: no drop on every run
    sources[0].write_text("xy")
    assert drop_stale(cache, sources) == 1


def test_drop_stale_leaves_what_it_cannot_read(tmp_path):
    sources = _files(tmp_path, ["pairs.py"])
    assert drop_stale(None, sources) == 0
    assert drop_stale(tmp_path / "missing", sources) == 0  # an OSError: left to numba


def test_the_sources_include_the_inlined_pair_law():
    names = {p.name for p in kernel_sources()}
    assert {"pairs.py", "fire.py", "aqs.py", "geometry.py", "pair.py"} <= names


CHILD = """
import sys
from jamlab.spheres.kernels import cache
from jamlab.warmup import count_compilations
import numpy as np
from jamlab.spheres import kernels as K
pos = np.array([[0.0, 0.0, 0.0], [0.9, 0.0, 0.0]])
start = np.array([0, 1, 1]); nbr = np.array([1]); shift = np.zeros((1, 3))
n = count_compilations(lambda: K.energy(pos, start, nbr, shift, None, None))
print(cache.DROPPED, n, cache.kernel_cache_dir())
"""


def _child(src: Path, cache: Path) -> tuple[int, int, str]:
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
    proc = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                          text=True, cwd=src)
    assert proc.returncode == 0, proc.stderr
    dropped, compiled, where = proc.stdout.split()
    return int(dropped), int(compiled), where


def test_a_change_to_an_inlined_file_recompiles_the_kernel(tmp_path):
    import jamlab

    src = tmp_path / "src"
    shutil.copytree(Path(jamlab.__file__).parent, src / "jamlab",
                    ignore=shutil.ignore_patterns("__pycache__"))
    cache = tmp_path / "cache"
    assert _child(src, cache)[1] >= 1  # a fresh cache: compiles
    dropped, compiled, where = _child(src, cache)
    assert (dropped, compiled) == (0, 0)  # the control: loaded from the cache
    assert Path(where).is_relative_to(cache)  # numba's locator under NUMBA_CACHE_DIR
    pair = src / "jamlab" / "spheres" / "pair.py"
    later = time.time() + 10
    os.utime(pair, (later, later))  # numba does not track pair.py for pairs.energy
    dropped, compiled, _ = _child(src, cache)
    assert dropped >= 2 and compiled >= 1


def test_the_installed_package_locates_its_cache():
    assert kernel_cache_dir() is not None
