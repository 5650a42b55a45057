"""``jamlab criticality``: contact forces, gaps, bucklers and ``θ_e``, ``θ_l``, ``γ`` of packings.

A thin face over :mod:`jamlab.analysis.criticality` and :mod:`jamlab.plots.criticality`; rules and
measured numbers in ``docs/criticality.md``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated

import typer

SUMMARY = "criticality.json"
FIGURES = ("distributions.png", "local_exponents.png", "finite_size.png")


def _window(text: str | None, option: str) -> tuple[float, float] | None:
    if text is None or text.strip().lower() == "auto":
        return None
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"{option} must be 'auto' or 'LO,HI', got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"{option} must satisfy 0 < LO < HI, got {text!r}")
    return lo, hi


def _fit_warnings(label: str, fit, n_boot: int) -> list[str]:
    """Why a fit has no estimate or no 95 % interval (NaN; ``null`` in the JSON), one line each
    (``ExponentFit.n_boot`` counts the resamples that gave an estimate)."""
    out = []
    lo, hi = fit.window
    if not math.isfinite(fit.value):
        out.append(
            f"{label}: no estimate on the window [{lo:.3g}, {hi:.3g}] "
            f"({fit.n_in_window} samples in it)"
        )
    if fit.at_bound:
        out.append(f"{label}: the fit sits at an end of its search ({fit.value:.4g}): the "
                   f"window [{lo:.3g}, {hi:.3g}] holds no power law it can follow; choose another")
    if not all(math.isfinite(c) for c in fit.ci95):
        if fit.n_packings < 2:
            why = (f"{fit.n_packings} packing (the bootstrap resamples packings: it needs at "
                   "least 2)")
        else:
            why = (f"only {fit.n_boot} of {n_boot} bootstrap resamples gave an estimate "
                   "(need 2; too few samples in the window)")
        out.append(f"{label}: the 95% interval could not be estimated: {why}")
    return out


def analyse(
    paths: list[Path],
    h_max: float = 0.5,
    alpha: float | None = None,
    method: str = "cdf",
    n_boot: int = 1000,
    seed: int = 0,
    windows: dict[str, tuple[float, float]] | None = None,
    out: Path | None = None,
) -> dict[str, object]:
    """Read the packings, measure, optionally draw the figures into ``out``; the summary dict
    (the ``--json`` output)."""
    import h5py
    import numpy as np

    from jamlab.analysis.criticality import (
        DEFAULT_RULES,
        REFERENCE,
        counts,
        criticality_samples,
        local_exponents,
        measure_exponents,
        packing_observables,
    )
    from jamlab.cli import flagged_note
    from jamlab.files import check_distinct_inputs
    from jamlab.spheres.io import read_packing

    check_distinct_inputs(paths, "packing")
    observables, warnings, resolution, pressures, alphas = [], [], [], [], []
    for path in paths:
        packing = read_packing(path)
        with h5py.File(path, "r") as h5:
            ftol = float(h5.attrs.get("param_ftol", math.nan))
            pressures.append(float(h5.attrs.get("pressure", math.nan)))
        note = flagged_note(path)
        if note is not None:
            warnings.append(note)
        if observables and packing.dim != observables[0].dim:
            raise ValueError(f"{path} is {packing.dim}D, {paths[0]} {observables[0].dim}D: "
                             "the fits pool one dimension at a time")
        if alpha is not None and alpha != packing.alpha:
            raise ValueError(f"--alpha {alpha} differs from the pair exponent of {path} "
                             f"({packing.alpha})")
        alphas.append(float(packing.alpha))
        obs = packing_observables(
            packing.positions, packing.box.length, packing.strain, packing.diameters,
            packing.alpha, h_max,
        )
        if obs.n_contacts == 0:
            raise ValueError(f"{path}: no backbone (not jammed)")
        observables.append(obs)
        resolution.append(ftol / obs.mean_force)
    groups: dict[int, list] = {}
    for obs in observables:
        groups.setdefault(obs.n, []).append(obs)

    def measure(obs_list):
        return measure_exponents(obs_list, DEFAULT_RULES, windows, method, n_boot, seed)

    fits = measure(observables)
    fits_by_n = {n: measure(g) for n, g in groups.items()} if len(groups) > 1 else {}
    for name, fit in fits.items():
        warnings += _fit_warnings(name, fit, n_boot)
    for n, fs in sorted(fits_by_n.items()):
        for name, fit in fs.items():
            warnings += _fit_warnings(f"{name} at N={n}", fit, n_boot)
    theta_e, gamma = fits["theta_e"].value, fits["gamma"].value
    summary: dict[str, object] = {name: fit.as_dict() for name, fit in fits.items()}
    summary.update(
        counts=counts(observables),
        n=sorted(groups),
        dim=sorted({o.dim for o in observables}),
        pressure_range=[float(np.nanmin(pressures)), float(np.nanmax(pressures))],
        isostatic_excess=sorted({o.isostatic_excess for o in observables}),
        force_resolution=float(np.nanmax(resolution)) if np.isfinite(resolution).any() else None,
        tau_j_from_theta_e=(3 + theta_e) / (2 + theta_e),
        tau_j_from_gamma=1 + gamma,
        reference=dict(REFERENCE),
        window_rule={k: [r.per_packing, r.upper] for k, r in DEFAULT_RULES.items()},
        method=method,
        h_max=h_max,
        alpha=sorted({o_alpha for o_alpha in alphas}),
        warnings=warnings,
    )
    if fits_by_n:
        summary["by_n"] = {
            str(n): {name: f.as_dict() for name, f in fs.items()} | {"counts": counts(groups[n])}
            for n, fs in sorted(fits_by_n.items())
        }
    if out is not None:
        from jamlab.plots.criticality import (
            plot_distributions,
            plot_finite_size,
            plot_local_exponents,
        )

        spans = {"theta_e": (1e-4, 1.0), "theta_l": (1e-4, 1.0), "gamma": (1e-7, 1e-1)}
        local = {
            name: {
                n: local_exponents(
                    criticality_samples(g)[name], *spans[name], method=method, n_boot=200
                )
                for n, g in groups.items()
            }
            for name in spans
        }
        summary["local"] = {
            name: {
                str(n): {
                    "lo": le.lo.tolist(),
                    "hi": le.hi.tolist(),
                    "value": [None if math.isnan(v) else v for v in le.value.tolist()],
                    "ci95_low": [None if math.isnan(v) else v for v in le.ci_low.tolist()],
                    "ci95_high": [None if math.isnan(v) else v for v in le.ci_high.tolist()],
                    "n_in_window": le.n_in_window.tolist(),
                }
                for n, le in by_n.items()
            }
            for name, by_n in local.items()
        }
        plot_distributions(groups, fits, out / FIGURES[0])
        plot_local_exponents(local, fits, out / FIGURES[1])
        plot_finite_size(groups, fits_by_n or {next(iter(groups)): fits}, out / FIGURES[2])
    return summary


def register(app: typer.Typer) -> None:
    """Add ``criticality``."""

    @app.command(
        "criticality",
        help="Contact forces, gaps, bucklers and the exponents theta_e, theta_l, gamma of jammed "
        "packings (pooled, bootstrap over packings), with figures.",
    )
    def criticality_command(
        packings: Annotated[
            list[Path], typer.Argument(help="Packings (HDF5, e.g. from jamlab prepare).")
        ],
        out: Annotated[Path, typer.Option("--out", help="Output directory (figures, summary).")],
        as_json: Annotated[
            bool, typer.Option("--json", help="Print the summary as JSON on stdout.")
        ] = False,
        h_max: Annotated[float, typer.Option("--h-max", help="Largest gap h kept.")] = 0.5,
        alpha: Annotated[
            float | None,
            typer.Option("--alpha", help="Pair exponent α (default: the packings' own)."),
        ] = None,
        method: Annotated[
            str, typer.Option("--method", help="Fit: 'cdf' (window CDF), 'plain' or 'mle'.")
        ] = "cdf",
        n_boot: Annotated[int, typer.Option("--n-boot", help="Bootstrap resamples.")] = 1000,
        seed: Annotated[int, typer.Option("--seed", help="Bootstrap seed.")] = 0,
        window_theta_e: Annotated[
            str, typer.Option("--window-theta-e", help="'auto' (the rule) or 'LO,HI' in f/<f>.")
        ] = "auto",
        window_theta_l: Annotated[
            str, typer.Option("--window-theta-l", help="'auto' or 'LO,HI' in f/<f>.")
        ] = "auto",
        window_gamma: Annotated[
            str, typer.Option("--window-gamma", help="'auto' or 'LO,HI' in h.")
        ] = "auto",
        force: Annotated[
            bool,
            typer.Option(
                "--force", "--overwrite",
                help="Replace the summary and figures of an earlier run in --out.",
            ),
        ] = False,
    ) -> None:
        from jamlab import validation
        from jamlab.files import atomic_write, check_new_run_directory, check_outputs
        from jamlab.report import json_safe

        if method not in ("cdf", "plain", "mle"):
            raise ValueError(f"--method must be cdf, plain or mle, got {method!r}")
        if not (math.isfinite(h_max) and 0 < h_max):
            raise ValueError(f"--h-max must be > 0, got {h_max}")
        if alpha is not None and not (math.isfinite(alpha) and alpha > 1):
            raise ValueError(f"--alpha must be > 1, got {alpha}")
        if n_boot < 2:
            raise ValueError(f"--n-boot must be >= 2, got {n_boot}")
        validation.seed("--seed", seed)  # (numpy's own message did not name the option)
        windows = {
            k: w
            for k, w in (
                ("theta_e", _window(window_theta_e, "--window-theta-e")),
                ("theta_l", _window(window_theta_l, "--window-theta-l")),
                ("gamma", _window(window_gamma, "--window-gamma")),
            )
            if w is not None
        }
        if "gamma" in windows and windows["gamma"][1] > h_max:
            raise ValueError(f"--window-gamma ends at {windows['gamma'][1]:g}, above --h-max "
                             f"{h_max:g}: gaps above --h-max are not kept")
        for p in packings:
            if not p.is_file():
                raise FileNotFoundError(f"no such packing file: {p}")
        if out.exists() and not out.is_dir():
            raise FileExistsError(f"--out {out} exists and is not a directory")
        # not into a run's directory, beside or among its members (only jamlab run writes there)
        check_new_run_directory("--out", out, itself=True)
        made = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
        try:
            # the summary and the figures: no input among them, none replaced without --force
            check_outputs({f"the {'summary' if f == SUMMARY else 'figure'} {f} in --out":
                           out / f for f in (SUMMARY, *FIGURES)},
                          {f"packing {k}": p for k, p in enumerate(packings)}, force=force)
            summary = analyse(packings, h_max, alpha, method, n_boot, seed, windows, out)
        except BaseException:
            if made and not any(out.iterdir()):
                out.rmdir()  # a failed run leaves no empty --out behind
            raise
        summary = json_safe(summary)  # NaN and inf are not JSON: null
        text = json.dumps(summary, indent=1, allow_nan=False)
        atomic_write(out / SUMMARY, lambda tmp: Path(tmp).write_text(text + "\n"))
        for w in summary["warnings"]:  # type: ignore[union-attr]
            typer.echo(f"jamlab: warning: {w}", err=True)
        if as_json:
            brief = {k: summary[k] for k in ("theta_e", "theta_l", "gamma", "counts")}
            brief |= {k: summary[k] for k in summary if k not in brief and k != "local"}
            typer.echo(json.dumps(brief, indent=1, allow_nan=False))
            return
        c = summary["counts"]
        typer.echo(
            f"{c['packings']} packings (N={summary['n']}), {c['contacts']} backbone contacts "
            f"({c['localized_contacts']} localized), {c['gaps']} gaps <= {h_max}"
        )
        for name in ("theta_e", "theta_l", "gamma"):
            f = summary[name]
            ref = summary["reference"][name]  # type: ignore[index]
            value = "not estimated" if f["value"] is None else f"{f['value']:.4f}"
            if None in f["ci95"]:
                ci = "95% interval not estimated (see the warning)"
            else:
                ci = f"95% [{f['ci95'][0]:.4f}, {f['ci95'][1]:.4f}]"
            typer.echo(
                f"{name} = {value}  {ci}  "
                f"window [{f['window'][0]:.3g}, {f['window'][1]:.3g}]  (reference {ref})"
            )
        tau_e, tau_g = summary["tau_j_from_theta_e"], summary["tau_j_from_gamma"]
        typer.echo(
            f"tau_J = (3+theta_e)/(2+theta_e) = "
            f"{'not estimated' if tau_e is None else f'{tau_e:.4f}'}, "
            f"1+gamma = {'not estimated' if tau_g is None else f'{tau_g:.4f}'}"
        )
        typer.echo(f"wrote {out / SUMMARY} and {', '.join(FIGURES)}")
