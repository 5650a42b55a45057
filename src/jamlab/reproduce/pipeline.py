"""The reproduction pipeline: run the ensembles, compute each part, render the table and figures.

The analysis is split into parts (:data:`PARTS`, in report order of their rows). Each part
computes one typed result (:mod:`jamlab.reproduce.measurements`,
:mod:`jamlab.reproduce.coordination`, :mod:`jamlab.reproduce.theory_checks`), which
:mod:`jamlab.reproduce.table` renders as rows and JSON data and :mod:`jamlab.reproduce.figures`
as figures (:data:`FIGURE_PART` says which part each figure needs).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from jamlab.files import (
    RUN_MEMBERS,
    atomic_write_text,
    check_new_run_directory,
    removed_on_failure,
)
from jamlab.report import Figure, ReportMeta, Row, write_report
from jamlab.reproduce import amorphous, criticality_table, figures, moduli_table, table
from jamlab.reproduce.cache import exact_law_file, load_exact_law, save_exact_law
from jamlab.reproduce.coordination import coordination
from jamlab.reproduce.criticality import finite_size_scaling, packing_criticality
from jamlab.reproduce.ensembles import RunSet
from jamlab.reproduce.measurements import (
    moduli,
    one_trace,
    phi_j_estimate,
    pressure_tau_estimates,
    stress_strain,
    tau_estimates,
)
from jamlab.reproduce.pressure_moduli import pressure_moduli
from jamlab.reproduce.scales import Scale, get_scale, pressure_run_name, studies
from jamlab.reproduce.theory_checks import exact_law_checks, theory_checks

__all__ = ["COMPUTED_PARTS", "FIGURE_PART", "MARKER", "PARTS", "Part", "REPORT_FILES",
           "ReproduceResult", "check_report_directory", "make_figure", "reproduce"]

TITLE = "jamlab: reproduction of Franz & Spigler, Mean-field avalanches in jammed spheres"


class NoSamplesError(RuntimeError):
    """An ensemble of :func:`reproduce` in which every sample failed: there is nothing to
    analyse (the run directories keep the failures)."""


@dataclass
class ReproduceResult:
    """What :func:`reproduce` produced: the report files, table rows, figures and wall time."""

    out: Path
    paths: dict[str, Path]
    rows: list[Row]
    figures: list[Figure]
    seconds: float
    data: dict[str, Any]


class _Analysis:
    """What the parts share: scale, run directories, output places, and each part's result
    (computed once, on first use)."""

    def __init__(self, scale: Scale, runs: Path, out: Path, figdir: Path,
                 log: Callable[[str], None], ext: str = ".png") -> None:
        self.scale, self.runs, self.out, self.figdir, self.log, self.ext = (
            scale, RunSet(runs), out, figdir, log, ext)
        self._results: dict[str, Any] = {}

    def result(self, part: str) -> Any:
        """The typed result of ``part``."""
        if part not in self._results:
            self._results[part] = PARTS[part].compute(self)
        return self._results[part]


@dataclass(frozen=True)
class Part:
    """One part of the analysis: ``compute`` its typed result; ``render`` it as table rows and
    JSON data (None: the part only feeds figures)."""

    compute: Callable[[_Analysis], Any]
    render: Callable[[Any, Scale], tuple[list[Row], dict[str, Any]]] | None


def _avalanches(c: _Analysis) -> Any:
    est = tau_estimates(c.runs["jamming"], c.runs["unsat"], c.scale)
    for label, e in est.items():
        c.log(f"τ at {label}: {table.fit_text(e.fit, e.sigma)}, {e.n_avalanches} avalanches")
    return est


def _stress_strain_data(s: Any, scale: Scale) -> tuple[list[Row], dict[str, Any]]:
    return [], ({} if s is None else {"stress_strain": dict(samples=s.samples)})


def _criticality(c: _Analysis) -> Any:
    r = packing_criticality(c.runs["jamming"], c.runs.path / "jamming", c.scale)
    c.log(f"criticality of {sum(r.packings.values())} jamming packings ({r.seconds:.1f} s CPU)")
    return r, c.result("avalanches")["jamming"]


def _order(c: _Analysis) -> Any:
    r = amorphous.order_checks(c.runs, c.scale)
    c.log("bond order of " + ", ".join(f"{e.run} φ = {e.label}: {e.total[0]} of {e.total[1]} "
                                       "ordered" for e in r)
          + f" ({sum(e.seconds for e in r):.1f} s CPU)")
    return r


def _exact_law(c: _Analysis) -> Any:
    """:func:`exact_law_checks`, or its result stored by this code in ``OUT/data`` before
    (:mod:`jamlab.reproduce.cache`)."""
    path = exact_law_file(c.out / "data")
    if path.is_file():
        c.log(f"exact law: read from {path} (stored by this code)")
        return load_exact_law(path)
    result = exact_law_checks()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_exact_law(path, *result)
    return result


PARTS: dict[str, Part] = {
    "avalanches": Part(_avalanches, lambda r, s: (table.tau_rows(r), table.tau_data(r))),
    "pressure_tau": Part(lambda c: pressure_tau_estimates(c.runs, c.scale),
                         lambda r, s: (table.pressure_tau_rows(r), table.pressure_tau_data(r))),
    "phi_j": Part(lambda c: phi_j_estimate(c.runs["jamming"], c.scale),
                  lambda r, s: ([table.phi_j_row(r)], table.phi_j_data(r))),
    "moduli": Part(lambda c: moduli(c.runs["jamming"], c.runs["unsat"], c.scale),
                   lambda r, s: (moduli_table.moduli_rows(r, s),
                                 moduli_table.moduli_data(r))),
    "pressure_moduli": Part(lambda c: pressure_moduli(c.runs, c.scale),
                            lambda r, s: (moduli_table.pressure_moduli_rows(r),
                                          moduli_table.pressure_moduli_data(r))),
    "trace": Part(lambda c: one_trace(c.runs["jamming"], c.scale), None),
    "stress_strain": Part(lambda c: stress_strain(c.runs["stress-strain"], c.scale),
                          _stress_strain_data),
    "coordination": Part(lambda c: coordination(c.scale, c.out / "data", c.log),
                         lambda r, s: (table.coordination_rows(r, s),
                                       table.coordination_data(r))),
    # the exact law of μ_J and 0.5, built once for the exponent rows and the figure fig3_exact
    "exact_law": Part(_exact_law, None),
    "theory": Part(lambda c: theory_checks(c.scale, c.result("exact_law")[0]),
                   lambda r, s: (table.theory_rows(r, s) + table.exponent_rows(r),
                                 table.theory_data(r))),
    "criticality": Part(_criticality, lambda r, s: (criticality_table.criticality_rows(*r),
                                                    criticality_table.criticality_data(*r))),
    "finite_size": Part(lambda c: finite_size_scaling(c.runs["jamming"], c.runs["unsat"],
                                                      c.result("avalanches"), c.scale),
                        lambda r, s: (criticality_table.finite_size_rows(r),
                                      criticality_table.finite_size_data(r))),
    "order": Part(_order, lambda r, s: (amorphous.order_rows(r), amorphous.order_data(r))),
}
"""The analysis in independent parts, in report order of their rows."""

FIGURE_PART = {"fig1": "coordination", "fig2": "theory", "fig3": "theory",
               "fig3_exact": "exact_law", "fig4": "trace",
               "fig5": "avalanches", "fig6": "stress_strain", "fig7": "moduli",
               "theory_vs_cascade": "theory", "criticality": "criticality",
               "finite_size": "finite_size", "fig5_pressure": "pressure_tau",
               "tau_pressure": "pressure_tau"}
"""Which part makes which figure."""
COMPUTED_PARTS = frozenset({"coordination", "theory", "exact_law"})
"""The parts whose figures read no run directory: computed from the scale alone."""

_DRAW: dict[str, Callable[[_Analysis], Path | None]] = {
    "fig1": lambda c: figures.fig1(c.result("coordination"), c.figdir, c.ext),
    "fig2": lambda c: figures.fig2(c.scale, c.figdir, c.ext),
    "fig3": lambda c: figures.fig3(c.figdir, c.ext),
    "fig3_exact": lambda c: figures.fig3_exact(c.figdir, c.ext, c.result("exact_law")[1]),
    "fig4": lambda c: figures.fig4(c.result("trace"), c.scale, c.figdir, c.ext),
    "fig5": lambda c: figures.fig5(c.result("avalanches"), c.scale, c.figdir, c.ext),
    "fig6": lambda c: figures.fig6(c.result("stress_strain"), c.scale, c.figdir, c.ext),
    "fig7": lambda c: figures.fig7(c.result("moduli"), c.scale, c.figdir, c.ext),
    "theory_vs_cascade": lambda c: figures.theory_vs_cascade(c.result("theory"), c.figdir, c.ext),
    "criticality": lambda c: figures.criticality(c.result("criticality")[0], c.figdir, c.ext),
    "finite_size": lambda c: figures.finite_size(c.result("finite_size"), c.figdir, c.ext),
    "fig5_pressure": lambda c: figures.fig5_pressure(c.result("pressure_tau"), c.scale,
                                                     c.figdir, c.ext),
    "tau_pressure": lambda c: figures.tau_pressure(c.result("pressure_tau"), c.figdir, c.ext),
}


def _analyse(c: _Analysis) -> tuple[list[Row], dict[str, Any], list[Figure]]:
    """Every part's rows and data, and every figure that has data, in report order."""
    rows: list[Row] = []
    data: dict[str, Any] = {}
    files: dict[str, Path] = {}
    for name, part in PARTS.items():
        result = c.result(name)
        if part.render is not None:
            part_rows, part_data = part.render(result, c.scale)
            rows += part_rows
            data.update(part_data)
        for key in (k for k, p in FIGURE_PART.items() if p == name):
            path = _DRAW[key](c)
            if path is not None:
                files[key] = path
    caps = figures.captions(c.scale, c.result("coordination"), c.result("avalanches"),
                            c.result("theory")) | figures.criticality_captions(
        c.result("criticality")[0], c.result("finite_size"))
    figs = [Figure(key, figures.TITLES[key], files[key].relative_to(c.out).as_posix(), caps[key])
            for key in figures.TITLES if key in files]
    return rows, data, figs


