"""Exchange with the field's file formats: GSD (HOOMD schema), extended XYZ, LAMMPS data, text.

Formats (``docs/formats.md``, "Exchange formats"):

- ``gsd``: HOOMD-blue's schema through the ``gsd`` package, one frame per configuration. The
  standard chunks (what HOOMD, OVITO and freud read) hold the box ``[L, L, L, γ, 0, 0]`` (HOOMD's
  dimensionless tilt ``xy``: the image across ``y`` is shifted by ``xy·Ly = γL`` in ``x``; 2-d:
  ``Lz = 0``), positions wrapped into HOOMD's origin-centred box with image flags, and diameters,
  in single precision as the schema has them; the exact float64 values jamlab reads back are in
  ``log/`` chunks (``jamlab/box_length``, ``jamlab/strain``, ``particles/jamlab/position``, ...).
- ``extxyz``: extended XYZ (the ASE/OVITO/QUIP dialect), one block per configuration:
  ``Lattice="L 0 0 γL L 0 0 0 L"``, ``Properties=species:S:1:pos:R:3:radius:R:1``, ``pbc``, and
  ``strain``, ``box_length``, ``dim`` in the comment line; floats written with Python's shortest
  round-trip repr (ASE's own writer keeps 8 decimals, too few for a minimum), read with ASE.
- ``lammps-data``: a LAMMPS data file (``atom_style sphere``: ``id type diameter density x y z``,
  one atom type per distinct diameter), triclinic box of tilt ``xy = (γ − round γ) L`` (the same
  lattice); the exact ``γ`` is kept in the title line. One configuration per file.
- ``positions``: the whitespace text positions of ``jamlab import-xyz`` (import only).

An AQS trace exports as a movie: one frame per configuration the run saved beside the trace
(``TRACE.configs/step_*.h5`` with ``--save-every``, and ``TRACE.last.h5``), in step order, each
with its trace row (step, γ, E, Σ, p, plastic) as per-frame data.

``gsd`` and ``ase`` are optional (``pip install 'jamlab[formats]'``); without them the formats
that need them raise ``ImportError`` naming the extra.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jamlab import validation
from jamlab.files import atomic_write, open_hdf5
from jamlab.spheres import Box, Packing
from jamlab.spheres.box import reduced_strain
from jamlab.spheres.exchange_seed import extxyz_seed, gsd_seed_chunk, seed_of_gsd_chunk
from jamlab.spheres.io import read_lammps_positions, read_packing
from jamlab.spheres.trace import read_trace

__all__ = [
    "FORMATS",
    "EXPORT_FORMATS",
    "SUFFIXES",
    "Frame",
    "format_from_suffix",
    "make_packing",
    "frames_of",
    "export_frames",
    "read_frames",
    "write_gsd",
    "read_gsd",
    "write_extxyz",
    "read_extxyz",
    "write_lammps_data",
    "read_lammps_data",
]

FORMATS = ("gsd", "extxyz", "lammps-data", "positions")
"""Formats ``jamlab import`` reads."""
EXPORT_FORMATS = ("gsd", "extxyz", "lammps-data")
"""Formats ``jamlab export`` writes."""

SUFFIXES = {
    ".gsd": "gsd",
    ".extxyz": "extxyz",
    ".xyz": "extxyz",
    ".data": "lammps-data",
    ".lmp": "lammps-data",
    ".lammps": "lammps-data",
    ".txt": "positions",
}
"""The exchange format each file suffix names (:func:`format_named_by`)."""
_EXTRA = "pip install 'jamlab[formats]'"
_ROW_KEYS = ("gamma", "energy", "shear_stress", "pressure", "plastic")
"""Trace columns carried as per-frame data of an exported AQS trace."""


@dataclass(frozen=True, eq=False)
class Frame:
    """One configuration and, for a frame of an AQS trace, its step and trace row."""

    packing: Packing
    step: int | None = None
    row: dict[str, float] = field(default_factory=dict)


def format_named_by(path: str | os.PathLike) -> str | None:
    """The format a file's suffix names (module table), or ``None`` for another suffix."""
    return SUFFIXES.get(Path(path).suffix.lower())


