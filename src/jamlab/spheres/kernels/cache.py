"""Dropping numba caches that numba itself would keep although they are stale.

numba keys a cached kernel on the timestamp and size of *its own* source file only ("Cache
invalidation" in numba's documentation): a kernel that calls a kernel of another file — FIRE's
loop calls the pair sums of ``pairs.py``, which inline the pair law of
:mod:`jamlab.spheres.pair` — keeps its old machine code when only the other file changes. In an
editable install (the README's) a ``git pull`` that touches ``pairs.py`` alone would leave FIRE
running the old pair sums: a different result, with nothing to say so. (It was seen in this
project as a 2–3 % slower FIRE after a change to ``pairs.py`` alone, a harmless case.)

So the package's cache directory holds a marker, :data:`MARKER`, with the fingerprint of all
its sources (name, modification time and size of the package's modules and of
``spheres/pair.py``, as numba fingerprints one file). On its first import (this module's, which
:mod:`jamlab.spheres.kernels` imports before any kernel module), when the marker is missing or
differs, every cached kernel of the package is removed and the marker rewritten: the kernels
recompile on first use, or in ``jamlab warmup``. Equality, not age, decides (as in numba), so
clock skew cannot make it drop the caches on every run. A file system that refuses the removal
leaves the caches to numba.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["DROPPED", "MARKER", "drop_stale", "fingerprint", "kernel_cache_dir", "kernel_sources"]

_HERE = Path(__file__).resolve().parent
MARKER = "jamlab-kernel-sources.txt"


def kernel_sources() -> list[Path]:
    """The files whose compiled code the package's kernels contain."""
    return [*sorted(_HERE.glob("*.py")), _HERE.parent / "pair.py"]


def fingerprint(sources: list[Path]) -> str:
    """One line per source: name, ``st_mtime_ns``, size."""
    lines = []
    for p in sources:
        st = p.stat()
        lines.append(f"{p.name} {st.st_mtime_ns} {st.st_size}")
    return "\n".join(lines) + "\n"


def kernel_cache_dir() -> Path | None:
    """Where numba keeps this package's cached kernels (``__pycache__`` beside the sources, or
    under ``NUMBA_CACHE_DIR``), as numba's own locators find it; ``None`` when it has none, or
    when this numba does not expose its locators as 0.59–0.68 do (then the caches are left to
    numba: a failed import of the kernels would be worse)."""
    try:
        from numba.core.caching import CacheImpl

        locators = CacheImpl._locator_classes
    except (ImportError, AttributeError):
        return None
    for locator in locators:
        found = locator.from_function(kernel_cache_dir, str(_HERE / "pairs.py"))
        if found is not None:
            return Path(found.get_cache_path())
    return None


def drop_stale(cache_dir: Path | None, sources: list[Path]) -> int:
    """If ``cache_dir``'s marker is not the fingerprint of ``sources``, remove every numba cache
    file (``*.nbi``, ``*.nbc``) there and write the marker; the number of files removed (0 when
    the marker matches, or on an ``OSError``: a read-only or vanished cache is left to numba)."""
    if cache_dir is None:
        return 0
    try:
        current = fingerprint(sources)
        marker = cache_dir / MARKER
        if marker.is_file() and marker.read_text() == current:
            return 0
        files = [f for f in cache_dir.iterdir() if f.suffix in (".nbi", ".nbc")]
        for f in files:
            f.unlink(missing_ok=True)
        tmp = cache_dir / f"{MARKER}.{os.getpid()}.tmp"
        tmp.write_text(current)
        tmp.replace(marker)
    except OSError:
        return 0
    return len(files)


DROPPED = drop_stale(kernel_cache_dir(), kernel_sources())
"""Cache files this process removed on import (0 normally)."""
