"""Output files: the one guard every command applies to its output paths, and the atomic writes
shared by every writer in jamlab (packings, traces, run directories).

:func:`check_outputs` refuses, before any computation, an output path that is an existing
directory, sits in a missing or unwritable directory, or is the same file as an input (also
through a symbolic or hard link) or as another output; and an input inside an output directory.
:func:`check_new_run_directory` refuses a run directory or report inside an existing run directory.

:func:`atomic_write` writes a file under a temporary name in its final directory, fsync's it,
renames it over the destination with ``os.replace`` (atomic on POSIX) and fsync's the directory:
a reader sees either no file or a whole one, and an interrupted write leaves at most a
``.NAME.XXXX.tmp`` file. The file gets the mode ``0o666 & ~umask`` (like ``open(path, "w")``),
not ``mkstemp``'s ``0o600``. :func:`atomic_write_hdf5` builds an HDF5 file in memory and writes its
bytes the same way, so that a full disk is an ``OSError`` (``ENOSPC``) from a plain ``write``,
never an error inside the HDF5 library. :func:`atomic_write_text` and :func:`atomic_savefig` do
the same for text (reports, CSV) and matplotlib figures (drawn in the format of the suffix).
An ``OSError`` of a failed write names the destination, not the temporary file.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

__all__ = [
    "atomic_write",
    "atomic_write_bytes",
    "atomic_write_hdf5",
    "atomic_write_text",
    "atomic_savefig",
    "check_distinct_inputs",
    "check_links",
    "check_new_run_directory",
    "check_outputs",
    "open_hdf5",
    "fsync_dir",
    "OTHER_FORMAT_SUFFIXES",
    "RUN_FORMAT",
    "RUN_MEMBERS",
    "run_directory_of",
]

PathLike = str | os.PathLike


def fsync_dir(directory: PathLike) -> None:
    """fsync a directory so that a rename inside it survives a crash."""
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _identity(path: Path) -> tuple[Any, ...]:
    """What makes two paths the same file: (device, inode) if it exists, else the real path."""
    try:
        st = os.stat(path)
    except OSError:
        return ("path", os.path.realpath(path))
    return ("inode", st.st_dev, st.st_ino)


def _inside(path: Path, directory: Path) -> bool:
    real, root = os.path.realpath(path), os.path.realpath(directory)
    return real == root or real.startswith(root.rstrip(os.sep) + os.sep)


RUN_FORMAT = "jamlab-run"
"""The ``format`` of a run directory's manifest (:mod:`jamlab.runs.storage` takes it from here)."""

RUN_MEMBERS = ("manifest.json", "run.lock", "samples", "checkpoints")
"""The entries of a jamlab run directory that only ``jamlab run`` writes: its manifest, its lock,
the sample and the checkpoint folders. :mod:`jamlab.runs.storage` takes its names from here (this
module must not import the run machinery: every command imports it)."""


def _spellings(path: PathLike) -> list[Path]:
    """``path`` as written (absolute) and with every symbolic link resolved: a guard checks both,
    so neither a symlinked directory nor one that is itself a link elsewhere slips through."""
    spelled, real = Path(os.path.abspath(path)), Path(os.path.realpath(path))
    return [spelled] if spelled == real else [spelled, real]


def run_directory_of(path: PathLike) -> Path | None:
    """The jamlab run directory (one holding a manifest) that ``path`` is a member of — an entry
    of :data:`RUN_MEMBERS` or a file below one — or ``None``; through any spelling of ``path``
    (symbolic links are resolved, and the path as written is checked too)."""
    for spelled in _spellings(path):
        for parent in spelled.parents:
            if (parent / RUN_MEMBERS[0]).is_file():
                if spelled.relative_to(parent).parts[0] in RUN_MEMBERS:
                    return parent
                break
    return None