def format_from_suffix(path: str | os.PathLike, formats: tuple[str, ...] = FORMATS) -> str:
    """The format named by a file's suffix (``.gsd``, ``.extxyz``/``.xyz``, ``.data``/``.lmp``/
    ``.lammps``, ``.txt``); ``ValueError`` if the suffix names none (the message lists
    ``formats``, the ones the caller can use: :data:`EXPORT_FORMATS` for a file written)."""
    named = format_named_by(path)
    if named is None:
        raise ValueError(
            f"cannot tell the format of {path} from its suffix; give --format "
            f"({', '.join(formats)})"
        )
    return named


def make_packing(
    positions: np.ndarray,
    length: float,
    strain: float,
    diameters: np.ndarray | None = None,
    alpha: float | None = None,
    seed: int | None = None,
) -> Packing:
    """A :class:`Packing` from exchanged data (diameters default to 1, ``alpha`` to 2);
    ``ValueError`` naming what is wrong."""
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim != 2 or positions.shape[1] < 2:
        raise ValueError(f"positions must be an (N, d >= 2) array, got shape {positions.shape}")
    if diameters is not None:
        diameters = np.asarray(diameters, dtype=np.float64)
        if diameters.shape != (positions.shape[0],):
            raise ValueError(f"{diameters.size} diameters for {positions.shape[0]} particles")
    box = Box(float(length), positions.shape[1], float(strain))
    return Packing(
        positions, box, seed=seed, diameters=diameters, alpha=2.0 if alpha is None else alpha
    )


# --- jamlab side: configurations and traces as frames -------------------------------------------


def _h5_format(path: Path) -> str:
    with open_hdf5(path) as h5:
        fmt = h5.attrs.get("format", "")
    return fmt.decode() if isinstance(fmt, bytes) else str(fmt)


def frames_of(path: str | os.PathLike) -> list[Frame]:
    """The frames of a jamlab configuration (one) or AQS trace (every configuration the run saved
    beside it, in step order, with its trace row); ``ValueError`` for any other file."""
    from jamlab.spheres.aqs.checkpoint import saved_configurations

    path = Path(path)
    fmt = _h5_format(path)
    if fmt == "jamlab-configuration":
        return [Frame(read_packing(path))]
    if fmt != "jamlab-aqs-trace":
        raise ValueError(f"not a jamlab configuration or AQS trace (format {fmt!r}): {path}")
    trace = read_trace(path)
    files = saved_configurations(path, trace)
    frames = []
    for step in sorted(files):
        packing = read_packing(files[step])
        if not 0 <= step <= trace.n_steps or packing.strain != float(trace.gamma[step]):
            raise ValueError(f"{files[step]} (step {step}, strain {packing.strain!r}) is not a "
                             f"configuration of the run in {path.name}: a leftover of another run")
        row = {k: float(getattr(trace, k)[step]) for k in _ROW_KEYS}
        frames.append(Frame(packing, step, row))
    return frames


def saved_files(path: str | os.PathLike) -> tuple[dict[str, Path], Path | None]:
    """``({description: file}, folder)``: the files :func:`frames_of` reads beside the AQS trace
    ``path`` (``<stem>.last.h5`` and the ``step_*.h5`` of its snapshot folder, listed, not opened:
    :func:`frames_of` reads them) and that folder; ``({}, None)`` for a configuration. An export
    writes over none of them and nothing into the folder (a foreign file would be read, or removed
    by ``shear --force``, with the snapshots). ``<stem>.last.h5`` is listed even when it does not
    exist: a file written there would be read as the run's last configuration (by ``shear
    --resume`` and the next export)."""
    from jamlab.spheres.aqs.checkpoint import checkpoint_paths, snapshot_files

    path = Path(path)
    if _h5_format(path) != "jamlab-aqs-trace":
        return {}, None
    last, snapshots = checkpoint_paths(path)
    files = {f"saved configuration {f.name}": f for f in snapshot_files(snapshots)}
    return files | {"last configuration": last}, snapshots


