"""``jamlab prepare`` (jammed / UNSAT packings) and ``jamlab coordination`` (paper Fig. 1).

A thin face over :mod:`jamlab.spheres.packing`; protocol and stopping rule in
``docs/packings.md``. A packing that fails its stopping rule is still written, with the HDF5
attributes ``ok = False`` and ``reason``, and the command exits with code 1.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated

import typer

from jamlab.cli._options import Force


@contextlib.contextmanager
def _status(quiet: bool, title: str) -> Iterator[Callable[[str], None]]:
    if quiet:
        yield lambda message: None
        return
    from rich.console import Console

    console = Console(stderr=True)
    with console.status(title) as status:
        yield lambda message: status.update(f"{title}: {message}")


def register(app: typer.Typer) -> None:
    """Add ``prepare`` and ``coordination``."""

    @app.command(
        "prepare",
        help="Jammed (--phi jamming) or over-jammed (--phi 0.8) packing from a random state.",
    )
    def prepare_command(
        n: Annotated[int, typer.Option("--n", help="Number of spheres.")] = 1000,
        dim: Annotated[int, typer.Option("--dim", help="Dimension d.")] = 3,
        phi: Annotated[
            str, typer.Option("--phi", help="'jamming', or a packing fraction above jamming.")
        ] = "jamming",
        seed: Annotated[int, typer.Option("--seed", help="Seed of the random start.")] = 0,
        out: Annotated[Path, typer.Option("--out", help="Output HDF5 file.")] = Path("packing.h5"),
        p_target: Annotated[
            float | None,
            typer.Option("--p-target", help="Target pressure at jamming (default 1e-7)."),
        ] = None,
        phi_init: Annotated[
            float | None,
            typer.Option("--phi-init", help="Quench packing fraction (jamming; default 0.66)."),
        ] = None,
        ftol: Annotated[float, typer.Option("--ftol", help="Max force tolerance.")] = 1e-12,
        sizes: Annotated[
            str,
            typer.Option(
                "--sizes",
                help="Diameters: mono (D=1), bidisperse (50:50, 1:1.4) or "
                "polydisperse[:w] (uniform, mean 1, relative sd w, default 0.1).",
            ),
        ] = "mono",
        alpha: Annotated[
            float, typer.Option("--alpha", help="Pair exponent: V = (1 - r/sigma)^alpha, > 1.")
        ] = 2.0,
        quiet: Annotated[bool, typer.Option("--quiet", help="No progress display.")] = False,
        pressure: Annotated[
            float | None,
            typer.Option(
                "--pressure",
                help="Jam (at --p-target), then relax positions and box to this pressure "
                "(minimize_enthalpy; --phi jamming only).",
            ),
        ] = None,
        ptol: Annotated[
            float | None,
            typer.Option("--ptol", help="Relative pressure tolerance (--pressure; default 1e-6)."),
        ] = None,
        force: Force = False,
    ) -> None:
        from jamlab import validation
        from jamlab.files import check_outputs
        from jamlab.provenance import provenance_json
        from jamlab.spheres.io import write_packing
        from jamlab.spheres.packing import jam, prepare
        from jamlab.spheres.pair import check_alpha
        from jamlab.spheres.state import parse_sizes

        validation.integer("--n", n, minimum=2)
        validation.dimension("--dim", dim)
        validation.seed("--seed", seed)
        validation.positive("--ftol", ftol)
        at_jamming = phi.strip().lower() == "jamming"
        for name, value in (("--p-target", p_target), ("--phi-init", phi_init)):
            if value is not None and not at_jamming:
                raise ValueError(f"{name} applies to --phi jamming, not to --phi {phi}")
        # the jamming protocol's own defaults where not given
        protocol = {}
        if p_target is not None:
            protocol["p_target"] = validation.positive("--p-target", p_target)
        if phi_init is not None:
            protocol["phi_init"] = validation.packing_fraction("--phi-init", phi_init)
        ptol = validation.pressure_tolerance(ptol, pressure, applies="--pressure")
        if pressure is not None:
            validation.positive("--pressure", pressure)
            if phi.strip().lower() != "jamming":
                raise ValueError("--pressure prepares at jamming: use it with --phi jamming")
        parse_sizes(sizes)
        check_alpha(alpha)
        value = None  # the packing fraction of --phi NUMBER
        if phi.strip().lower() != "jamming":
            try:
                value = float(phi)
            except ValueError:
                raise ValueError(f"--phi must be 'jamming' or a number, got {phi!r}") from None
            value = validation.above_jamming(
                "--phi", validation.packing_fraction("--phi", value), dim
            )
        check_outputs({"--out": out}, force=force, hdf5=("--out",))
        if pressure is not None:
            from jamlab.spheres.packing import jam_at_pressure

            with _status(quiet, f"jamming N={n} d={dim} seed={seed} to p={pressure:g}") as progress:
                res = jam_at_pressure(
                    n,
                    dim,
                    seed,
                    pressure,
                    ptol=ptol,
                    ftol=ftol,
                    **protocol,
                    progress=progress,
                    sizes=sizes,
                    alpha=alpha,
                )
        elif phi.strip().lower() == "jamming":
            with _status(quiet, f"jamming N={n} d={dim} seed={seed}") as progress:
                res = jam(
                    n,
                    dim,
                    seed,
                    ftol=ftol,
                    **protocol,
                    progress=progress,
                    sizes=sizes,
                    alpha=alpha,
                )
        else:
            with _status(quiet, f"minimising N={n} d={dim} phi={value}"):
                res = prepare(n, dim, value, seed, ftol=ftol, sizes=sizes, alpha=alpha)
        write_packing(out, res.packing, **res.attrs(), provenance=provenance_json())
        s = res.state
        typer.echo(
            f"{out}: N={n} d={dim} phi={res.packing.phi:.10f} p={s.pressure:.4e} z={s.z:.5f} "
            f"z_nr={s.z_nr:.5f} rattlers={s.n_rattlers} N_c'={s.n_contacts_nr} "
            f"(isostatic {s.n_contacts_iso}) minimisations={res.n_minimizations} "
            f"restarts={res.n_restarts} time={res.time:.1f}s ok={res.ok}"
        )
        if not res.ok:
            typer.echo(f"jamlab: packing failed its stopping rule: {res.reason}", err=True)
            raise typer.Exit(1)

    @app.command("coordination", help="z, z_nr, p, E along a compression from a jammed packing.")
    def coordination_command(
        config: Annotated[Path, typer.Argument(help="Jammed packing (jamlab prepare).")],
        out: Annotated[Path, typer.Option("--out", help="Figure (PNG/PDF).")] = Path("fig1.png"),
        csv: Annotated[Path | None, typer.Option("--csv", help="Also write the table.")] = None,
        steps: Annotated[int, typer.Option("--steps", help="Number of compression steps.")] = 40,
        dphi_min: Annotated[float, typer.Option("--dphi-min")] = 1e-6,
        dphi_max: Annotated[float, typer.Option("--dphi-max")] = 0.3,
        ftol: Annotated[float, typer.Option("--ftol", help="Max force tolerance.")] = 1e-12,
        quiet: Annotated[bool, typer.Option("--quiet", help="No progress display.")] = False,
        force: Force = False,
    ) -> None:
        import h5py
        import numpy as np

        from jamlab import validation
        from jamlab.cli import warn_if_flagged
        from jamlab.files import atomic_write, check_outputs
        from jamlab.plots.packings import plot_coordination
        from jamlab.spheres.compression import compression_schedule
        from jamlab.spheres.io import read_packing
        from jamlab.spheres.packing import coordination_curve, fit_power_law_corrected
        from jamlab.spheres.potential import max_force
        from jamlab.spheres.rigidity import is_jammed

        validation.integer("--steps", steps, minimum=2)
        validation.positive("--ftol", ftol)
        validation.positive("--dphi-min", dphi_min)
        validation.positive("--dphi-max", dphi_max, maximum=1.0)
        if not config.is_file():
            raise FileNotFoundError(f"no such configuration file: {config}")
        check_outputs({"--out": out, "--csv": csv}, {"configuration": config}, force=force,
                      figures=("--out",))
        packing = read_packing(config)
        # the curve's dphi is measured from the start: it must be a jammed minimum
        state = is_jammed(packing, ftol)
        fmax = max_force(packing)
        if not (fmax < ftol and state.jammed):
            raise ValueError(
                f"{config} is not a jammed minimum (max|F_i| = {fmax:.2e}, ftol {ftol:g}; "
                f"{'jammed' if state.jammed else 'not jammed: ' + state.reason}): start from "
                "jamlab prepare --phi jamming"
            )
        with h5py.File(config, "r") as h5:
            phi_j = float(h5.attrs.get("phi_j", packing.phi))
        if not math.isfinite(phi_j):
            phi_j = packing.phi
        compression_schedule(phi_j, dphi_min, dphi_max, steps)  # refused before any warning
        warn_if_flagged(config)
        if state.pressure > 1e-4:
            typer.echo(f"jamlab: warning: {config} is far above jamming (p = "
                       f"{state.pressure:.2e}): dphi is measured from its phi", err=True)
        with _status(quiet, "compressing") as progress:
            curve = coordination_curve(
                packing, phi_j, dphi_min, dphi_max, steps, ftol, progress=progress
            )
        fits = plot_coordination(curve, out)
        if csv is not None:
            cols = curve.as_columns()
            atomic_write(csv, lambda tmp: np.savetxt(
                tmp,
                np.column_stack(list(cols.values())),
                delimiter=",",
                header=",".join(cols),
                comments="",
                fmt="%.17g",
            ))
        series = {
            "z_nr - 2d": curve.z_nr - 2 * curve.dim,
            "z_nr - z_iso": curve.z_nr - curve.z_iso,
            "p": curve.pressure,
        }
        for name, (a, sa, _) in fits.items():
            line = f"{name} ~ (phi - phi_J)^{a:.4f} ± {sa:.4f}  (fit over [1e-4, 1e-1])"
            try:
                b, sb, _, c, sc = fit_power_law_corrected(curve.dphi, series[name])
                line += f"; with correction (1 + c dphi): {b:.4f} ± {sb:.4f}, "
                line += f"c = {c:.2f} ± {sc:.2f}"
            except ValueError:
                pass
            typer.echo(line)
        typer.echo(f"wrote {out}" + (f" and {csv}" if csv else ""))
        if not curve.converged.all():
            typer.echo("jamlab: some minimisations did not converge (see CSV)", err=True)
            raise typer.Exit(1)
