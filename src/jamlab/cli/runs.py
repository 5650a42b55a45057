"""``jamlab run`` and ``jamlab status``: a thin face over :mod:`jamlab.runs` (``docs/runs.md``)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from jamlab.cli import multivalue

_MULTI_VALUE_OPTIONS = ("--phi", "--n")


def expand_multi_values(
    args: list[str], options: tuple[str, ...] = _MULTI_VALUE_OPTIONS
) -> list[str]:
    """Rewrite ``--phi a b c`` as ``--phi a --phi b --phi c`` (click options take one value):
    :func:`jamlab.cli.multivalue.expand_multi_values` with ``jamlab run``'s options."""
    return multivalue.expand_multi_values(args, options)


_MultiValueCommand = multivalue.multi_value_command(_MULTI_VALUE_OPTIONS)
"""A command whose ``--phi`` and ``--n`` accept several space-separated values."""


def _progress(quiet: bool):  # -> factory for run_study(progress=...)
    if quiet:
        return None

    def factory(total: int, skipped: int):
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        progress = Progress(
            TextColumn("samples"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("failed {task.fields[failed]}"),
            TextColumn("({task.fields[skipped]} already done)"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=Console(stderr=True),
            transient=False,
        )
        task_id = progress.add_task("run", total=total, failed=0, skipped=skipped)
        progress.start()
        failed = 0
        finished = 0
        if total == 0:
            progress.stop()

        def callback(key, outcome) -> None:
            nonlocal failed, finished
            from jamlab.runs import SampleFailure

            finished += 1
            if isinstance(outcome, SampleFailure):
                failed += 1
            progress.update(task_id, advance=1, failed=failed)
            if finished == total:
                progress.stop()

        return callback

    return factory


def cost_lines(costs: list[Any]) -> list[str]:
    """`jamlab status`'s cost lines, one per (φ, N) cell (:func:`jamlab.runs.cost.cell_costs`):
    the mean CPU time of a finished sample and the projection of what is left."""
    lines = []
    for c in costs:
        head = f"cpu phi={c.phi} N={c.n}: "
        if c.mean is None:
            timed = "no finished sample records its CPU time"
        else:
            timed = (
                f"{c.mean:,.0f} s per finished sample ({len(c.seconds)} timed of {c.done}; "
                f"{min(c.seconds):,.0f}–{max(c.seconds):,.0f} s)"
            )
        if c.to_do == 0:
            left = "nothing left"
        elif c.left is None:
            left = f"{c.to_do:.1f} samples' worth left, cost unknown"
        else:
            left = f"left ≈ {c.left / 3600:.2f} CPU-h ({c.to_do:.1f} samples' worth)"
        spent = ""
        if c.failures:
            timed_failures = (f"{sum(c.failed_seconds) / 3600:.2f} CPU-h in the "
                              f"{len(c.failed_seconds)} that record it" if c.failed_seconds
                              else "their CPU time not recorded")
            spent = f"; {c.failures} failed attempt(s), {timed_failures}"
        lines.append(head + timed + "; " + left + spent)
    return lines


def register(app: typer.Typer) -> None:
    """Add ``run`` and ``status``."""

    @app.command(
        "run",
        cls=_MultiValueCommand,
        help=(
            "Run or resume an ensemble: every (phi, N, sample) is prepared and sheared (AQS). "
            "Parameters come from options or a TOML study file (options override it). Running "
            "the same command again skips finished samples and redoes partial or failed ones."
        ),
    )
    def run_command(
        study_file: Annotated[
            Path | None, typer.Argument(help="TOML study file (see examples/study.toml).")
        ] = None,
        phi: Annotated[
            list[str] | None,
            typer.Option(
                "--phi", help="Packing fractions and/or 'jamming', e.g. --phi jamming 0.75 0.8."
            ),
        ] = None,
        n: Annotated[
            list[str] | None, typer.Option("--n", help="Particle numbers, e.g. --n 500 1000.")
        ] = None,
        samples: str | None = typer.Option(None, "--samples", help="Samples per (phi, N)."),
        dgamma: str | None = typer.Option(None, "--dgamma", help="AQS strain step."),
        gamma_max: str | None = typer.Option(None, "--gamma-max", help="Final strain."),
        out: str | None = typer.Option(None, "--out", help="Run directory."),
        seed: str | None = typer.Option(None, "--seed", help="Master seed (default 0)."),
        dim: str | None = typer.Option(None, "--dim", help="Space dimension (default 3)."),
        p_target: str | None = typer.Option(
            None, "--p-target", help="Jamming protocol's target pressure (default 1e-7)."
        ),
        force_tol: str | None = typer.Option(
            None, "--force-tol", help="FIRE tolerance, max |F_i| (default 1e-12)."
        ),
        sizes: str | None = typer.Option(
            None,
            "--sizes",
            help="Diameters: mono (default), bidisperse (1:1.4) or polydisperse[:w].",
        ),
        alpha: str | None = typer.Option(
            None, "--alpha", help="Pair exponent, V = (1 - r/sigma)^alpha (default 2)."
        ),
        pressure: str | None = typer.Option(
            None,
            "--pressure",
            help="AQS at this fixed pressure (default: constant volume, the paper's protocol).",
        ),
        floppy: str | None = typer.Option(
            None,
            "--floppy",
            help="Constant volume: a step from an unjammed minimum by 'fire' (default) or "
            "'project' (the overlap-free configuration nearest to the affine start; docs/aqs.md).",
        ),
        volume_guess: str | None = typer.Option(
            None,
            "--volume-guess",
            help="Fixed pressure: where each step starts its box side — 'elastic' (default: "
            "extrapolated across elastic steps only), 'always' (the rule of runs made before "
            "the option; resumes them) or 'never' (docs/aqs.md).",
        ),
        checkpoint_every: str | None = typer.Option(
            None,
            "--checkpoint-every",
            help="Save each sample's shear every K steps in RUN/checkpoints/, so that an "
            "interrupted sample resumes from its last save (default 0: off; part of the study; "
            "docs/runs.md).",
        ),
        task: str | None = typer.Option(None, "--task", hidden=True),
        workers: int | None = typer.Option(
            None, "--workers",
            help="Local worker processes (default: the usable cores; 0 = in-process).",
        ),
        scheduler: str | None = typer.Option(
            None, "--scheduler", help="Address of a running dask scheduler, tcp://HOST:8786."
        ),
        cluster: str | None = typer.Option(
            None, "--cluster", help="Start a cluster for the run: 'slurm' (dask-jobqueue)."
        ),
        slurm_jobs: int | None = typer.Option(None, "--slurm-jobs", help="SLURM jobs (default 1)."),
        slurm_cores: int | None = typer.Option(None, "--slurm-cores", help="Cores per job."),
        slurm_processes: int | None = typer.Option(
            None, "--slurm-processes", help="Dask worker processes per job."
        ),
        slurm_memory: str | None = typer.Option(None, "--slurm-memory", help="Memory per job."),
        slurm_walltime: str | None = typer.Option(None, "--slurm-walltime", help="HH:MM:SS."),
        slurm_queue: str | None = typer.Option(None, "--slurm-queue", help="Partition."),
        slurm_account: str | None = typer.Option(None, "--slurm-account", help="Account."),
        slurm_directive: Annotated[
            list[str] | None,
            typer.Option("--slurm-directive", help="Extra #SBATCH directive (repeatable)."),
        ] = None,
        retry_failed: bool = typer.Option(
            True, "--retry-failed/--skip-failed", help="Redo samples recorded as failed."
        ),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar or summary."),
    ) -> None:
        from jamlab.runs import Execution, Study, load_toml, run_study
        from jamlab.runs.study import merge

        params: dict[str, Any] = {}
        execution: dict[str, Any] = {}
        if study_file is not None:
            params, toml_out, execution = load_toml(study_file)
            out = out if out is not None else toml_out
        params = merge(
            params,
            [
                ("phi", phi or None),
                ("n", n or None),
                ("samples", samples),
                ("dgamma", dgamma),
                ("gamma_max", gamma_max),
                ("seed", seed),
                ("dim", dim),
                ("p_target", p_target),
                ("force_tol", force_tol),
                ("sizes", sizes),
                ("alpha", alpha),
                ("pressure", pressure),
                ("floppy", floppy),
                ("volume_guess", volume_guess),
                ("checkpoint_every", checkpoint_every),
                ("task", task),
            ],
        )
        study = Study.from_dict(params)
        if params.get("p_target") is not None and "jamming" not in study.phi:
            raise ValueError("p_target applies to phi 'jamming' (the jamming protocol's target "
                             "pressure), and the study has none")
        if out is None:
            raise ValueError("no run directory: give --out DIR (or 'out' in the study file)")
        # (the [slurm] key, the option, its value): merged into the study file's table, and
        # named when one is given without --cluster slurm
        slurm_options = (
            ("jobs", "--slurm-jobs", slurm_jobs),
            ("cores", "--slurm-cores", slurm_cores),
            ("processes", "--slurm-processes", slurm_processes),
            ("memory", "--slurm-memory", slurm_memory),
            ("walltime", "--slurm-walltime", slurm_walltime),
            ("queue", "--slurm-queue", slurm_queue),
            ("account", "--slurm-account", slurm_account),
            ("job_extra_directives", "--slurm-directive", slurm_directive or None),
        )
        slurm = dict(execution.pop("slurm", {}) or {})
        slurm = merge(slurm, [(key, value) for key, _, value in slurm_options])
        exec_params = merge(
            execution, [("workers", workers), ("scheduler", scheduler), ("cluster", cluster)]
        )
        quiet = quiet or bool(exec_params.pop("quiet", False))
        unknown = sorted(set(exec_params) - {"workers", "scheduler", "cluster"})
        if unknown:
            raise ValueError(f"unknown [execution] option(s): {', '.join(unknown)}")
        ex = Execution(slurm=slurm, **exec_params)  # checks the values first
        given = [option for _, option, value in slurm_options if value is not None]
        if given and ex.cluster != "slurm":
            raise ValueError(f"{given[0]} applies with --cluster slurm only")
        if workers is not None and ex.scheduler is not None:
            raise ValueError("--workers applies to local processes or --cluster, not to a "
                             "running --scheduler (its workers are its own)")
        log = None if quiet else (lambda msg: print(msg, file=sys.stderr))
        summary = run_study(
            study, out, ex, retry_failed=retry_failed, progress=_progress(quiet), log=log
        )
        if not quiet:
            print(
                f"{summary.done} samples written"
                + (f" ({summary.resumed} resumed from a checkpoint)" if summary.resumed else "")
                + f", {summary.failed} failed, "
                f"{summary.skipped} already done, in {summary.seconds:.1f} s",
                file=sys.stderr,
            )
            for key, message in summary.failures[:5]:
                print(
                    f"  failed phi={key.phi_label} N={key.n} sample={key.index}: {message}",
                    file=sys.stderr,
                )
        if summary.failed:
            raise typer.Exit(1)

    @app.command("status", help="Done / failed / pending samples per (phi, N) of a run directory.")
    def status_command(
        run_dir: Annotated[Path, typer.Argument(help="Run directory.")],
        failures: bool = typer.Option(False, "--failures", help="List the failed samples' errors."),
    ) -> None:
        from rich.console import Console
        from rich.table import Table

        from jamlab.runs import RunDir
        from jamlab.runs.cost import cell_costs
        from jamlab.runs.flag_rule import FLAG_RULE_ATTRS, flag_rule_lines
        from jamlab.runs.origin import census_lines, machine_census
        from jamlab.runs.physics import resume_step

        run = RunDir(run_dir)
        study = run.study()
        # one pass over the sample files, each opened once: the table, the costs, the machines
        states, attrs = run.survey(study, ("cpu_seconds", "provenance", *FLAG_RULE_ATTRS))
        counts = run.summary(study, states)
        table = Table(title=f"{run_dir}  (seed {study.seed}, {study.samples} samples per cell)")
        for column in ("phi", "N", "done", "failed", "corrupt", "pending"):
            table.add_column(column, justify="left" if column == "phi" else "right")
        totals = dict.fromkeys(("done", "failed", "corrupt", "pending"), 0)
        for (label, n_value), c in counts.items():
            table.add_row(label, str(n_value), *(str(c[s]) for s in totals))
            for s in totals:
                totals[s] += c[s]
        table.add_row("all", "", *(str(v) for v in totals.values()), style="bold")
        console = Console()
        console.print(table)
        past = {key: run.failures(key) for key in study.keys()}  # read once, used thrice
        # each unfinished sample's checkpoint judged once (as jamlab run will), used twice
        steps = {key: resume_step(run, key, study) for key in study.keys()
                 if study.checkpoint_every and states[key] != "done"}
        for line in cost_lines(cell_costs(run, study, states, attrs, past, steps)):
            console.print(line, markup=False, soft_wrap=True)
        for line in census_lines(machine_census(run, study, states, attrs=attrs)):
            console.print(line, markup=False, soft_wrap=True)
        for line in flag_rule_lines(study, attrs):
            console.print(line, markup=False, soft_wrap=True)
        if study.checkpoint_every:
            for key in study.keys():
                if states[key] == "done" or (step := steps[key]) is None:
                    continue
                # the verdict jamlab run acts on: a damaged or foreign checkpoint is replaced
                where = ("damaged or not this sample's, will be redone from the start" if step < 0
                         else f"at step {step} of {study.n_steps}")
                console.print(f"checkpoint phi={key.phi_label} N={key.n} sample={key.index}: "
                              f"{where}", markup=False, soft_wrap=True)
        for key in study.keys():
            # a finished sample that failed before says so (its failures are kept)
            if states[key] == "done" and past[key]:
                console.print(f"phi={key.phi_label} N={key.n} sample={key.index}: done on a retry "
                              f"after {len(past[key])} failure(s); {_failure_text(past[key][-1])}",
                              markup=False, soft_wrap=True)
        if failures:
            for key in study.keys():
                if states[key] == "failed":
                    again = f" (failed {len(past[key])} times)" if len(past[key]) > 1 else ""
                    console.print(f"phi={key.phi_label} N={key.n} sample={key.index}{again}: "
                                  f"{_failure_text(past[key][-1])}", markup=False, soft_wrap=True)


def _failure_text(record: dict[str, Any]) -> str:
    """A failure record in one line: the error, when, and on which CPU if it was recorded."""
    where = (record.get("machine") or {}).get("cpu")
    when = record.get("time", "time not recorded") + (f", {where}" if where else "")
    return f"{record.get('error_type', '?')}: {record.get('message', '')} ({when})"
