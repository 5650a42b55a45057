"""τ(p) where it stands: every fixed-pressure run given, by pressure, in one table and one figure.

The run directories (``jamlab run`` studies at fixed pressure, one N each; several realisations
of one N are pooled) are grouped by pressure. For each pressure, all its sizes pooled:

- the window: the lower end ``x_min`` of the report's cut-off fit of all the avalanches pooled
  (``jamlab.reproduce.measurements.fit_tau_cutoff``, the ``medium`` scale's rule: KS-chosen);
- τ with an exponential cut-off there (``fit_cutoff_power_law``), its asymptotic σ and the σ of
  ``--boot`` resamples that draw each size's packings with replacement and pool them (packings
  as the units; seed ``--seed``);
- with two sizes or more, one τ for all sizes with each size's cut-off scale *and* shape free
  (the shapes of ``--shape-grid``; :func:`jamlab.analysis.shared_tau`): its best value, its 95 %
  profile interval, and the likelihood ratio of a τ per size against it (χ² on K − 1 degrees of
  freedom, avalanches as units); with one size, the shape-free fit of that size
  (:func:`jamlab.analysis.cutoff_shape_profile`);
- per N, τ with an exponential cut-off in the pooled window, its asymptotic σ, and the slope
  ``dτ/d ln N`` with its σ from the same number of packing resamples
  (:func:`jamlab.analysis.size_difference`);
- which of τ_J = 1.41269, the paper's 1.52 and τ_UNSAT = 1 each 95 % interval holds.

``--figure F`` (``.png``, ``.pdf`` or ``.svg``, not inside a run directory): τ against p, two
panels: the pooled fits (exponential ± 1.96 σ of the packing resamples; one τ with each size's
cut-off free, 95 % profile interval, drawn as a third series where a τ per size is preferred
at 5 %) and each N alone (± 1.96 asymptotic σ), beside τ_J, the paper's constant-volume fit
and τ_UNSAT.

Avalanches are those the report counts (jammed steps only, ``S = −ΔH``); finished samples only.

    R=data/runs
    PYTHONPATH=src python scripts/tau_summary.py $R/n500-p1e-2-vg $R/n1000-p1e-2-vg \\
        $R/n500-p1e-3-vg $R/n1000-p1e-3-vg --figure /tmp/tau.png
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.stats import norm

from jamlab.analysis import cutoff_shape_profile, fit_cutoff_power_law, shared_tau, size_difference
from jamlab.analysis.cutoff_powerlaw import DEFAULT_STRETCHES
from jamlab.paper import PAPER_TAU
from jamlab.reproduce.measurements import avalanche_set, fit_tau_cutoff
from jamlab.reproduce.scales import SCALES
from jamlab.runs import check_figure_path, open_pressure_run
from jamlab.theory import tau_jamming

Z95 = float(norm.ppf(0.975))
REFERENCES = {"τ_J": tau_jamming(), "1.52": PAPER_TAU["jamming"][0], "τ_UNSAT": 1.0}


def pooled_packing_sigma(groups: dict[int, list[np.ndarray]], x_min: float, boot: int,
                         seed: int) -> tuple[float, int]:
    """σ of τ (exponential cut-off at the fixed ``x_min``) over ``boot`` resamples that draw each
    size's packings with replacement (``numpy.random.default_rng(seed)``, sizes ascending) and
    pool them; the number of resamples used (those with 10 sizes or more in the window)."""
    rng = np.random.default_rng(seed)
    taus = []
    for _ in range(boot):
        s = np.concatenate([np.concatenate([packs[i] for i in rng.integers(0, len(packs),
                                                                            len(packs))])
                            for packs in (groups[n] for n in sorted(groups))])
        if np.count_nonzero(s >= x_min) >= 10:
            taus.append(fit_cutoff_power_law(s, x_min).tau)
    return (float(np.std(taus, ddof=1)) if len(taus) > 1 else math.nan), len(taus)


def holds(low: float, high: float) -> str:
    """The references inside ``[low, high]``, by name ("none" if none)."""
    inside = [name for name, v in REFERENCES.items() if low <= v <= high]
    return ", ".join(inside) if inside else "none"


def summarise(groups: dict[int, list[np.ndarray]], boot: int, seed: int,
              grid: tuple[float, ...]) -> dict:
    """One pressure's numbers (module docstring); ValueError where a fit cannot be made."""
    pooled = np.concatenate([np.concatenate(g) for g in groups.values()])
    cut = fit_tau_cutoff(pooled, replace(SCALES["medium"], n_boot=0))
    if cut is None:
        raise ValueError(f"too few avalanches for the pooled cut-off fit ({pooled.size})")
    x_min = cut.x_min
    sigma_pack, used = pooled_packing_sigma(groups, x_min, boot, seed)
    out = {"x_min": x_min, "tail": int(np.count_nonzero(pooled >= x_min)), "tau": cut.tau,
           "sigma": cut.tau_stderr, "sigma_pack": sigma_pack, "boot_used": used,
           "n": sorted(groups), "packings": [len(groups[n]) for n in sorted(groups)]}
    if len(groups) >= 2:
        f = shared_tau(groups, x_min, grid, boot=0, seed=seed)  # no resamples: slope unused here
        d = size_difference(groups, x_min, boot, seed)
        out.update(free=(f.tau, f.tau_low, f.tau_high), free_a=f.a_joint, lr=f.lr, dof=f.dof,
                   p_value=f.p_value, per_n=list(zip(d.n, d.tails, d.tau, d.sigma, strict=True)),
                   slope=(d.slope, d.slope_sigma, d.z_slope))
    else:
        prof = cutoff_shape_profile(pooled, x_min, grid)
        out.update(free=(prof.tau_best, prof.tau_low, prof.tau_high), free_a=(prof.best,),
                   lr=math.nan, dof=0, p_value=math.nan, per_n=[], slope=None)
    return out