def export_frames(frames: list[Frame], fmt: str, out: str | os.PathLike) -> Path:
    """Write ``frames`` to ``out`` in ``fmt`` (one of :data:`EXPORT_FORMATS`), atomically."""
    if fmt == "gsd":
        return write_gsd(out, frames)
    if fmt == "extxyz":
        return write_extxyz(out, frames)
    if fmt == "lammps-data":
        if len(frames) != 1:
            raise ValueError(
                f"a LAMMPS data file holds one configuration, got {len(frames)} frames: "
                "choose one with --frame, or export gsd/extxyz for the movie"
            )
        return write_lammps_data(out, frames[0].packing)
    valid = ", ".join(EXPORT_FORMATS)
    raise ValueError(f"unknown export format {fmt!r}: valid formats are {valid}")


def read_frames(
    path: str | os.PathLike,
    fmt: str | None = None,
    *,
    box_length: float | None = None,
    strain: float = 0.0,
) -> list[Packing]:
    """Every configuration in ``path`` (format from the suffix when ``fmt`` is None);
    ``box_length``/``strain`` only for ``positions`` (see ``read_lammps_positions``)."""
    path = Path(path)
    fmt = fmt or format_from_suffix(path)
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}: valid formats are {', '.join(FORMATS)}")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    if fmt != "positions" and (box_length is not None or strain != 0.0):
        raise ValueError(f"--box-length and --strain are for text positions; {fmt} has its box")
    if fmt == "gsd":
        return read_gsd(path)
    if fmt == "extxyz":
        return read_extxyz(path)
    if fmt == "lammps-data":
        return [read_lammps_data(path)]
    return [read_lammps_positions(path, box_length=box_length, strain=strain)]


# --- GSD ----------------------------------------------------------------------------------------


def _gsd_hoomd():
    try:
        import gsd.hoomd
    except ImportError:
        raise ImportError(f"the gsd format needs the gsd package: {_EXTRA}") from None
    return gsd.hoomd


def _cell(length: float, strain: float, dim: int) -> np.ndarray:
    """Lattice vectors as rows (3 × 3): ``a = (L,0,0)``, ``b = (γL, L, 0)``, ``c = (0,0,L)``;
    in 2-d ``c = (0, 0, 0)``."""
    h = np.zeros((3, 3))
    h[0, 0] = h[1, 1] = length
    h[1, 0] = strain * length
    if dim == 3:
        h[2, 2] = length
    return h


def _pad3(positions: np.ndarray) -> np.ndarray:
    out = np.zeros((positions.shape[0], 3))
    out[:, : positions.shape[1]] = positions
    return out


def _check_dim_3(packing: Packing, fmt: str) -> None:
    if packing.dim not in (2, 3):
        raise ValueError(f"{fmt} holds 2-d or 3-d configurations, got d={packing.dim}")


