"""``jamlab reproduce``: the paper's figures and numbers in one report (``docs/reproduce.md``)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from jamlab.cli._options import Force

SeedOption = Annotated[int | None, typer.Option("--seed", help="Master seed (default 0).")]
SizesOption = Annotated[
    str,
    typer.Option(
        "--sizes",
        help="Diameters of every ensemble: mono (the paper's), bidisperse or polydisperse[:w].",
    ),
]
AlphaOption = Annotated[
    float, typer.Option("--alpha", help="Pair exponent, V = (1 - r/sigma)^alpha (paper: 2).")
]


def _scale(name: str, seed: int | None, sizes: str, alpha: float):
    """The scale ``name`` with the master seed and pair law of ``--seed``, ``--sizes`` and
    ``--alpha`` (one rule for ``reproduce`` and ``figure``)."""
    from jamlab.reproduce import SCALES, with_seed
    from jamlab.reproduce.scales import with_pair_law

    if name not in SCALES:
        raise ValueError(f"unknown scale {name!r}: valid scales are {', '.join(SCALES)}")
    chosen = SCALES[name] if seed is None else with_seed(SCALES[name], seed)
    if sizes != "mono" or alpha != 2.0:
        chosen = with_pair_law(chosen, sizes, alpha)
    return chosen


def reproduce_command(
    out: Annotated[Path, typer.Option("--out", help="Report directory (index.html, report.md).")],
    scale: Annotated[
        str,
        typer.Option(
            "--scale",
            help="quick (< 30 min on 2 cores), medium (~10 h on 2 cores, projected), "
            "paper (a cluster), tiny.",
        ),
    ] = "quick",
    runs: Annotated[
        Path | None,
        typer.Option("--runs", help="Where the run directories live (default OUT/runs)."),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option("--workers",
                     help="Local worker processes (default: the usable cores; 0 = here)."),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="Address of a running dask scheduler, tcp://HOST:8786."),
    ] = None,
    seed: SeedOption = None,
    sizes: SizesOption = "mono",
    alpha: AlphaOption = 2.0,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress messages.")] = False,
    force: Annotated[
        bool,
        typer.Option("--force", help="Replace report files in --out that an earlier "
                     "`jamlab reproduce` did not write (its own are always updated)."),
    ] = False,
) -> None:
    """Run (or resume) the ensembles of a scale, make every figure and write the report with the
    table quantity | paper | ours ± uncertainty | samples | verdict."""
    from jamlab.reproduce import NoSamplesError, reproduce
    from jamlab.runs import Execution

    chosen = _scale(scale, seed, sizes, alpha)
    execution = Execution(workers=workers, scheduler=scheduler)
    log = None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    try:
        result = reproduce(chosen, out, runs=runs, execution=execution, log=log, force=force)
    except NoSamplesError as exc:  # a computation that failed, not bad input: exit code 1
        typer.echo(f"jamlab: error: {exc}", err=True)
        raise typer.Exit(1) from None
    failed = sum(r["failed"] for r in result.data.get("runs", {}).values())
    typer.echo(f"wrote {result.paths['html']} and {result.paths['markdown']} "
               f"in {result.seconds:.0f} s ({len(result.rows)} rows, "
               f"{len(result.figures)} figures, {failed} failed samples)")


def figure_command(
    name: Annotated[str, typer.Argument(
        help="fig1 … fig7, fig3_exact, theory_vs_cascade, criticality, finite_size or "
             "tau_pressure.")],
    out: Annotated[Path, typer.Option("--out", help="Output PNG file.")],
    runs: Annotated[
        Path | None,
        typer.Option("--runs", help="Run directories of `jamlab reproduce` (its OUT/runs)."),
    ] = None,
    scale: Annotated[str, typer.Option("--scale", help="Scale the runs were made with.")] = (
        "quick"
    ),
    seed: SeedOption = None,
    sizes: SizesOption = "mono",
    alpha: AlphaOption = 2.0,
    force: Force = False,
) -> None:
    """Make one figure of the report from existing runs (figs. 1-3 and theory_vs_cascade need
    none: they are computed). Give the --scale, --seed, --sizes and --alpha the runs were made
    with (those of their jamlab reproduce)."""
    from jamlab.files import check_outputs
    from jamlab.reproduce import COMPUTED_PARTS, FIGURE_PART, make_figure

    check_outputs({"--out": out}, force=force, figures=("--out",))
    if name in ("fig4", "fig5", "fig6", "fig7") and runs is None:
        raise ValueError(f"{name} needs --runs (the runs/ directory of a `jamlab reproduce`)")
    if name not in FIGURE_PART:
        raise ValueError(f"unknown figure {name!r}: valid figures are {', '.join(FIGURE_PART)}")
    if runs is not None and FIGURE_PART[name] in COMPUTED_PARTS:
        raise ValueError(f"{name} is computed, it reads no runs: drop --runs")
    if runs is not None and not runs.is_dir():
        raise ValueError(f"--runs {runs} is not a directory (the runs/ of a `jamlab reproduce`)")
    chosen = _scale(scale, seed, sizes, alpha)  # those the runs were made with
    path = make_figure(name, chosen, runs if runs is not None else Path("."), out)
    typer.echo(f"wrote {path}")


def register(app: typer.Typer) -> None:
    """Add ``reproduce`` and ``figure``."""
    app.command("reproduce")(reproduce_command)
    app.command("figure")(figure_command)