def _run_all(scale: Scale, runs: Path, execution: Any, log: Callable[[str], None]) -> dict:
    from jamlab.runs import RunSummary, run_study

    summaries: dict[str, RunSummary] = {}
    for name, study in studies(scale).items():
        t = time.perf_counter()
        summaries[name] = run_study(study, runs / name, execution, log=log)
        s = summaries[name]
        log(f"{name}: {s.done} computed, {s.skipped} reused, {s.failed} failed "
            f"({time.perf_counter() - t:.0f} s)")
    return summaries


def _machines(scale: Scale, runs: Path) -> str:
    """Where the report's samples ran (:func:`jamlab.runs.origin.census_lines`, counted over
    its run directories) and where this report's analysis ran."""
    from jamlab.provenance import machine, summary_text
    from jamlab.runs import RunDir
    from jamlab.runs.origin import MachineCensus, census_lines, machine_census

    census = MachineCensus()
    for name, study in studies(scale).items():
        if (runs / name / "manifest.json").is_file():
            run = RunDir(runs / name)
            states, attrs = run.survey(study, ("provenance",))  # each file opened once
            machine_census(run, study, states, census=census, attrs=attrs)
    samples = " ".join(line.strip() for line in census_lines(census, keys=False))
    return (f"samples — {samples or 'none finished'}; this report's analysis, theory and "
            f"cascades: {summary_text(machine())}")