def write_gsd(out: str | os.PathLike, frames: list[Frame]) -> Path:
    """GSD file (HOOMD schema), one frame per :class:`Frame` (module docstring)."""
    hoomd = _gsd_hoomd()

    def write(tmp: str) -> None:
        with hoomd.open(tmp, "w") as traj:
            for k, fr in enumerate(frames):
                p = fr.packing
                _check_dim_3(p, "gsd")
                L, gamma, dim = p.box.length, p.box.strain, p.dim
                h = _cell(L, gamma, dim)
                x = _pad3(p.positions)
                # HOOMD's box is centred on the origin: x = pos + h^T (image + 1/2)
                frac = np.zeros_like(x)
                frac[:, :dim] = np.linalg.solve(h[:dim, :dim].T, x[:, :dim].T).T
                image = np.floor(frac)
                pos = (frac - image - 0.5) @ h
                pos[:, dim:] = 0.0
                diam = p.diameters
                f = hoomd.Frame()
                f.configuration.step = int(fr.step if fr.step is not None else k)
                f.configuration.dimensions = dim
                f.configuration.box = [L, L, L if dim == 3 else 0.0, gamma, 0.0, 0.0]
                f.particles.N = p.n
                f.particles.types = ["A"]
                f.particles.typeid = np.zeros(p.n, dtype=np.uint32)
                f.particles.position = pos.astype(np.float32)
                f.particles.image = image.astype(np.int32)
                f.particles.diameter = diam.astype(np.float32)
                f.log["jamlab/box_length"] = np.array([L])
                f.log["jamlab/strain"] = np.array([gamma])
                f.log["jamlab/alpha"] = np.array([p.alpha])
                f.log["jamlab/seed"] = gsd_seed_chunk(p.seed)
                f.log["particles/jamlab/position"] = np.ascontiguousarray(p.positions)
                f.log["particles/jamlab/diameter"] = np.ascontiguousarray(diam)
                if fr.step is not None:
                    f.log["jamlab/aqs_step"] = np.array([fr.step], np.int64)
                for key, value in fr.row.items():
                    f.log[f"jamlab/{key}"] = np.array([value])
                traj.append(f)

    return atomic_write(out, write)


def read_gsd(path: str | os.PathLike) -> list[Packing]:
    """Every frame of a GSD file: jamlab's exact ``log/`` values when present, else the HOOMD
    chunks (single precision; positions shifted from the centred box to ``[0, L)``)."""
    hoomd = _gsd_hoomd()
    packings = []
    try:
        traj = hoomd.open(str(path), "r")
    except (RuntimeError, OSError) as exc:
        raise ValueError(f"not a GSD (HOOMD) file: {path}: {exc}") from None
    with traj:
        for f in traj:
            log = f.log
            if "particles/jamlab/position" in log and "jamlab/box_length" in log:
                pos = np.asarray(log["particles/jamlab/position"], dtype=np.float64)
                packings.append(
                    make_packing(
                        pos,
                        float(log["jamlab/box_length"][0]),
                        float(log["jamlab/strain"][0]),
                        log.get("particles/jamlab/diameter"),
                        float(log["jamlab/alpha"][0]) if "jamlab/alpha" in log else None,
                        seed_of_gsd_chunk(log.get("jamlab/seed"), path),
                    )
                )
                continue
            dim = int(f.configuration.dimensions)
            Lx, Ly, Lz, xy, xz, yz = (float(v) for v in f.configuration.box)
            if Lx != Ly or (dim == 3 and Lz != Lx) or xz != 0 or yz != 0:
                raise ValueError(
                    f"{path}: box {list(f.configuration.box)} is not a Lees–Edwards cube "
                    "(Lx = Ly [= Lz], xz = yz = 0)"
                )
            h = _cell(Lx, xy, dim)
            pos = np.asarray(f.particles.position, dtype=np.float64) + 0.5 * h.sum(axis=0)
            diam = f.particles.diameter
            packings.append(
                make_packing(pos[:, :dim], Lx, xy, None if diam is None else diam.astype(float))
            )
    if not packings:
        raise ValueError(f"{path}: no frame")
    return packings


# --- extended XYZ -------------------------------------------------------------------------------


def _ase_io():
    try:
        import ase.io
    except ImportError:
        raise ImportError(f"the extxyz format needs ASE: {_EXTRA}") from None
    return ase.io


def _f(x: float) -> str:
    return repr(float(x))


