"""Atomic file writes shared by every writer in jamlab (packings, traces, run directories).

A file is written under a temporary name in its final directory, fsync'ed, renamed over the
destination with ``os.replace`` (atomic on POSIX) and the directory is fsync'ed: a reader sees
either no file or a whole one, and an interrupted write leaves at most a ``.NAME.XXXX.tmp`` file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = ["atomic_write", "fsync_dir"]


def fsync_dir(directory: str | os.PathLike) -> None:
    """fsync a directory so that a rename inside it survives a crash."""
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def atomic_write(
    path: str | os.PathLike, write: Callable[[str], None], *, make_parents: bool = False
) -> Path:
    """Call ``write(tmp_path)``, then fsync it and rename it over ``path``; return ``path``.

    Without ``make_parents`` a missing destination directory is a ``FileNotFoundError``.
    """
    path = Path(path)
    directory = path.parent
    if make_parents:
        directory.mkdir(parents=True, exist_ok=True)
    elif not directory.is_dir():
        raise FileNotFoundError(f"output directory does not exist: {directory}")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise
    fsync_dir(directory)
    return path
