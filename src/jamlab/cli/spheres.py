"""``jamlab inspect``, ``jamlab minimize``, ``jamlab random-packing``, ``jamlab import-xyz``.

A thin face over :mod:`jamlab.spheres`; the configuration file format is in ``docs/formats.md``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from jamlab import validation
from jamlab.cli._options import Force
from jamlab.summary import SUMMARY_KEYS, compute_summary, stored_summary

INSPECT_KEYS = SUMMARY_KEYS
"""What ``jamlab inspect`` prints (:data:`jamlab.summary.SUMMARY_KEYS`)."""


def inspect_packing(path: Path) -> dict[str, float | int]:
    """The numbers ``jamlab inspect`` prints (keys :data:`INSPECT_KEYS`): the summary stored in
    the file when it is valid for its contents and the current code (:mod:`jamlab.summary`),
    else computed."""
    stored = stored_summary(path)
    if stored is not None:
        return stored
    from jamlab.spheres.io import read_packing

    return compute_summary(read_packing(path))


ORDER_KEYS = ("q6", "crystalline_fraction")
"""What ``jamlab inspect --order`` adds."""


def bond_order_summary(path: Path) -> dict[str, float]:
    """``Q_6`` and ten Wolde's crystalline fraction of the configuration at ``path``, with the
    first shell (``r < 1.3 σ_ij``) as bonds — the report's order check
    (:data:`jamlab.reproduce.amorphous.ORDER_CUTOFF`)."""
    from jamlab.analysis.order import bond_order
    from jamlab.reproduce.amorphous import ORDER_CUTOFF
    from jamlab.spheres.io import read_packing

    p = read_packing(path)
    if p.dim != 3:
        raise ValueError(f"--order needs a 3D configuration ({path} is {p.dim}D)")
    o = bond_order(p.positions, p.box.length, p.box.strain, p.diameters, ORDER_CUTOFF)
    return {"q6": o.global_q, "crystalline_fraction": o.crystalline_fraction}


def register(app: typer.Typer) -> None:
    """Add the soft-sphere commands."""

    @app.command("inspect", help="Print N, d, phi, strain, energy, stress, pressure, z, z_nr.")
    def inspect_command(
        config: Annotated[Path, typer.Argument(help="Configuration file (HDF5, docs/formats.md).")],
        as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
        order: Annotated[bool, typer.Option(
            "--order", help="Also the bond order (3D): Steinhardt's Q_6 and ten Wolde's "
            "crystalline fraction, first shell r < 1.3 σ_ij as bonds (docs/analysis.md §7).",
        )] = False,
    ) -> None:
        from jamlab.cli import warn_if_flagged

        info = inspect_packing(config)
        warn_if_flagged(config)
        if order:
            info = info | bond_order_summary(config)
        if as_json:
            typer.echo(json.dumps(info))
            return
        typer.echo(
            f"{config}: N={info['n']} d={info['dim']} phi={info['phi']:.10g} "
            f"strain={info['strain']!r}"
        )
        keys = INSPECT_KEYS[4:] + (ORDER_KEYS if order else ())
        width = max(len(k) for k in keys)
        for key in keys:
            value = info[key]
            text = f"{value!r}" if isinstance(value, float) else str(value)
            typer.echo(f"  {key:<{width}}  {text}")

    @app.command("minimize", help="Minimise the energy with FIRE 2.0 at fixed box and strain.")
    def minimize_command(
        config: Annotated[Path, typer.Argument(help="Configuration file (HDF5).")],
        out: Annotated[
            Path, typer.Option("--out", help="Where to write the minimised configuration.")
        ],
        ftol: Annotated[
            float, typer.Option("--ftol", help="Stop when max_i |F_i| < ftol.")
        ] = 1e-12,
        max_iter: Annotated[
            int, typer.Option("--max-iter", help="Largest number of steps.")
        ] = 1_000_000,
        force: Force = False,
    ) -> None:
        from jamlab.files import check_outputs
        from jamlab.provenance import provenance_json
        from jamlab.spheres.fire import minimize, polish_reading
        from jamlab.spheres.io import read_packing, write_packing
        from jamlab.spheres.potential import max_force

        validation.positive("--ftol", ftol)
        validation.integer("--max-iter", max_iter, minimum=0, maximum=validation.MAX_ITER)
        if not config.is_file():
            raise FileNotFoundError(f"no such configuration file: {config}")
        check_outputs({"--out": out}, {"configuration": config}, force=force, hdf5=("--out",))
        packing = read_packing(config)
        result = minimize(packing, ftol=ftol, max_iter=max_iter)
        if result.converged:  # converged as the written file reads (fire.polish_reading)
            result = polish_reading(result, max_force(result.packing), max_iter)[0]
        write_packing(
            out,
            result.packing,
            minimize_converged=int(result.converged),
            minimize_iterations=result.iterations,
            minimize_max_force=result.max_force,
            minimize_ftol=ftol,
            provenance=provenance_json(),
        )
        status = "converged" if result.converged else "NOT CONVERGED"
        typer.echo(
            f"{status}: {result.iterations} iterations, max|F_i| = {result.max_force:.3e} "
            f"(ftol {ftol:g}), energy = {result.energy!r}, time = {result.time:.3f} s -> {out}"
        )
        if not result.converged:
            raise typer.Exit(1)

    @app.command("random-packing", help="Write uniformly random positions at packing fraction phi.")
    def random_command(
        out: Annotated[Path, typer.Option("--out", help="Output configuration file (HDF5).")],
        n: Annotated[int, typer.Option("--n", help="Number of spheres (>= 2).")],
        phi: Annotated[float, typer.Option("--phi", help="Packing fraction N v_d(1/2)/L^d (> 0).")],
        dim: Annotated[int, typer.Option("--dim", help="Dimension (2 to 64).")] = 3,
        seed: Annotated[int, typer.Option("--seed", help="Seed of numpy.random.default_rng.")] = 0,
        force: Force = False,
    ) -> None:
        import jamlab.spheres as sp
        from jamlab.files import check_outputs
        from jamlab.spheres.io import write_packing

        validation.integer("--n", n, minimum=2)
        validation.dimension("--dim", dim)
        validation.seed("--seed", seed)
        validation.packing_fraction("--phi", phi)
        check_outputs({"--out": out}, force=force, hdf5=("--out",))
        packing = sp.random_packing(n, dim, phi, seed)
        write_packing(out, packing)
        typer.echo(f"N={n} d={dim} phi={phi} L={packing.box.length!r} seed={seed} -> {out}")

    @app.command(
        "import-xyz",
        help="Convert a text file of positions (one sphere per line, '#' comments; e.g. the "
        "LAMMPS reference positions.txt) to a configuration file.",
    )
    def import_command(
        positions: Annotated[Path, typer.Argument(help="Text file of positions.")],
        out: Annotated[Path, typer.Option("--out", help="Output configuration file (HDF5).")],
        box_length: Annotated[
            float | None,
            typer.Option("--box-length", help="Box side L (default: meta.json beside it)."),
        ] = None,
        strain: Annotated[
            float, typer.Option("--strain", help="Accumulated strain of the positions.")
        ] = 0.0,
        force: Force = False,
    ) -> None:
        from jamlab.files import check_outputs
        from jamlab.spheres.io import positions_meta, read_lammps_positions, write_packing

        if box_length is not None:
            validation.positive("--box-length", box_length)
        validation.strain("--strain", strain)
        if not positions.is_file():
            raise FileNotFoundError(f"no such positions file: {positions}")
        meta = positions_meta(positions, box_length)
        check_outputs(
            {"--out": out}, {"positions file": positions, "meta.json": meta}, force=force,
            hdf5=("--out",),
        )
        packing = read_lammps_positions(positions, box_length=box_length, strain=strain)
        write_packing(out, packing)
        typer.echo(f"N={packing.n} d={packing.dim} phi={packing.phi:.10g} -> {out}")