def write_extxyz(out: str | os.PathLike, frames: list[Frame]) -> Path:
    """Extended XYZ, one block per frame (module docstring); written here at full precision
    (no dependency), read back with ASE."""
    blocks = []
    for k, fr in enumerate(frames):
        p = fr.packing
        _check_dim_3(p, "extxyz")
        L, gamma, dim = p.box.length, p.box.strain, p.dim
        h = _cell(L, gamma, dim)
        if dim == 2:
            h[2, 2] = 1.0  # extxyz needs three vectors; z is not periodic in 2-d
        info = {
            "strain": _f(gamma),
            "box_length": _f(L),
            "dim": str(dim),
            "alpha": _f(p.alpha),
            "seed": str(-1 if p.seed is None else p.seed),
            "frame": str(k),
        }
        if fr.step is not None:
            info["aqs_step"] = str(fr.step)
        for key, value in fr.row.items():
            info[f"aqs_{key}"] = _f(value)
        lattice = " ".join(_f(v) for v in h.reshape(-1))
        pbc = "T T T" if dim == 3 else "T T F"
        head = (
            f'Lattice="{lattice}" Properties=species:S:1:pos:R:3:radius:R:1 pbc="{pbc}" '
            + " ".join(f"{key}={value}" for key, value in info.items())
        )
        x = _pad3(p.positions)
        radius = 0.5 * p.diameters
        lines = [str(p.n), head]
        lines += [
            f"X {_f(a)} {_f(b)} {_f(c)} {_f(r)}" for (a, b, c), r in zip(x, radius, strict=True)
        ]
        blocks.append("\n".join(lines) + "\n")

    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            fh.writelines(blocks)

    return atomic_write(out, write)


def read_extxyz(path: str | os.PathLike) -> list[Packing]:
    """Every block of an extended XYZ file (read by ASE). The box must be a Lees–Edwards cube:
    ``a = (L, 0, 0)``, ``b = (γL, L, 0)``, ``c = (0, 0, L)`` (2-d: ``pbc = T T F``, ``z = 0``);
    ``strain``, ``box_length``, ``dim`` from the comment line when present (jamlab's files);
    diameters from a ``diameter`` or ``radius`` column, else 1."""
    aio = _ase_io()
    try:
        images = aio.read(str(path), index=":", format="extxyz")
    except Exception as exc:  # noqa: BLE001 - ASE raises many types on a malformed file
        raise ValueError(f"cannot read {path} as extended XYZ: {exc}") from None
    packings = []
    for i, atoms in enumerate(images):
        info = atoms.info
        cell = np.asarray(atoms.cell[:], dtype=np.float64)
        pbc = list(atoms.pbc)
        dim = int(info.get("dim", 2 if not pbc[2] else 3))
        L = float(info.get("box_length", cell[0, 0]))
        gamma = float(info["strain"]) if "strain" in info else cell[1, 0] / L
        expect = _cell(L, gamma, dim)
        if dim == 2:
            expect[2, 2] = cell[2, 2]
        if not np.allclose(cell, expect, rtol=0, atol=1e-12 * L) or not all(pbc[:dim]):
            raise ValueError(
                f"{path}: block {i}: cell {cell.tolist()} (pbc {pbc}) is not a Lees–Edwards "
                f"cube of side {L} at strain {gamma}"
            )
        pos = np.asarray(atoms.positions, dtype=np.float64)
        if dim == 2 and np.any(pos[:, 2] != 0):
            raise ValueError(f"{path}: block {i}: a 2-d configuration has z != 0")
        if "diameter" in atoms.arrays:
            diam = np.asarray(atoms.arrays["diameter"], dtype=np.float64)
        elif "radius" in atoms.arrays:
            diam = 2.0 * np.asarray(atoms.arrays["radius"], dtype=np.float64)
        else:
            diam = None
        seed = extxyz_seed(info.get("seed", -1), path, i)
        alpha = float(info["alpha"]) if "alpha" in info else None
        packings.append(make_packing(pos[:, :dim], L, gamma, diam, alpha, seed))
    if not packings:
        raise ValueError(f"{path}: no configuration")
    return packings


