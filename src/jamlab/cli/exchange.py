"""``jamlab export`` and ``jamlab import``: the field's file formats (GSD, extended XYZ, LAMMPS
data, text positions), a thin face over :mod:`jamlab.spheres.exchange` (``docs/formats.md``,
"Exchange formats")."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from jamlab.cli._options import Force
from jamlab.files import check_outputs


def _pick(frames: list, frame: int | None, what: str) -> list:
    if frame is None:
        return frames
    if not -len(frames) <= frame < len(frames):
        raise ValueError(f"--frame {frame} out of range: {what} has {len(frames)} frame(s)")
    return [frames[frame]]


def register(app: typer.Typer) -> None:
    """Add ``jamlab export`` and ``jamlab import``."""

    @app.command(
        "export",
        help="Write a configuration, or an AQS trace's saved configurations as a movie, as GSD "
        "(HOOMD, OVITO), extended XYZ (ASE, OVITO) or a LAMMPS data file.",
    )
    def export_command(
        source: Annotated[
            Path, typer.Argument(help="Configuration or AQS trace (HDF5, docs/formats.md).")
        ],
        out: Annotated[Path, typer.Option("--out", help="File to write.")],
        fmt: Annotated[
            str | None,
            typer.Option(
                "--format", help="gsd, extxyz or lammps-data (default: from --out's suffix)."
            ),
        ] = None,
        frame: Annotated[
            int | None,
            typer.Option("--frame", help="Only this frame of a trace (0 = first, -1 = last)."),
        ] = None,
        force: Force = False,
    ) -> None:
        from jamlab.cli import UserError
        from jamlab.spheres import exchange as ex

        fmt = fmt or ex.format_from_suffix(out, ex.EXPORT_FORMATS)
        if fmt not in ex.EXPORT_FORMATS:
            raise ValueError(
                f"cannot export to {fmt!r}: valid formats are {', '.join(ex.EXPORT_FORMATS)}"
            )
        named = ex.format_named_by(out)
        if named is not None and named != fmt:  # every reader would take the suffix's word
            raise ValueError(f"--out {out} names {named}, and --format {fmt} writes {fmt}: give "
                             "the file a suffix of its format (or leave --format out)")
        from jamlab.spheres.aqs.checkpoint import replacement_pending

        if replacement_pending(source):  # some snapshots may be another run's, or aside
            raise ValueError(f"{source}: a shear --force replacing this run was killed at its "
                             f"first save; any jamlab shear ... --out {source} finishes or undoes "
                             "the replacement")
        # a trace's saved configurations (X.last.h5, X.configs/step_*.h5) are inputs too, and
        # nothing is written into its snapshot folder X.configs/
        saved, folder = ex.saved_files(source)
        check_outputs({"--out": out}, {"input": source, **saved},
                      read_directories={"snapshot folder": folder}, force=force)
        frames = _pick(ex.frames_of(source), frame, str(source))
        try:
            ex.export_frames(frames, fmt, out)
        except ImportError as exc:
            raise UserError(str(exc)) from None
        p = frames[-1].packing
        steps = [f.step for f in frames if f.step is not None]
        span = f", AQS steps {steps[0]}..{steps[-1]}" if steps else ""
        typer.echo(
            f"{len(frames)} frame(s){span}: N={p.n} d={p.dim} L={p.box.length!r} "
            f"strain={p.box.strain!r} -> {out} ({fmt})"
        )

    @app.command(
        "import",
        help="Convert a GSD, extended XYZ, LAMMPS data or text positions file to a "
        "configuration file (HDF5).",
    )
    def import_command(
        source: Annotated[Path, typer.Argument(help="File to read.")],
        out: Annotated[Path, typer.Option("--out", help="Configuration file to write (HDF5).")],
        fmt: Annotated[
            str | None,
            typer.Option(
                "--format",
                help="gsd, extxyz, lammps-data or positions (default: from the suffix).",
            ),
        ] = None,
        frame: Annotated[
            int, typer.Option("--frame", help="Frame of a multi-frame file (-1 = last).")
        ] = -1,
        box_length: Annotated[
            float | None,
            typer.Option("--box-length", help="positions only: box side L (or meta.json)."),
        ] = None,
        strain: Annotated[
            float, typer.Option("--strain", help="positions only: strain of the positions.")
        ] = 0.0,
        force: Force = False,
    ) -> None:
        import numpy as np

        from jamlab.cli import UserError
        from jamlab.spheres import exchange as ex
        from jamlab.spheres.io import positions_meta, read_packing, write_packing

        fmt = fmt or ex.format_from_suffix(source)
        if box_length is not None and not box_length > 0:
            raise ValueError(f"--box-length must be > 0, got {box_length}")
        # text positions read the meta.json beside them (as import-xyz)
        meta = positions_meta(source, box_length) if fmt == "positions" else None
        check_outputs({"--out": out}, {"input": source, "meta.json": meta}, force=force,
                      hdf5=("--out",))
        try:
            packings = ex.read_frames(source, fmt, box_length=box_length, strain=strain)
        except ImportError as exc:
            raise UserError(str(exc)) from None
        (packing,) = _pick(packings, frame, str(source))
        write_packing(out, packing, imported_from=str(source), imported_format=fmt)
        if not np.array_equal(read_packing(out).diameters, packing.diameters):
            out.unlink()
            raise ValueError(f"{out}: this jamlab's configuration file cannot keep the diameters")
        typer.echo(
            f"frame {frame % len(packings)} of {len(packings)}: N={packing.n} d={packing.dim} "
            f"phi={packing.phi:.10g} strain={packing.box.strain!r} -> {out}"
        )
