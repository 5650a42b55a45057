"""``jamlab shear``: athermal quasi-static shear of a configuration, writing the AQS trace.

A thin face over :func:`jamlab.spheres.aqs.shear`; the trace format is in ``docs/formats.md``
("AQS trace"), the method and the elastic/plastic rule in ``docs/aqs.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def register(app: typer.Typer) -> None:
    """Add ``jamlab shear``."""

    @app.command("shear", help="AQS shear: x += dγ y, γ += dγ, minimise; write the trace (HDF5).")
    def shear_command(
        config: Annotated[
            Path, typer.Argument(help="Start configuration (HDF5, docs/formats.md).")
        ],
        dgamma: Annotated[float, typer.Option("--dgamma", help="Strain step dγ (> 0).")],
        gamma_max: Annotated[
            float, typer.Option("--gamma-max", help="Final strain increment (> dγ).")
        ],
        out: Annotated[Path, typer.Option("--out", help="Trace file to write (HDF5).")],
        minimizer: Annotated[
            str,
            typer.Option(
                "--minimizer", help="'linear' (linear response + Newton, FIRE fallback) or 'fire'."
            ),
        ] = "linear",
        ftol: Annotated[
            float, typer.Option("--ftol", help="Converged when max_i |F_i| < ftol.")
        ] = (1e-12),
        save_every: Annotated[
            int | None,
            typer.Option(
                "--save-every",
                help="Save the trace and the configuration every k steps (always at the end).",
            ),
        ] = None,
        resume: Annotated[
            bool,
            typer.Option(
                "--resume",
                help="Continue the run in --out from its saved last configuration.",
            ),
        ] = False,
        plot: Annotated[
            Path | None, typer.Option("--plot", help="Also draw E and Σ against γ (PNG/PDF).")
        ] = None,
    ) -> None:
        from jamlab.spheres.aqs import checkpoint_paths, n_steps_for, shear
        from jamlab.spheres.io import read_packing
        from jamlab.spheres.trace import read_trace

        n_steps = n_steps_for(dgamma, gamma_max)
        if minimizer not in ("linear", "fire"):
            raise ValueError(f"--minimizer must be 'linear' or 'fire', got {minimizer!r}")
        if not config.is_file():
            raise FileNotFoundError(f"no such configuration file: {config}")
        previous = None
        if resume:
            last, _ = checkpoint_paths(out)
            if not (out.is_file() and last.is_file()):
                raise FileNotFoundError(f"--resume needs {out} and {last} from an earlier run")
            previous = read_trace(out)
            if previous.attrs.get("dgamma") != dgamma:
                raise ValueError(
                    f"--dgamma {dgamma} differs from the run being resumed "
                    f"({previous.attrs.get('dgamma')})"
                )
            packing = read_packing(last)
        else:
            packing = read_packing(config)
        result = shear(
            packing,
            dgamma,
            n_steps=n_steps,
            minimizer=minimizer,
            ftol=ftol,
            save_every=save_every,
            out=out,
            previous=previous,
            source=str(config),
        )
        tr = result.trace
        typer.echo(
            f"{tr.n_steps} steps of dγ={dgamma:g} to γ={tr.gamma[-1]:.6g} ({minimizer}): "
            f"{int(tr.plastic.sum())} plastic, {result.n_fallback} FIRE fallbacks, "
            f"{result.n_not_converged} not converged, {result.time:.2f} s -> {out}"
        )
        if plot is not None:
            from jamlab.plots.shear import stress_strain_figure

            stress_strain_figure(tr, plot)
            typer.echo(f"figure -> {plot}")