# --- LAMMPS data --------------------------------------------------------------------------------

_TITLE_KEYS = ("jamlab_box_length", "jamlab_strain", "jamlab_dim", "jamlab_alpha", "jamlab_seed")


def write_lammps_data(out: str | os.PathLike, packing: Packing) -> Path:
    """LAMMPS data file (``atom_style sphere``), triclinic box ``[0, L)^3`` with tilt
    ``xy = (γ − round γ) L``; 2-d: ``z`` in ``[−0.5, 0.5)`` (use ``dimension 2``). Atom types
    number the distinct diameters in increasing order."""
    from jamlab import __version__

    p = packing
    _check_dim_3(p, "a LAMMPS data file")
    L, gamma, dim = p.box.length, p.box.strain, p.dim
    diam = p.diameters
    kinds, types = np.unique(diam, return_inverse=True)
    x = _pad3(p.positions)
    seed = -1 if p.seed is None else p.seed
    title = (
        f"LAMMPS data file written by jamlab {__version__}: jamlab_box_length={_f(L)} "
        f"jamlab_strain={_f(gamma)} jamlab_dim={dim} jamlab_alpha={_f(p.alpha)} "
        f"jamlab_seed={seed} (tilt xy = (strain - round(strain)) * box_length)"
    )
    zlo, zhi = (0.0, L) if dim == 3 else (-0.5, 0.5)
    lines = [
        title,
        "",
        f"{p.n} atoms",
        f"{kinds.size} atom types",
        "",
        f"0.0 {_f(L)} xlo xhi",
        f"0.0 {_f(L)} ylo yhi",
        f"{_f(zlo)} {_f(zhi)} zlo zhi",
        f"{_f(reduced_strain(gamma) * L)} 0.0 0.0 xy xz yz",
        "",
        "Atoms # sphere",
        "",
    ]
    lines += [
        f"{i + 1} {t + 1} {_f(d)} 1.0 {_f(a)} {_f(b)} {_f(c)}"
        for i, (t, d, (a, b, c)) in enumerate(zip(types, diam, x, strict=True))
    ]

    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            fh.write("\n".join(lines) + "\n")

    return atomic_write(out, write)


_SECTIONS = (
    "Atoms", "Velocities", "Masses", "Ellipsoids", "Lines", "Triangles", "Bodies", "Bonds",
    "Angles", "Dihedrals", "Impropers", "Pair Coeffs", "PairIJ Coeffs", "Bond Coeffs",
    "Angle Coeffs", "Dihedral Coeffs", "Improper Coeffs", "Atom Type Labels",
)  # fmt: skip


