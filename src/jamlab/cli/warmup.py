"""``jamlab warmup``: compile the numba kernels once after installing (:mod:`jamlab.warmup`)."""

from __future__ import annotations

from typing import Annotated

import typer

from jamlab import validation


def register(app: typer.Typer) -> None:
    """Add ``warmup``."""

    @app.command(
        "warmup",
        help="Compile jamlab's numba kernels now (once per install and machine), so that the "
        "first real run does not wait for them.",
    )
    def warmup_command(
        jobs: Annotated[
            int | None, typer.Option("--jobs", help="Processes (default: the usable cores).")
        ] = None,
        extra: Annotated[
            bool, typer.Option("--all", help="Also d = 2 and the other pair laws.")
        ] = False,
    ) -> None:
        from jamlab.warmup import warmup

        if jobs is not None:
            validation.integer("--jobs", jobs, minimum=1)
        result = warmup(jobs=jobs, extra=extra, progress=lambda m: typer.echo(f"  {m}"))
        more = f" (the check compiled {result.left} more)" if result.left else ""
        typer.echo(
            f"numba cache filled: {result.compiled + result.left} kernels compiled in "
            f"{result.seconds:.1f} s{more}"
        )
        from jamlab.provenance import machine, summary_text
        from jamlab.spheres import blas

        record = machine()  # loads CHOLMOD as the runs will (spheres.blas)
        choice = blas.choice()
        typer.echo(f"this machine: {summary_text(record)}")
        typer.echo(f"CHOLMOD's BLAS kernels: {choice.get('coretype') or 'its own choice'} "
                   f"({choice.get('reason', '')}; docs/aqs.md, \"CHOLMOD's BLAS kernels\")")
