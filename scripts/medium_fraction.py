"""Run a measured fraction of the ``medium`` reproduce scale, and project the rest from it.

A session cannot host the ~10-hour ``jamlab reproduce --scale medium``. This script runs some of
its run directories (``--studies``, by name; default the fixed-pressure ensemble at p = 1e-4,
the costliest pressure) into ``--runs``, exactly as ``jamlab reproduce --scale medium --runs
RUNS`` would (same studies, seeds and layout, so a later full run reuses these samples), then
prints per finished sample its worker wall time (the ``seconds`` stored with it), the τ fits of the
report (the scale's rule, and at fixed pressure and at jamming the fit with an exponential
cut-off) from the finished samples (``jamlab.reproduce.measurements.tau_estimate``: jammed
steps only, S = −ΔH at fixed pressure), and the scale's projected cost with the measured
seconds per sample put in place of the benchmark-based estimate for the studies run.

    PYTHONPATH=src nice -n 10 python scripts/medium_fraction.py --runs medium-runs \\
        --studies pressure-1e-04 --workers 1

``--dirs DIR ...`` reports the same (time per sample, τ fits with the medium scale's rules) for
any finished run directories instead, e.g. an ensemble of ``jamlab run`` at another N;
``--n N ...`` restricts the report to those sizes of each study (the scale pools its N);
``--pool`` pools the ``--dirs`` of one study (same pressure, δγ, γ_max, φ; e.g. ``jamlab run``
ensembles at N = 250 and 500) into one estimate, as the scale pools its N (one N from two
``--dirs`` only as two realisations: studies with different master seeds);
``--figure-dir DIR`` draws the report's τ(p) figure of the fixed-pressure studies reported.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from jamlab.reproduce.measurements import tau_estimate, with_cutoff
from jamlab.reproduce.scales import SCALES, studies
from jamlab.reproduce.table import coarse_text, converged_text, shape_text
from jamlab.runs import Execution, Study, open_run, open_study, run_study


def selected_n(study: Study, n_only: list[int] | None) -> list[int]:
    """The sizes of ``study`` that ``n_only`` selects (all of them when it is empty or None)."""
    return list(study.n) if not n_only else [n for n in study.n if n in n_only]


def analyse(runs: list[tuple[Any, Study]], scale, name: str,
            n_only: list[int] | None = None) -> Any:
    """Print the worker time per finished sample and the report's τ fits (the scale's rule; at
    fixed pressure and at jamming also the fit with an exponential cut-off) of run directories
    ``runs`` (``(run dataset, study)`` pairs of one protocol, their sizes pooled as the report
    pools a study's N); ``n_only``: only these sizes (default all). One N may come from two
    directories only as two realisations (studies with different master seeds). Returns the τ
    estimate, with the cut-off fits where the report makes them; ValueError when no size is
    left or one N comes from two directories of one master seed."""
    study = runs[0][1]
    pairs, seeds, done_all, seconds, cpu = [], [], [], [], []
    for ds, st in runs:
        n_values = selected_n(st, n_only)
        sel = {"N": n_values}
        done = ds.status.sel(sel).values == "done"
        done_all.append(done.ravel())
        seconds.append(np.asarray(ds.seconds.sel(sel).values)[done])
        if "cpu_seconds" in ds:
            c = np.asarray(ds.cpu_seconds.sel(sel).values)[done]
            cpu.append(c[np.isfinite(c)])
        pairs += [(ds, n) for n in n_values]
        seeds += [int(st.seed)] * len(n_values)
    n_list = [n for _, n in pairs]
    if not n_list:
        raise ValueError(f"{name}: none of N = {n_only} in the study (N = {list(study.n)})")
    # one N from two directories only as two realisations (different master seeds: their
    # samples' seeds differ, jamlab.runs.seeds); with one seed they may be the same samples
    if len(set(zip(n_list, seeds, strict=True))) < len(n_list):
        raise ValueError(f"{name}: N = {n_list}: one size in two run directories of one "
                         "master seed, not pooled (their samples may share seeds)")
    done = np.concatenate(done_all)
    seconds = np.concatenate(seconds)
    cpu = np.concatenate(cpu) if cpu else np.empty(0)
    print(f"\n# {name}: N = {n_list}, {int(done.sum())} of {done.size} samples finished, "
          f"{study.dgamma:g} x {int(round(study.gamma_max / study.dgamma))} steps each"
          + ("" if study.pressure is None else f", fixed p = {study.pressure:g}"))
    if seconds.size:
        print(f"worker wall time per sample: {', '.join(f'{s:.0f}' for s in seconds)} s "
              f"(mean {seconds.mean():.0f} s)")
        if cpu.size:
            print(f"CPU time per sample (preparation included): {cpu.mean():.0f} s mean, "
                  f"{cpu.min():.0f}–{cpu.max():.0f} s ({cpu.size} samples)")
        # CPU time where the samples record it: worker wall time counts the waits of a
        # shared machine (e.g. 965 s wall against 578 s CPU per sample at N = 1000, p = 1e-4)
        per, what = (cpu.mean(), "CPU") if cpu.size else (seconds.mean(), "worker wall")
        print(f"projected for all {done.size} samples of this study: "
              f"{done.size * per / 3600:.2f} h of one core (from the mean {what} time)")
    label = "jamming" if "jamming" in study.phi else repr(study.phi[0])
    est = tau_estimate(label, pairs, scale)
    fit = est.fit
    if fit is None:
        print(f"tau: no fit ({est.n_avalanches} avalanches)")
    else:
        print(f"tau = {fit.tau:.3f} ± {est.sigma:.3f} from {est.n_avalanches} avalanches "
              f"({est.exclusion_text}; fitted avalanches start at p = {est.fit_pressures})")
    if study.pressure is not None or label == "jamming":  # (the report's rows with a cut-off)
        est = with_cutoff(est, pairs, scale)
        cut = est.cutoff
        print("tau with an exponential cut-off (the report's second row): "
              + ("no fit" if cut is None else
                 f"{cut.tau:.3f} ± {est.cutoff_sigma:.3f} "
                 + (f"(95 % [{cut.ci_low:.3f}, {cut.ci_high:.3f}])"
                    if math.isfinite(cut.ci_low) else "(asymptotic: no bootstrap)")
                 + f" on S >= {cut.x_min:.2e}, {cut.n_tail} sizes, "
                 f"S_c = {cut.x_c:.2e}" + (" (at its bound)" if cut.at_bound else "")))
        print("tau with the cut-off's shape free (the report's third row): "
              + shape_text(est.cutoff_shape))
        print("the cut-off fit at twice the strain step (the second row's check): "
              + (coarse_text(cut, est.cutoff_coarse) or "n/a"))
        print("the cut-off fit from the lowest δγ-converged floor (the second row's end): "
              + (converged_text(est.cutoff_converged) or "n/a"))
        d = est.size_difference
        if d is not None:  # (two N or more, with a bootstrap: the report's size-difference row)
            print(f"tau(N = {d.n[-1]}) - tau(N = {d.n[0]}) in that window, packings resampled "
                  f"({scale.n_boot}): {d.delta:+.3f} ± {d.boot_sigma:.3f} "
                  f"(z = {d.z_boot:+.2f}; asymptotic σ: z = {d.z_asymptotic:+.2f})")
    return est


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=Path("medium-runs"))
    ap.add_argument("--studies", nargs="+", default=["pressure-1e-04"])
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--analyse-only", action="store_true", help="do not run, only report")
    ap.add_argument("--dirs", type=Path, nargs="+", default=None,
                    help="only report on these run directories (any study, e.g. of `jamlab "
                    "run`), with the medium scale's fit rules")
    ap.add_argument("--figure-dir", type=Path, default=None,
                    help="draw the report's τ(p) figure (tau_pressure.png) of the fixed-pressure "
                    "studies reported into this directory, and their size distributions "
                    "(fig5_pressure.png) when they share one δγ and γ_max")
    ap.add_argument("--pool", action="store_true",
                    help="with --dirs: pool the directories of one study (the same fixed "
                    "pressure or constant volume, δγ, γ_max and φ) into one estimate, as the "
                    "scale pools its N (one N per directory, or per realisation: another "
                    "master seed)")
    ap.add_argument("--n", type=int, nargs="+", default=None,
                    help="report only these N of each study (default: all its N, pooled)")
    ap.add_argument("--n-boot", type=int, default=None,
                    help="bootstrap resamples of the fits (default: the scale's; 0: asymptotic "
                    "errors only, minutes instead of tens of minutes per study)")
    args = ap.parse_args(argv)
    scale = SCALES["medium"]
    if args.n_boot is not None:
        if args.n_boot < 0:
            ap.error(f"--n-boot must be >= 0, got {args.n_boot}")
        scale = replace(scale, n_boot=args.n_boot)

    def draw(by_pressure: dict[float, Any]) -> int:
        if args.figure_dir is not None:
            from jamlab.reproduce.figures import fig5_pressure, tau_pressure

            args.figure_dir.mkdir(parents=True, exist_ok=True)
            path = tau_pressure(by_pressure, args.figure_dir)
            print(f"\nfigure: {path}" if path is not None
                  else "\nno fixed-pressure study: no figure")
            if len(steps) == 1:  # the histograms' title gives the one δγ and γ_max
                (step, gamma_max), = steps
                fig5 = fig5_pressure(by_pressure, replace(scale, pressure_dgamma=step,
                                                          pressure_gamma_max=gamma_max),
                                     args.figure_dir)
                if fig5 is not None:
                    print(f"figure: {fig5}")
        return 0

    by_pressure: dict[float, Any] = {}

    steps: set[tuple[float, float]] = set()

    def keep(study: Study, est: Any) -> None:
        if study.pressure is not None:
            by_pressure[study.pressure] = est
            steps.add((study.dgamma, study.gamma_max))

    if args.dirs:
        groups: dict[tuple, list[tuple[Any, Study, Path]]] = {}
        for path in args.dirs:
            ds, study = open_study(ap, path)
            key = ((study.pressure, study.dgamma, study.gamma_max, study.phi) if args.pool
                   else (path,))
            groups.setdefault(key, []).append((ds, study, path))
        fixed = [m[0][1].pressure for m in groups.values() if m[0][1].pressure is not None]
        if args.figure_dir is not None and len(set(fixed)) < len(fixed):
            ap.error("two estimates at one pressure for one figure: pool their directories "
                     "with --pool")
        for members in groups.values():
            name = " + ".join(str(path) for _, _, path in members)
            try:
                est = analyse([(ds, st) for ds, st, _ in members], scale, name, args.n)
            except ValueError as err:
                ap.error(str(err))
            keep(members[0][1], est)
        return draw(by_pressure)
    all_studies = studies(scale)
    unknown = [s for s in args.studies if s not in all_studies]
    if unknown:
        ap.error(f"unknown studies {unknown}; the medium scale has {sorted(all_studies)}")
    for name in args.studies:
        study = all_studies[name]
        if not args.analyse_only:
            t0 = time.perf_counter()
            summary = run_study(study, args.runs / name, Execution(workers=args.workers),
                                log=print)
            print(f"{name}: {summary.done} computed, {summary.skipped} reused, "
                  f"{summary.failed} failed in {time.perf_counter() - t0:.0f} s")
        try:
            est = analyse([(open_run(args.runs / name), study)], scale, name, args.n)
        except ValueError as err:
            ap.error(str(err))
        keep(study, est)
    return draw(by_pressure)


if __name__ == "__main__":
    raise SystemExit(main())
