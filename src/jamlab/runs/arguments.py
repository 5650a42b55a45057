"""The analysis scripts' shared arguments: run directories, the N of each (``--n``) and where
a figure may go (``--figure``).

Every script in ``scripts/`` that reads finished runs takes them the same way: run directories
as positional arguments and ``--n`` with one size for all of them or one per run (runs of
different N side by side). The convention lives here once; scripts cannot import each other.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any


def add_run_arguments(parser: argparse.ArgumentParser, *, default_n: int | None = None) -> None:
    """Add ``runs`` (one or more directories) and ``--n`` (required unless ``default_n``)."""
    parser.add_argument("runs", type=Path, nargs="+")
    needed = {"required": True} if default_n is None else {"default": [default_n]}
    parser.add_argument("--n", type=int, nargs="+",
                        help="N of the runs: one for all, or one per run", **needed)


def sizes_per_run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> list[int]:
    """One N per run from ``args.n``: the one size repeated, or the sizes as given.

    Any other count is the parser's error (one line, exit code 2)."""
    runs, sizes = len(args.runs), list(args.n)
    if len(sizes) not in (1, runs):
        parser.error(f"--n takes one size or one per run ({runs}), got {len(sizes)}")
    return sizes * runs if len(sizes) == 1 else sizes


def check_figure_path(parser: argparse.ArgumentParser, figure: Path | None,
                      runs: list[Path]) -> None:
    """A script's ``--figure`` (None: no figure): it must end in ``.png``, ``.pdf`` or ``.svg``
    and lie outside every run directory read (a figure is never written into a run); else the
    parser's error (one line, exit code 2)."""
    if figure is None:
        return
    if figure.suffix not in (".png", ".pdf", ".svg"):
        parser.error(f"--figure must end in .png, .pdf or .svg, got {figure}")
    inside = [r for r in runs if figure.resolve().is_relative_to(r.resolve())]
    if inside:
        parser.error(f"--figure {figure} is inside the run directory {inside[0]}")


def open_study(parser: argparse.ArgumentParser, path: Path) -> tuple[Any, Any]:
    """The run directory ``path`` opened (:func:`jamlab.runs.open_run`) and its
    :class:`jamlab.runs.Study`; where it is not a run directory, the parser's error (one line,
    exit code 2)."""
    from jamlab.runs.load import open_run
    from jamlab.runs.study import Study

    try:
        ds = open_run(path)
    except (OSError, ValueError) as err:
        parser.error(f"{path}: not a run directory ({err})")
    return ds, Study.from_dict(json.loads(ds.attrs["study"]))


def open_pressure_run(parser: argparse.ArgumentParser, path: Path) -> tuple[Any, float, int]:
    """:func:`open_study` for a fixed-pressure study of one N: the run, its pressure and its N;
    any other study is the parser's error (one line, exit code 2)."""
    ds, study = open_study(parser, path)
    if study.pressure is None or len(study.n) != 1:
        parser.error(f"{path}: not a fixed-pressure study of one N (pressure {study.pressure}, "
                     f"N = {list(study.n)})")
    return ds, study.pressure, int(study.n[0])