def figure(rows: dict[float, dict], path: Path) -> None:
    """The figure of ``--figure`` (module docstring)."""
    from jamlab.plots.report import plot_tau_against_pressure
    from jamlab.reproduce.figures import tau_pressure_references

    ps = sorted(rows)
    nan = [math.nan] * len(ps)

    def series(values):
        return tuple(list(v) for v in zip(*values, strict=True)) if values else (nan, nan, nan)

    exp = series([(r["tau"], r["tau"] - Z95 * r["sigma_pack"], r["tau"] + Z95 * r["sigma_pack"])
                  for r in (rows[p] for p in ps)])
    one = [(rows[p]["free"] if not rows[p]["p_value"] < 0.05 else (math.nan,) * 3) for p in ps]
    rejected = [(rows[p]["free"] if rows[p]["p_value"] < 0.05 else (math.nan,) * 3) for p in ps]
    pooled = {"exponential cut-off, KS window (95 %, packings resampled)": exp,
              "one τ, each N's cut-off scale and shape free (95 % profile)": series(one)}
    if any(math.isfinite(r[0]) for r in rejected):
        pooled["the same where a τ per N is preferred at 5 %"] = series(rejected)
    sizes = sorted({n for r in rows.values() for n, *_ in r["per_n"]})
    per_n = {}
    for n in sizes:
        vals = []
        for p in ps:
            hit = [(t, t - Z95 * s, t + Z95 * s) for m, _, t, s in rows[p]["per_n"] if m == n]
            vals.append(hit[0] if hit else (math.nan,) * 3)
        per_n[f"N = {n} alone (95 %, asymptotic)"] = series(vals)
    refs = tau_pressure_references()
    panels = [("fixed-pressure AQS, all sizes pooled, KS window", pooled)]
    if per_n:
        panels.append(("each N alone, exponential cut-off in the pooled window", per_n))
    plot_tau_against_pressure(ps, panels, refs, path)
    print(f"\nfigure: {path}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="fixed-pressure run directories, one N each")
    ap.add_argument("--boot", type=int, default=200, help="packing resamples per pressure")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shape-grid", type=float, nargs="+", default=list(DEFAULT_STRETCHES),
                    help="the cut-off shapes a of the shape-free fits")
    ap.add_argument("--figure", type=Path, default=None, help="write the figure here")
    args = ap.parse_args(argv)
    if args.boot < 2:
        ap.error(f"--boot must be >= 2, got {args.boot}")
    if any(not np.isfinite(a) or a <= 0 for a in args.shape_grid) or len(
            set(args.shape_grid)) < len(args.shape_grid):
        ap.error(f"--shape-grid must be distinct numbers > 0, got {args.shape_grid}")
    check_figure_path(ap, args.figure, args.runs)
    by_p: dict[float, dict[int, list[np.ndarray]]] = {}
    for path in args.runs:
        ds, pressure, n = open_pressure_run(ap, path)
        by_p.setdefault(pressure, {}).setdefault(n, []).extend(
            avalanche_set(ds, "jamming", n).per_sample)
    grid = tuple(args.shape_grid)
    rows = {}
    for p in sorted(by_p, reverse=True):
        try:
            rows[p] = summarise(by_p[p], args.boot, args.seed, grid)
        except ValueError as err:
            ap.error(f"p = {p:g}: {err}")
    print("| p | N (packings) | window x_min (ε), sizes | τ, exponential cut-off ± σ asymptotic "
          f"/ packings ({args.boot} resamples) | holds (95 %, packings) | one τ, each N's "
          "cut-off free: best, 95 % (σ = width/3.92) | holds | its shape a per N | τ per N "
          "against one τ: 2Δlog L, p |")
    print("|---|---|---|---|---|---|---|---|---|")
    for p, r in rows.items():
        t, lo, hi = r["free"]
        lo_e, hi_e = r["tau"] - Z95 * r["sigma_pack"], r["tau"] + Z95 * r["sigma_pack"]
        sizes = " + ".join(f"{n} ({k})" for n, k in zip(r["n"], r["packings"], strict=True))
        lr = (f"{r['lr']:.2f} ({r['dof']}), {r['p_value']:.2g}" if r["dof"] else "— (one size)")
        print(f"| {p:g} | {sizes} | {r['x_min']:.3g}, {r['tail']} | {r['tau']:.3f} ± "
              f"{r['sigma']:.3f} / {r['sigma_pack']:.3f} | {holds(lo_e, hi_e)} | {t:.3f}, "
              f"[{lo:.3f}, {hi:.3f}] ({(hi - lo) / 3.92:.3f}) | {holds(lo, hi)} | "
              f"{', '.join(f'{a:g}' for a in r['free_a'])} | {lr} |")
    several = {p: r for p, r in rows.items() if r["slope"] is not None}
    if several:
        print("\n| p | τ per N, exponential cut-off in the pooled window (± asymptotic σ; "
              f"sizes) | dτ/d ln N ± σ ({args.boot} packing resamples), z |")
        print("|---|---|---|")
    for p, r in several.items():
        per_n = "; ".join(f"{n}: {t:.3f} ± {s:.3f} ({k})" for n, k, t, s in r["per_n"])
        slope, sig, z = r["slope"]
        print(f"| {p:g} | {per_n} | {slope:+.3f} ± {sig:.3f}, {z:+.2f} |")
    if args.figure is not None:
        figure(rows, args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