def _check_writable(path: Path) -> None:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot create output directory {path}: {exc.strerror}") from None
    if not path.is_dir() or not os.access(path, os.W_OK | os.X_OK):
        raise ValueError(f"output directory {path} is not writable")


MARKER = ".jamlab-reproduce.json"
"""The file :func:`reproduce` writes into its report directory before anything else: the report
files beside it are its own, and a later call may replace them."""

REPORT_FILES = ("index.html", "report.md", "results.json", "report.json")
"""The files of a report directory (besides ``figures/*``) that :func:`reproduce` replaces."""


def _own_report(out: Path) -> bool:
    """Whether the report files in ``out`` are those of an earlier :func:`reproduce`: it holds
    :data:`MARKER`, or (a report written before the marker existed) a ``results.json`` with
    reproduce's title."""
    if (out / MARKER).is_file():
        return True
    try:
        payload = json.loads((out / "results.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(payload, dict) and payload.get("title") == TITLE


def check_report_directory(out: str | os.PathLike, *, force: bool = False) -> None:
    """``ValueError`` (one line) if ``out`` holds report files (:data:`REPORT_FILES` or
    ``figures/*``) that :func:`reproduce` did not write, unless ``force``. Checked before
    anything runs; an earlier report of :func:`reproduce` is replaced (that is how it resumes)."""
    out = Path(out)
    if force or not out.is_dir() or _own_report(out):
        return
    found = [name for name in REPORT_FILES if (out / name).exists()]
    figdir = out / "figures"
    if figdir.is_dir() and any(figdir.iterdir()):
        found.append("figures/")
    if found:
        raise ValueError(f"{out} holds {', '.join(found)} not written by jamlab reproduce; "
                         "give --force to replace them")


def reproduce(
    scale: Scale | str,
    out: str | os.PathLike,
    *,
    runs: str | os.PathLike | None = None,
    execution: Any = None,
    log: Callable[[str], None] | None = None,
    force: bool = False,
) -> ReproduceResult:
    """Run (or resume) the ensembles of ``scale`` and write the report into ``out``.

    The ensembles are run through :func:`jamlab.runs.run_study` (a second call reuses every
    finished sample); the numbers follow the rules of ``docs/reproduce.md``; the report is
    ``out/report.md``, ``out/index.html`` and ``out/results.json`` with the figures in
    ``out/figures`` (:func:`jamlab.report.write_report`).

    Parameters
    ----------
    scale : Scale or str
        A :class:`~jamlab.reproduce.Scale` or the name of one in
        :data:`~jamlab.reproduce.SCALES` (``"tiny"``, ``"quick"``, ``"medium"``, ``"paper"``).
    out : path
        The report directory (created if missing).
    runs : path, optional
        Where the run directories ``jamming``, ``unsat`` and ``stress-strain`` live (default
        ``out/runs``).
    execution : jamlab.runs.Execution, optional
        Where the samples run (default: all local cores).
    log : callable, optional
        Called with one progress message at a time (default: silent).
    force : bool
        Replace report files in ``out`` that an earlier call did not write (default: refuse,
        :func:`check_report_directory`).

    Returns
    -------
    ReproduceResult
        The report's paths (``"markdown"``, ``"html"``, ``"json"``), its rows and figures, the
        wall time of this call in seconds and the machine-readable numbers (``data``, also in
        ``results.json``).

    Raises
    ------
    ValueError
        For an unknown scale, an output directory that cannot be written, that holds report
        files of something else (without ``force``), or that is or lies inside a run directory
        (likewise ``runs``), before running anything.

    Examples
    --------
    A scale is checked before anything runs:

    >>> from jamlab.reproduce import SCALES, reproduce
    >>> sorted(SCALES)
    ['medium', 'paper', 'quick', 'tiny']
    >>> reproduce("huge", "report")
    Traceback (most recent call last):
    ...
    ValueError: unknown scale 'huge': valid scales are tiny, quick, medium, paper

    The ``tiny`` scale (about a minute on one core) writes a complete report::

        from jamlab.runs import Execution
        result = reproduce("tiny", "report", execution=Execution(workers=0))
        result.paths["markdown"]        # report/report.md
    """
    t0 = time.perf_counter()
    scale = get_scale(scale)
    log = log or (lambda msg: None)
    out = Path(out)
    check_report_directory(out, force=force)
    runs_dir = Path(runs) if runs is not None else out / "runs"
    # a report, and the runs' parent, never go into a run directory (nothing written yet)
    check_new_run_directory("report directory", out, itself=True)
    check_new_run_directory("runs directory", runs_dir, itself=True)
    figdir = out / "figures"
    # refused before its first sample (a study that differs from the runs there, a scheduler out
    # of reach, a --runs that is a file), a call leaves nothing it created behind
    made = [out, out / MARKER, figdir, runs_dir, *(runs_dir / name for name in studies(scale))]
    with removed_on_failure(made, keep_only=frozenset({MARKER, *RUN_MEMBERS})):
        _check_writable(out)
        _check_writable(runs_dir)
        atomic_write_text(out / MARKER, json.dumps({"written_by": "jamlab reproduce"}) + "\n")
        figdir.mkdir(parents=True, exist_ok=True)
        summaries = _run_all(scale, runs_dir, execution, log)
    empty = {name: s for name, s in summaries.items() if s.done + s.skipped == 0}
    if empty:
        name, s = next(iter(empty.items()))
        why = " ".join(s.failures[0][1].split()) if s.failures else ""
        first = f" (the first: {why[:240]}{'…' if len(why) > 240 else ''})" if why else ""
        raise NoSamplesError(
            f"no sample of the {name} ensemble finished: {s.failed} of {s.total} failed{first}; "
            f"no report written (`jamlab status {runs_dir / name} --failures` lists them)")
    log("analysis and figures")
    rows, data, figs = _analyse(_Analysis(scale, runs_dir, out, figdir, log))
    data["runs"] = {k: asdict(v) | {"failures": [str(f) for f in v.failures]}
                    for k, v in summaries.items()}
    seconds = time.perf_counter() - t0
    meta = ReportMeta(
        title=TITLE,
        scale=scale.name,
        seconds=seconds,
        parameters={"this invocation": (
            f"{sum(v.done for v in summaries.values())} samples computed, "
            f"{sum(v.skipped for v in summaries.values())} reused from earlier runs, "
            f"{sum(v.failed for v in summaries.values())} failed "
            f"(the wall time covers only this invocation)"),
            "machines": _machines(scale, runs_dir)} | table.parameters(scale, runs_dir),
        notes=table.notes(scale),
        sections=dict(criticality_table.SECTION_TEXT) | {amorphous.SECTION:
                                                         amorphous.SECTION_TEXT},
    )
    paths = write_report(out, rows, figs, meta, extra=data)
    log(f"report written: {paths['html']} ({seconds:.0f} s)")
    return ReproduceResult(out, paths, rows, figs, seconds, data)


def make_figure(
    name: str,
    scale: Scale | str,
    runs: str | os.PathLike,
    out_file: str | os.PathLike,
    work: str | os.PathLike | None = None,
) -> Path:
    """Make one figure of the report (``fig1`` … ``fig7``, ``theory_vs_cascade``) from existing
    run directories under ``runs`` (those of ``jamlab reproduce``; nothing is run except the
    coordination curve and the theory, which need no ensemble) and write it to ``out_file``,
    drawn in the format its suffix names (``.png``, ``.pdf``, ``.svg``, ``.jpg`` …; another
    suffix is a ``ValueError`` before any work), atomically.

    ``work`` keeps the intermediate files (default: a temporary directory); the coordination
    curves are cached in ``work/data``.
    """
    import shutil
    import tempfile

    from matplotlib.backend_bases import FigureCanvasBase

    from jamlab.files import atomic_write
    from jamlab.runs import RunDir

    if name not in FIGURE_PART:
        raise ValueError(f"unknown figure {name!r}: valid figures are {', '.join(FIGURE_PART)}")
    scale = get_scale(scale)
    runs = Path(runs)
    part = FIGURE_PART[name]
    needs = {"avalanches": ("jamming", "unsat"), "moduli": ("jamming", "unsat"),
             "criticality": ("jamming", "unsat"), "finite_size": ("jamming", "unsat"),
             "trace": ("jamming",), "stress_strain": ("stress-strain",)}.get(part, ())
    if part == "pressure_tau":  # the fixed-pressure figures: the scale's pressure-<p> runs
        if not scale.pressures:
            raise ValueError(f"{name} draws fixed-pressure ensembles, and the scale "
                             f"{scale.name!r} has none (quick and medium have)")
        needs = tuple(pressure_run_name(p) for p in scale.pressures)
    wanted = studies(scale)
    for run in needs:
        if not (runs / run / "manifest.json").is_file():
            raise ValueError(f"{runs / run} is not a run directory: run `jamlab reproduce "
                             f"--scale {scale.name}` first (or give --runs)")
        # the figures select the scale's φ and N: runs of another scale do not hold them
        diffs = RunDir(runs / run).study().differences(wanted[run])
        if diffs:
            raise ValueError(f"{runs / run} was not made with the scale {scale.name!r} "
                             f"({'; '.join(diffs)}; recorded != the scale's): give the "
                             "--scale, --seed, --sizes and --alpha it was made with")
    out_file = Path(out_file)
    if not out_file.parent.is_dir():
        raise FileNotFoundError(f"output directory does not exist: {out_file.parent}")
    ext = out_file.suffix.lower()
    kinds = FigureCanvasBase.get_supported_filetypes()
    if ext.lstrip(".") not in kinds:
        raise ValueError(f"{out_file}: a figure needs one of the suffixes "
                         f"{', '.join('.' + k for k in sorted(kinds))}")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(work) if work is not None else Path(tmp)
        figdir = base / "figures"
        figdir.mkdir(parents=True, exist_ok=True)
        analysis = _Analysis(scale, runs, base, figdir, lambda msg: None, ext)
        path = _DRAW[name](analysis)
        if path is None:
            raise ValueError(f"no data for {name} in {runs} (no finished samples)")
        atomic_write(out_file, lambda part: shutil.copyfile(path, part))
    return out_file