def read_lammps_data(path: str | os.PathLike) -> Packing:
    """A LAMMPS data file with an ``Atoms`` section of style ``sphere`` (``id type diameter
    density x y z [ix iy iz]``) or ``atomic`` (``id type x y z [ix iy iz]``; diameters 1).
    Positions are shifted by ``(xlo, ylo, zlo)``; image flags are ignored (any periodic image
    is a valid position). The box must be a cube with ``xz = yz = 0``; ``γ``, ``d`` and ``α`` come
    from jamlab's title line when present, else ``γ = xy/L`` and ``d = 2`` if every ``z = 0``
    and the ``z`` side differs from ``L`` (LAMMPS's 2-d boxes), ``d = 3`` otherwise."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    try:
        lines = path.read_text().splitlines()
    except UnicodeDecodeError:
        raise ValueError(f"not a LAMMPS data file (not text): {path}") from None
    title = dict(re.findall(r"\b(jamlab_\w+)=(\S+)", lines[0])) if lines else {}
    header: dict[str, list[str]] = {}
    n_atoms = None
    i = 1
    while i < len(lines):
        text = lines[i].split("#", 1)[0].strip()
        if not text:
            i += 1
            continue
        if text in _SECTIONS:
            break
        words = text.split()
        if words[-1] == "atoms":
            n_atoms = int(words[0])
        for key, count in (("xlo xhi", 2), ("ylo yhi", 2), ("zlo zhi", 2), ("xy xz yz", 3)):
            if text.endswith(key):
                header[key] = words[:count]
        i += 1
    missing = [k for k in ("xlo xhi", "ylo yhi", "zlo zhi") if k not in header]
    if n_atoms is None or missing:
        raise ValueError(f"not a LAMMPS data file (no atoms count or {missing}): {path}")
    lo = np.array([float(header[k][0]) for k in ("xlo xhi", "ylo yhi", "zlo zhi")])
    hi = np.array([float(header[k][1]) for k in ("xlo xhi", "ylo yhi", "zlo zhi")])
    xy, xz, yz = (float(v) for v in header.get("xy xz yz", ["0", "0", "0"]))
    L = float(title.get("jamlab_box_length", hi[0] - lo[0]))
    # the Atoms section
    while i < len(lines) and lines[i].split("#", 1)[0].strip() != "Atoms":
        i += 1
    if i == len(lines):
        raise ValueError(f"{path}: no Atoms section")
    style = lines[i].split("#", 1)[1].strip() if "#" in lines[i] else ""
    rows = []
    i += 1
    while i < len(lines) and len(rows) < n_atoms:
        text = lines[i].split("#", 1)[0].strip()
        i += 1
        if text:
            rows.append(text.split())
    if len(rows) != n_atoms:
        raise ValueError(f"{path}: {len(rows)} atom lines for {n_atoms} atoms")
    ncol = {len(r) for r in rows}
    if not style:
        style = {7: "sphere", 10: "sphere", 5: "atomic", 8: "atomic"}.get(min(ncol), "")
    first = {"sphere": 4, "atomic": 2}.get(style)
    if first is None or len(ncol) != 1 or min(ncol) not in (first + 3, first + 6):
        raise ValueError(
            f"{path}: Atoms style {style or '?'} with {sorted(ncol)} columns: jamlab reads "
            "'sphere' (id type diameter density x y z) and 'atomic' (id type x y z)"
        )
    try:
        data = np.array([[float(v) for v in r[: first + 3]] for r in rows])
    except ValueError as exc:
        raise ValueError(f"{path}: cannot parse the Atoms section: {exc}") from None
    order = np.argsort(data[:, 0], kind="stable")
    data = data[order]
    pos = data[:, first : first + 3] - lo
    z = data[:, first + 2]
    if "jamlab_dim" in title:
        dim = int(title["jamlab_dim"])
    else:  # LAMMPS's 2-d boxes have any z extent and every z = 0
        flat = not np.isclose(hi[2] - lo[2], L, rtol=1e-12, atol=0) and np.all(z == 0)
        dim = 2 if flat else 3
    if dim == 2 and np.any(z != 0):
        raise ValueError(f"{path}: a 2-d configuration has z != 0")
    if not np.allclose((hi - lo)[:dim], L, rtol=1e-12, atol=0) or xz != 0 or yz != 0:
        raise ValueError(
            f"{path}: box sides {(hi - lo).tolist()} with tilts xz={xz}, yz={yz}: not a "
            "Lees–Edwards cube (equal sides, xz = yz = 0)"
        )
    if "jamlab_strain" in title:
        gamma = float(title["jamlab_strain"])
        if abs(reduced_strain(gamma) * L - xy) > 1e-12 * L:
            raise ValueError(f"{path}: title strain {gamma} does not match the tilt xy={xy}")
    else:
        gamma = xy / L
    diam = data[:, 2] if style == "sphere" else None
    alpha = float(title["jamlab_alpha"]) if "jamlab_alpha" in title else None
    seed = title.get("jamlab_seed", "-1")
    seed = None if seed == "-1" else validation.seed(f"{path}: jamlab_seed", seed)
    return make_packing(pos[:, :dim], L, gamma, diam, alpha, seed)