def _is_run_directory(directory: Path) -> bool:
    try:
        manifest = json.loads((directory / RUN_MEMBERS[0]).read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(manifest, dict) and manifest.get("format") == RUN_FORMAT


def check_new_run_directory(name: str, path: PathLike, *, itself: bool = False) -> None:
    """``ValueError`` (one line) if the directory ``path`` lies inside an existing jamlab run
    directory (an ancestor with a jamlab run manifest), through any spelling of it; with
    ``itself`` also if ``path`` is one. ``jamlab run`` and ``jamlab reproduce`` make no run
    directory, report or anything else inside another run's directory."""
    for spelled in _spellings(path):
        for parent in (spelled, *spelled.parents) if itself else spelled.parents:
            if _is_run_directory(parent):
                where = "is" if parent == spelled else "lies in"
                raise ValueError(f"{name} {path} {where} the run directory {parent}; "
                                 "only that run's own jamlab run writes there")


def check_distinct_inputs(paths: list[PathLike], what: str = "input") -> None:
    """``ValueError`` (one line) if two of ``paths`` are the same file: the same path, or the
    same file through a symbolic or hard link (same device and inode)."""
    seen: dict[tuple[Any, ...], Path] = {}
    for path in map(Path, paths):
        ident = _identity(path)
        if ident in seen:
            same = "given twice" if seen[ident] == path else f"the same file as {seen[ident]}"
            raise ValueError(f"{what} {path} is {same}: each file may be given once")
        seen[ident] = path


OTHER_FORMAT_SUFFIXES = frozenset({
    ".xyz", ".extxyz", ".gsd", ".data", ".lmp", ".lammps", ".dump", ".lammpstrj", ".csv",
    ".json", ".npz", ".npy", ".txt", ".toml", ".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps",
    ".ps", ".tif", ".tiff", ".gif", ".webp", ".avif", ".pgf", ".raw", ".rgba", ".svgz",
})
"""Suffixes of formats that are not HDF5 (:func:`check_outputs`'s ``hdf5``): every exchange
format's (``spheres.exchange.SUFFIXES``), every figure format's matplotlib writes, and the
tables' (kept here as a list: this module imports neither; a test holds the two in it)."""


def check_outputs(
    outputs: Mapping[str, PathLike | None],
    inputs: Mapping[str, PathLike | None] | None = None,
    *,
    directories: Mapping[str, PathLike | None] | None = None,
    read_directories: Mapping[str, PathLike | None] | None = None,
    force: bool = False,
    continued: tuple[str, ...] = (),
    figures: tuple[str, ...] = (),
    hdf5: tuple[str, ...] = (),
) -> None:
    """The output-path guard of every command; raises ``ValueError`` (one line) before anything
    is computed or written.

    An output file that exists already is refused unless ``force`` (``--force``) or its
    description is in ``continued`` (a file the command continues, e.g. the trace of
    ``shear --resume``): no finished data is replaced by accident. A member of a jamlab run
    directory (:func:`run_directory_of`) is refused even with ``force``: only ``jamlab run``
    writes there. Outputs named in ``figures`` must have a suffix matplotlib can write (checked
    here, not after the computation); outputs named in ``hdf5`` (jamlab's HDF5 files) must not
    carry the suffix of another format (:data:`OTHER_FORMAT_SUFFIXES`: ``.xyz``, ``.gsd``,
    ``.png`` …), which ``jamlab export``/``import`` and every reader would take at its word.

    ``outputs``: ``{description: file to be written}``; ``inputs``: ``{description: file that is
    read}`` (one that does not exist yet is refused as an output too: its reader would take a file
    written there for it); ``directories``: ``{description: directory that will be written
    into}`` (an input inside it is refused); ``read_directories``: ``{description: directory
    whose files are read}`` (an output inside it is refused, even with ``force``: a new file there
    would be read or removed with them). ``None`` values are skipped. Descriptions appear in the
    message, e.g. ``{"--out": path}``.
    """
    inputs = {k: Path(v) for k, v in (inputs or {}).items() if v is not None}
    files = {k: Path(v) for k, v in outputs.items() if v is not None}
    dirs = {k: Path(v) for k, v in (directories or {}).items() if v is not None}
    read_dirs = {k: Path(v) for k, v in (read_directories or {}).items() if v is not None}
    seen: dict[tuple[Any, ...], str] = {}
    for name, path in files.items():
        if path.is_dir():
            raise ValueError(f"{name} {path} is an existing directory, not a file")
        parent = path.parent
        if not parent.is_dir():
            raise ValueError(f"{name} {path}: output directory does not exist: {parent}")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise ValueError(f"{name} {path}: output directory is not writable: {parent}")
        ident = _identity(path)
        for in_name, in_path in inputs.items():
            if _identity(in_path) == ident:
                if not os.path.lexists(in_path):  # a file the input's reader looks for
                    raise ValueError(f"{name} {path} is the {in_name} {in_path} (absent now, "
                                     "read as input once it exists); write it elsewhere")
                raise ValueError(
                    f"{name} {path} is the same file as the {in_name} {in_path}; "
                    "writing it would destroy the input"
                )
        for in_name, directory in read_dirs.items():
            if _inside(path, directory):
                raise ValueError(f"{name} {path} lies in the {in_name} {directory}, which is "
                                 "read as input; write it elsewhere")
        if ident in seen:
            raise ValueError(f"{name} {path} is the same file as {seen[ident]}")
        seen[ident] = f"{name} {path}"
        run = run_directory_of(path)
        if run is not None:
            raise ValueError(f"{name} {path} is a file of the run directory {run}; "
                             "only jamlab run writes there")
        if path.exists() and not (force or name in continued):
            raise ValueError(f"{name} {path} exists; give --force to replace it")
        if name in hdf5 and path.suffix.lower() in OTHER_FORMAT_SUFFIXES:
            raise ValueError(f"{name} {path}: this writes an HDF5 file, and {path.suffix} names "
                             "another format; give a .h5 name (jamlab export writes the others)")
        if name in figures:
            from matplotlib.backend_bases import FigureCanvasBase

            kinds = FigureCanvasBase.get_supported_filetypes()
            if path.suffix.lower().lstrip(".") not in kinds:
                raise ValueError(f"{name} {path}: a figure needs one of the suffixes "
                                 f"{', '.join('.' + k for k in sorted(kinds))}")
    for name, directory in dirs.items():
        if directory.exists() and not directory.is_dir():
            raise ValueError(f"{name} {directory} exists and is not a directory")
        for in_name, in_path in inputs.items():
            if _inside(in_path, directory):
                raise ValueError(f"the {in_name} {in_path} lies in {name} {directory}, which "
                                 "this command writes into; copy it elsewhere first")


def atomic_write(
    path: PathLike, write: Callable[[str], None], *, make_parents: bool = False
) -> Path:
    """Call ``write(tmp_path)``, then fsync it and rename it over ``path``; return ``path``.

    Without ``make_parents`` a missing destination directory is a ``FileNotFoundError``; an
    existing directory at ``path`` is an ``IsADirectoryError`` (nothing is written).
    """
    path = Path(path)
    directory = path.parent
    if make_parents:
        directory.mkdir(parents=True, exist_ok=True)
    elif not directory.is_dir():
        raise FileNotFoundError(f"output directory does not exist: {directory}")
    if path.is_dir():
        raise IsADirectoryError(f"output path is an existing directory: {path}")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    os.close(fd)
    try:
        os.chmod(tmp, 0o666 & ~_umask())
        write(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        if isinstance(exc, OSError) and exc.filename in (None, tmp):
            exc.filename = str(path)  # the message names the file, not a temporary one
        raise
    fsync_dir(directory)
    return path


def atomic_write_bytes(path: PathLike, data: bytes, *, make_parents: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_write`)."""

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()

    return atomic_write(path, write, make_parents=make_parents)


def atomic_write_hdf5(
    path: PathLike, fill: Callable[[Any], None], *, make_parents: bool = False
) -> Path:
    """Build an HDF5 file in memory with ``fill(h5file)`` and write it atomically to ``path``."""
    import h5py

    buffer = io.BytesIO()
    with h5py.File(buffer, "w") as h5:
        fill(h5)
    return atomic_write_bytes(path, buffer.getvalue(), make_parents=make_parents)


def atomic_write_text(
    path: PathLike, text: str, *, encoding: str = "utf-8", make_parents: bool = False
) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write_bytes(path, text.encode(encoding), make_parents=make_parents)


def atomic_savefig(fig: Any, path: PathLike, **kwargs: Any) -> Path:
    """``fig.savefig`` into ``path`` atomically (see :func:`atomic_write`), in the format its
    suffix names (``.pdf``, ``.svg``, ``.png``, ``.jpg`` …; ``format=`` overrides): a failed
    write leaves the earlier file whole."""
    path = Path(path)
    kwargs.setdefault("format", path.suffix.lower().lstrip(".") or "png")
    return atomic_write(path, lambda tmp: fig.savefig(tmp, **kwargs))


def open_hdf5(path: PathLike, what: str = "", newest: int | None = None,
              expected: str | None = None) -> Any:
    """``path`` opened read-only as an ``h5py.File`` (use it in a ``with``):
    ``FileNotFoundError`` ("no such {what} file") if it is not a file (``ValueError`` for a
    directory), ``ValueError`` ("not an HDF5 file") if HDF5 cannot open it; with ``expected``
    (the root attribute ``format`` of the files sought) a ``ValueError`` naming the kind of
    another jamlab file (a trace given where a configuration is read); and with ``newest`` a
    ``ValueError`` for a root attribute ``format_version`` that is not an integer in
    ``[1, newest]`` (a file of a newer jamlab; files without the attribute, other programs', are
    read). The readers of configurations and traces start here."""
    import h5py

    from jamlab import validation

    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a directory, not a {what + ' ' if what else ''}file")
    if not path.is_file():
        raise FileNotFoundError(f"no such {what + ' ' if what else ''}file: {path}")
    try:
        h5 = h5py.File(path, "r")
    except OSError:
        raise ValueError(f"not an HDF5 file: {path}") from None
    kind = h5.attrs.get("format")
    kind = kind.decode() if isinstance(kind, bytes) else kind
    if (expected is not None and isinstance(kind, str) and kind.startswith("jamlab-")
            and kind != expected):
        h5.close()
        raise ValueError(f"{path} is a {kind} file, not a {what or expected} file")
    version = h5.attrs.get("format_version") if newest is not None else None
    if version is not None:
        try:
            validation.format_version(path, version, newest, f"{what} files".lstrip())
        except ValueError:
            h5.close()
            raise
    return h5


def check_links(group: Any, path: PathLike) -> None:
    """``ValueError`` ("damaged file") if a member of the open HDF5 group ``group`` (of the file
    ``path``) is a link that resolves to nothing: a soft link to a missing path or an external
    link to a missing file or object. h5py lists such a member (``name in group`` is true) but
    raises ``KeyError`` when it is opened, and ``group.get(name)`` returns ``None``. Only the
    members that are links are resolved (no dataset is opened): a read stays as cheap."""
    import h5py

    links = [name for name in group
             if isinstance(group.get(name, getlink=True), h5py.SoftLink | h5py.ExternalLink)]
    dangling = [name for name in links if group.get(name) is None]
    if dangling:
        where = group.name.rstrip("/") + "/"
        names = ", ".join(where + name for name in dangling)
        raise ValueError(f"damaged file {path}: {names} is a link to nothing "
                         "(a dangling soft or external link)")


@contextlib.contextmanager
def removed_on_failure(paths: list[PathLike], keep_only: frozenset[str]) -> Iterator[None]:
    """Undo what a command created when it fails before it made anything worth keeping: of
    ``paths`` and their parents, those missing on entry are removed if the block raises (any
    exception, Ctrl-C too) and they hold no file but ones named in ``keep_only`` (markers,
    manifests, locks). One that holds any other file — a finished or failed sample, a
    checkpoint, a figure — is left whole, and so is everything that existed on entry."""
    created = []
    for path in map(Path, paths):
        if os.path.lexists(path):
            continue
        while not os.path.lexists(path.parent) and path.parent != path:
            path = path.parent  # the outermost missing directory: what a mkdir -p makes
        created.append(path)
    created = [p for p in created if not any(_inside(p, q) and p != q for q in created)]
    try:
        yield
    except BaseException:
        for path in created:
            if path.is_dir() and not path.is_symlink():
                files = [f for f in path.rglob("*") if not f.is_dir()]
                if all(f.name in keep_only for f in files):
                    shutil.rmtree(path, ignore_errors=True)
            elif path.is_file() and path.name in keep_only:
                path.unlink(missing_ok=True)
        raise

