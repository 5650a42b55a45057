"""``jamlab shear``: athermal quasi-static shear of a configuration, writing the AQS trace.

A thin face over :func:`jamlab.spheres.aqs.shear`; the trace format is in ``docs/formats.md``
("AQS trace"), the method and the elastic/plastic rule in ``docs/aqs.md``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from jamlab.cli._options import Force


def check_resume(
    previous: Any, packing: Any, *, dgamma: float, ftol: float, minimizer: str
) -> None:
    """``ValueError`` unless the run being resumed (trace ``previous``) was made from the
    configuration ``packing`` with the same ``dgamma``, ``ftol`` and ``minimizer``: a resumed
    trace is one run, and its attributes describe all of it."""
    attrs = previous.attrs
    for name, given in (("dgamma", dgamma), ("ftol", ftol), ("minimizer", minimizer)):
        if attrs.get(name) != given:
            raise ValueError(
                f"--{name} {given} differs from the run being resumed ({attrs.get(name)})"
            )
    recorded = {
        "N": attrs.get("N"),
        "dim": attrs.get("dim"),
        "box_length": attrs.get("box_length"),
        "seed": attrs.get("seed"),
        "strain": float(previous.gamma[0]),
    }
    given_values = {
        "N": packing.n,
        "dim": packing.dim,
        "box_length": float(packing.box.length),
        "seed": -1 if packing.seed is None else packing.seed,
        "strain": packing.strain,
    }
    differ = [k for k in recorded if recorded[k] != given_values[k]]
    if not differ and int(previous.iterations[0]) == 0:
        # the input was already a minimum: row 0 is its energy
        import jamlab.spheres as sp

        energy = sp.energy(packing, sp.NeighborList(packing, skin=0.0))
        if not math.isclose(energy, float(previous.energy[0]), rel_tol=1e-12, abs_tol=1e-300):
            differ.append("energy")
    if differ:
        raise ValueError(
            "the configuration is not the one the run being resumed started from "
            f"(different {', '.join(differ)})"
        )


def check_resume_pressure(
    previous: Any, packing: Any, *, dgamma: float, ftol: float, pressure: float, ptol: float,
    minimizer: str = "linear", confirm: str = "located", volume_guess: str | None = None,
) -> None:
    """:func:`check_resume` for a fixed-pressure run (``--pressure``): the same ``dgamma``,
    ``ftol``, target pressure, ``ptol`` and minimiser (``linear``: the Newton inner minimiser,
    recorded as ``enthalpy-nested-newton``; ``fire``: ``enthalpy-nested-fire``), the same
    ``confirm`` rule of the plastic flag (a trace without the attribute used ``chain``) and
    ``volume_guess`` (without the attribute: ``always``), and an
    input with the same N, d, seed, strain and box side (attribute ``input_box_length``: row 0 is
    already at the target pressure)."""
    from jamlab import validation
    from jamlab.spheres.pressure_shear import FROM_AQS_OPTION, RULES_BEFORE, minimizer_attribute

    attrs = previous.attrs
    if attrs.get("protocol") != "fixed-pressure":
        raise ValueError("--pressure given, but the run being resumed is at constant volume")
    for name, key, given in (("dgamma", "dgamma", dgamma), ("ftol", "ftol", ftol),
                             ("pressure", "pressure_target", pressure), ("ptol", "ptol", ptol),
                             ("minimizer", "minimizer",
                              minimizer_attribute(FROM_AQS_OPTION[minimizer])),
                             ("confirm", "confirm", confirm),
                             ("volume-guess", "volume_guess",
                              volume_guess or validation.DEFAULT_VOLUME_GUESS)):
        recorded = attrs.get(key, RULES_BEFORE.get(key))
        if recorded != given:
            raise ValueError(f"--{name} {given} differs from the run being resumed ({recorded})")
    recorded = (attrs.get("N"), attrs.get("dim"), attrs.get("seed"), float(previous.gamma[0]),
                attrs.get("input_box_length"))
    given_values = (packing.n, packing.dim, -1 if packing.seed is None else packing.seed,
                    packing.strain, float(packing.box.length))
    names = ("N", "dim", "seed", "strain", "box length")
    differ = [k for k, a, b in zip(names, recorded, given_values, strict=True) if a != b]
    if differ:
        raise ValueError(
            "the configuration is not the one the run being resumed started from "
            f"(different {', '.join(differ)})"
        )


def resume_save_every(previous: Any, save_every: int | None) -> int | None:
    """The ``--save-every`` of a resumed run: the one the trace was made with (attribute
    ``save_every``, 0 for none; older traces have none and take any). Its save points are the
    run's restart points (docs/aqs.md), so continuing with another would make the resumed run
    differ from the uninterrupted one while the attributes claimed one value for all of it."""
    recorded = previous.attrs.get("save_every")
    if recorded is None:
        return save_every
    recorded = int(recorded)
    if save_every is None:
        return recorded or None
    if save_every != recorded:
        raise ValueError(
            f"--save-every {save_every} differs from the run being resumed "
            f"({recorded or 'none'}); omit it to keep the run's"
        )
    return save_every


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
                "--minimizer",
                help="'linear' (linear response + Newton, FIRE fallback; at fixed pressure the "
                "Newton inner minimiser) or 'fire'.",
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
        keep_avalanches: Annotated[
            bool,
            typer.Option(
                "--keep-avalanches",
                help="Record the anatomy of every plastic step, elastic response subtracted "
                "(trace group 'avalanches'; docs/criticality.md).",
            ),
        ] = False,
        avalanche_threshold: Annotated[
            float | None,
            typer.Option(
                "--avalanche-threshold",
                help="With --keep-avalanches: keep the event displacements |u| above this "
                "(units of the mean diameter; default 1e-3).",
            ),
        ] = None,
        pressure: Annotated[
            float | None,
            typer.Option(
                "--pressure",
                help="Shear at this fixed pressure (box relaxed; docs/aqs.md) instead of at "
                "constant volume.",
            ),
        ] = None,
        ptol: Annotated[
            float | None,
            typer.Option("--ptol",
                         help="Relative pressure tolerance at fixed pressure (default 1e-6)."),
        ] = None,
        confirm: Annotated[
            str | None,
            typer.Option(
                "--confirm",
                help="At fixed pressure: which candidate plastic steps are redone in pieces — "
                "'located' (those Newton did not continue, each decided first on the piece "
                "where the branch ends; the default), 'continued' (the same candidates, each "
                "redone as a chain of pieces) or 'chain' (all candidates).",
            ),
        ] = None,
        floppy: Annotated[
            str,
            typer.Option(
                "--floppy",
                help="At constant volume: a step from an unjammed minimum by 'fire' (the usual "
                "strategies) or 'project' (the overlap-free configuration nearest to the affine "
                "start; docs/aqs.md).",
            ),
        ] = "fire",
        confirm_below: Annotated[
            float | None,
            typer.Option(
                "--confirm-below",
                help="At fixed pressure: a candidate step that released for certain more "
                "enthalpy than this many times max(the run's plastic threshold, dgamma^2) is a "
                "jump without being redone (default 5; 'inf' redoes every candidate; "
                "docs/aqs.md).",
            ),
        ] = None,
        volume_guess: Annotated[
            str | None,
            typer.Option(
                "--volume-guess",
                help="At fixed pressure: where each step starts its box side — 'elastic' "
                "(default: extrapolated across elastic steps only), 'always' (the rule of "
                "traces made before the option) or 'never' (docs/aqs.md).",
            ),
        ] = None,
        force: Force = False,
    ) -> None:
        from jamlab import validation
        from jamlab.cli import warn_if_flagged
        from jamlab.files import check_outputs
        from jamlab.spheres.aqs import (
            AQSParameters,
            checkpoint_paths,
            resume_configuration,
            shear,
        )
        from jamlab.spheres.aqs.checkpoint import (
            begin_replacement,
            foreign_snapshots,
            recover_replacement,
            snapshot_files,
        )
        from jamlab.spheres.io import read_packing
        from jamlab.spheres.trace import read_trace

        if minimizer not in ("linear", "fire"):
            raise ValueError(f"--minimizer must be 'linear' or 'fire', got {minimizer!r}")
        validation.floppy(floppy, "--floppy")
        if floppy != "fire" and (pressure is not None or minimizer != "linear"):
            raise ValueError("--floppy project applies to constant volume with --minimizer "
                             "linear (not with --pressure or plain FIRE)")
        validation.positive("--ftol", ftol)
        if avalanche_threshold is not None:
            if not keep_avalanches:
                raise ValueError("--avalanche-threshold applies to --keep-avalanches: give it too")
            validation.positive("--avalanche-threshold", avalanche_threshold)
        ptol = validation.pressure_tolerance(ptol, pressure, applies="fixed-pressure runs")
        if pressure is not None:
            validation.positive("--pressure", pressure)
        if confirm is not None and pressure is None:
            raise ValueError("--confirm applies to fixed-pressure runs: give --pressure too")
        if confirm is not None and confirm not in ("located", "continued", "chain"):
            raise ValueError(
                f"--confirm must be 'located', 'continued' or 'chain', got {confirm!r}")
        confirm = "located" if confirm is None else confirm
        if confirm_below is not None and pressure is None:
            raise ValueError("--confirm-below applies to fixed-pressure runs: give --pressure too")
        if confirm_below is not None and not confirm_below >= 1.0:
            raise ValueError(f"--confirm-below must be >= 1 (or inf), got {confirm_below!r}")
        if volume_guess is not None and pressure is None:
            raise ValueError("--volume-guess applies to fixed-pressure runs: give --pressure too")
        if pressure is not None:
            volume_guess = validation.volume_guess(
                volume_guess or validation.DEFAULT_VOLUME_GUESS, "--volume-guess")
        if save_every is not None:
            validation.integer("--save-every", save_every, minimum=1,
                               maximum=validation.MAX_STEPS)
        if not config.is_file():
            raise FileNotFoundError(f"no such configuration file: {config}")
        # a replacement of an earlier run killed inside the new run's first save: finished first
        recovered = recover_replacement(out)
        if recovered is not None:
            typer.echo(f"jamlab: note: {recovered}", err=True)
        last, snapshots = checkpoint_paths(out)
        outputs = {"--out": out, "--plot": plot}
        stale: list[Path] = []
        if resume:
            check_outputs(outputs, {"configuration": config}, force=force, continued=("--out",),
                          figures=("--plot",), hdf5=("--out",))
        else:
            outputs["checkpoint"] = last
            # the snapshots of an earlier run to --out would be read as this run's
            stale = snapshot_files(snapshots)
            check_outputs(
                outputs,
                {"configuration": config},
                directories={
                    "the snapshot directory": snapshots if save_every or stale else None
                },
                force=force,
                figures=("--plot",),
                hdf5=("--out", "checkpoint"),
            )
            foreign = foreign_snapshots(snapshots) if stale else []
            if foreign:  # never the earlier run's: --force would remove it with them
                raise ValueError(f"{foreign[0][1]}; move it out of {snapshots} (it is not a "
                                 "snapshot of an earlier run, and shear would remove it)")
            if stale and not force:
                raise ValueError(f"{snapshots} holds {len(stale)} snapshot(s) of an earlier "
                                 "run; give --force to remove them")
        previous = None
        if resume:
            if not out.is_file():
                raise FileNotFoundError(f"--resume needs {out} from an earlier run")
            previous = read_trace(out)
            packing = read_packing(config)
            if pressure is None:
                if previous.attrs.get("protocol") == "fixed-pressure":
                    raise ValueError("the run being resumed is at fixed pressure: give its "
                                     f"--pressure {previous.attrs.get('pressure_target')}")
                check_resume(previous, packing, dgamma=dgamma, ftol=ftol, minimizer=minimizer)
            else:
                check_resume_pressure(previous, packing, dgamma=dgamma, ftol=ftol,
                                      pressure=pressure, ptol=ptol, minimizer=minimizer,
                                      confirm=confirm, volume_guess=volume_guess)
            save_every = resume_save_every(previous, save_every)
            n_steps = validation.strain_steps(
                dgamma, gamma_max, float(previous.gamma[0]), names=("--dgamma", "--gamma-max")
            )
            packing = resume_configuration(out, previous)
        else:
            packing = read_packing(config)
            n_steps = validation.strain_steps(
                dgamma, gamma_max, packing.strain, names=("--dgamma", "--gamma-max")
            )
        warn_if_flagged(config)
        # only now, with every argument checked and the input read, is the earlier run's
        # replacement armed; it happens at the new run's first save (spheres.aqs.checkpoint):
        # until the new trace replaces --out, the earlier run stays whole with its snapshots
        if not resume and (stale or out.exists() or last.exists()):
            begin_replacement(out)
        try:
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
                keep_avalanches=keep_avalanches,
                avalanche_threshold=avalanche_threshold,
                pressure=pressure,
                ptol=ptol,
                confirm=confirm,
                confirm_below=confirm_below,
                volume_guess=volume_guess,
                params=None if pressure is not None else AQSParameters(floppy=floppy),
            )
        except BaseException:
            recover_replacement(out)  # failed before its first save: the earlier run is kept
            raise
        tr = result.trace
        protocol = minimizer if pressure is None else f"fixed p={pressure:g}"
        unjammed = "" if tr.jammed is None else f"{int((~tr.jammed).sum())} unjammed minima, "
        typer.echo(
            f"{tr.n_steps} steps of dγ={dgamma:g} to γ={tr.gamma[-1]:.6g} ({protocol}): "
            f"{unjammed}"
            f"{int(tr.plastic.sum())} plastic, {result.n_fallback} FIRE fallbacks, "
            f"{result.n_not_converged} not converged, {result.time:.2f} s -> {out}"
        )
        if plot is not None:
            from jamlab.plots.shear import stress_strain_figure

            stress_strain_figure(tr, plot)
            typer.echo(f"figure -> {plot}")
        if result.n_not_converged:
            # the trace is written (its rows say which minima are not converged); the run is not
            # reported as fine (as `jamlab minimize`)
            typer.echo(f"jamlab: {result.n_not_converged} step(s) did not converge "
                       f"(max|F_i| >= {ftol:g}{' or |p - p_t| > ptol' if pressure else ''})",
                       err=True)
            raise typer.Exit(1)
