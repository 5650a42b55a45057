"""Does τ depend on N in one window? Two sizes of a fixed-pressure study, with packings as units.

The τ(p) figure's right panel fits each N alone with an exponential cut-off in the window of the
pooled fit (``TauEstimate.cutoff_per_n``), with the asymptotic σ, which counts every avalanche as
independent. This script asks whether the sizes' τ differ there, with whole packings as the
independent units. The run directories (``jamlab run`` studies at fixed pressure, one N each;
several realisations of one N are pooled) are grouped by pressure; each pressure needs two sizes
or more. For each pressure it prints:

- the window: the lower end ``x_min`` of the report's cut-off fit of all the avalanches pooled
  (``jamlab.reproduce.measurements.fit_tau_cutoff``, the ``medium`` scale's rule: KS-chosen);
- per N: packings, sizes in the window, τ with an exponential cut-off at that ``x_min``
  (``fit_cutoff_power_law``) and its asymptotic σ;
- the difference ``Δτ = τ(largest N) − τ(smallest N)``, in units of the asymptotic σ, and of
  the σ of ``--boot`` resamples that draw each size's packings with replacement (seed
  ``--seed``); the fraction of resamples with ``Δτ ≤ 0``;
- the least-squares slope ``dτ/d ln N`` through all the sizes, ± its σ from the same resamples,
  and its z (with two sizes the slope is ``Δτ / ln(N₁/N₀)`` and its z is Δτ's bootstrap z);
- over all pressures: ``Σ z²`` (its χ² p on one degree of freedom per pressure) and ``Σ z / √k``
  (its two-sided normal p), of the slopes' bootstrap z.

``--coarse 2 4``: per pressure, also the sizes at ``k δγ`` (the same minima, steps grouped ``k``
at a time: ``jamlab.reproduce.ensembles.coarse_avalanches``) fitted in the same window, the
slope at each ``k`` and at the linear extrapolation ``2 τ(δγ) − τ(2 δγ)`` to ``δγ → 0``, σ from
the same packing resamples at every ``k`` (``jamlab.analysis.strain_step_slopes``): does the
strain step make the slope? (``k = 2`` is required.)

``--shapes 0.3 0.5 1``: per pressure, each size alone in the same window with the cut-off
``e^(−(S/S*)^a)`` held at each ``a`` (``jamlab.analysis.cutoff_shape_profile``), τ per size, the
slope weighted by the asymptotic σ (avalanches as units), and the ``a`` each size prefers with
its ``2Δlog L`` against the exponential: is the slope the cut-off's shape?

``--free-shapes``: per pressure, each size with its own cut-off scale *and* shape (the shapes of
``--shape-grid``, default ``jamlab.analysis.cutoff_powerlaw.DEFAULT_STRETCHES``): τ per size at its
best shape with its shape-free 95 % interval, the slope through them with its σ from ``--boot``
packing resamples (at most 500), one τ for all sizes with each size's shape and scale free and its
95 % profile interval, and the likelihood ratio of the separate fits against that one τ
(``jamlab.analysis.shared_tau``): is the slope a cut-off that moves with N?

``--window X``: every pressure's window starts at ``X`` (ε) instead of the pooled KS window (does
the answer depend on the window's lower end?).

``--dispersion``: per pressure and N, are the packings alike in the window
(``jamlab.analysis.packing_dispersion``, 2000 permutations, ``--seed``)? The between- over
within-packing variance of ``log(S/x_min)`` with its permutation p, and the variance over mean
of the packings' counts with its p of over-dispersion: a mixture of packings that differ in
cut-off or rate, whose pooled shape could move with N, would show in either.

``--steps FIRST LAST``: only the avalanches of the AQS steps ``FIRST`` … ``LAST`` (1-based, both
included; step ``k`` takes the minimum at ``γ = (k − 1) δγ`` to ``k δγ``) of every packing (does
the answer live in a part of the strain window? With ``--window``, every part is fitted in the
same window). Not with ``--coarse``.

Avalanches are those the report counts (jammed steps only, ``S = −ΔH``). The window is fixed
from the real data; the resamples refit τ in it (they do not choose their own window).

    PYTHONPATH=src python scripts/size_dependence.py data/runs/n500-p1e-6-vg \\
        data/runs/n500-p1e-6-vg-s1 data/runs/n1000-p1e-6-vg
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from jamlab.analysis import (
    combined_scores,
    cutoff_shape_profile,
    fit_log_slope,
    packing_dispersion,
    shared_tau,
    size_difference,
    strain_step_slopes,
)
from jamlab.analysis.cutoff_powerlaw import DEFAULT_STRETCHES
from jamlab.reproduce.ensembles import coarse_avalanches, counted_steps
from jamlab.reproduce.measurements import avalanche_set, fit_tau_cutoff
from jamlab.reproduce.scales import SCALES
from jamlab.runs import open_pressure_run


def steps_part(ap: argparse.ArgumentParser, path: Path, ds, n: int, first: int,
               last: int) -> tuple[np.ndarray, ...]:
    """Per finished packing, the sizes of the avalanches the report counts at AQS steps
    ``first`` … ``last`` (1-based, both included); the parser's error where the run has fewer
    steps than ``last``."""
    ej, counted = counted_steps(ds, "jamming", n)
    if last > ej.shape[1]:
        ap.error(f"{path}: --steps {first} {last}, but its packings have {ej.shape[1]} steps")
    part = np.zeros(ej.shape[1], dtype=bool)
    part[first - 1:last] = True
    return tuple(-row[m & part] for row, m in zip(ej, counted, strict=True))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="fixed-pressure run directories, one N each")
    ap.add_argument("--boot", type=int, default=2000, help="packing resamples per pressure")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--coarse", type=int, nargs="+", default=[],
                    help="strain steps k δγ to add (k = 2 required), e.g. --coarse 2 4")
    ap.add_argument("--shapes", type=float, nargs="+", default=[],
                    help="cut-off shapes a to hold fixed, e.g. --shapes 0.3 0.5 1")
    ap.add_argument("--free-shapes", action="store_true",
                    help="also fit each size with its own cut-off shape (module docstring)")
    ap.add_argument("--shape-grid", type=float, nargs="+", default=list(DEFAULT_STRETCHES),
                    help="the cut-off shapes a of --free-shapes")
    ap.add_argument("--dispersion", action="store_true",
                    help="per pressure and N: are the packings alike (packing_dispersion)?")
    ap.add_argument("--window", type=float, default=None,
                    help="the window's lower end x_min (ε) at every pressure, instead of the "
                         "pooled KS window")
    ap.add_argument("--steps", type=int, nargs=2, default=None, metavar=("FIRST", "LAST"),
                    help="only the avalanches of these AQS steps (1-based, both included)")
    args = ap.parse_args(argv)
    if args.steps is not None and not 1 <= args.steps[0] <= args.steps[1]:
        ap.error(f"--steps needs 1 <= FIRST <= LAST, got {args.steps}")
    if args.steps is not None and args.coarse:
        ap.error("--steps and --coarse do not go together (coarse steps straddle the parts)")
    if args.window is not None and not (np.isfinite(args.window) and args.window > 0):
        ap.error(f"--window must be a number > 0, got {args.window}")
    if any(not np.isfinite(a) or a <= 0 for a in args.shape_grid) or len(
            set(args.shape_grid)) < len(args.shape_grid):
        ap.error(f"--shape-grid must be distinct numbers > 0, got {args.shape_grid}")
    if any(not np.isfinite(a) or a <= 0 for a in args.shapes) or len(set(args.shapes)) < len(
            args.shapes):
        ap.error(f"--shapes must be distinct numbers > 0, got {args.shapes}")
    if args.boot < 2:
        ap.error(f"--boot must be >= 2, got {args.boot}")
    if args.coarse and (2 not in args.coarse or min(args.coarse) < 2):
        ap.error(f"--coarse takes k >= 2 and must include 2, got {args.coarse}")
    ks = [1, *sorted(set(args.coarse))] if args.coarse else []
    by_p: dict[float, dict[int, list[np.ndarray]]] = {}
    coarse: dict[float, dict[int, dict[int, list[np.ndarray]]]] = {}
    for path in args.runs:
        ds, pressure, n = open_pressure_run(ap, path)
        per_sample = avalanche_set(ds, "jamming", n).per_sample
        if args.steps is not None:
            per_sample = steps_part(ap, path, ds, n, *args.steps)
        by_p.setdefault(pressure, {}).setdefault(n, []).extend(per_sample)
        for k in ks:
            seen = coarse_avalanches(ds, "jamming", n, k).per_sample
            if k == 1 and not all(np.array_equal(a, b) for a, b in zip(
                    seen, per_sample, strict=True)):
                ap.error(f"{path}: k = 1 does not give the report's avalanches")
            coarse.setdefault(pressure, {}).setdefault(k, {}).setdefault(n, []).extend(seen)
    scale = replace(SCALES["medium"], n_boot=0)
    if args.steps is not None:
        print(f"AQS steps {args.steps[0]}–{args.steps[1]} of every packing only\n")
    print(f"| p | window x_min (ε) | N: packings, sizes, τ ± asymptotic σ | Δτ (largest − "
          f"smallest N) | z (asymptotic) | σ of Δτ, {args.boot} packing resamples | z | resamples "
          "with Δτ ≤ 0 | dτ/d ln N ± σ (resamples) | z of the slope |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    zs = []
    windows: dict[float, float] = {}  # each pressure's window, used again below
    for p in sorted(by_p, reverse=True):
        groups = by_p[p]
        if len(groups) < 2:
            ap.error(f"p = {p:g}: need two sizes N or more, got {sorted(groups)}")
        if args.window is None:
            cut = fit_tau_cutoff(np.concatenate([np.concatenate(g) for g in groups.values()]),
                                 scale)
            if cut is None:
                ap.error(f"p = {p:g}: too few avalanches for the pooled cut-off fit")
            x_min = cut.x_min
        else:
            x_min = args.window
        try:
            r = size_difference(groups, x_min, args.boot, args.seed)
        except ValueError as err:
            ap.error(f"p = {p:g}: {err}")
        zs.append(r.z_slope)
        windows[p] = r.x_min
        per_n = "; ".join(f"{n}: {k}, {t}, {tau:.3f} ± {s:.3f}" for n, k, t, tau, s in zip(
            r.n, r.packings, r.tails, r.tau, r.sigma, strict=True))
        print(f"| {p:g} | {r.x_min:.3g} | {per_n} | {r.delta:+.3f} | {r.z_asymptotic:+.2f} | "
              f"{r.boot_sigma:.3f} | {r.z_boot:+.2f} | {r.fraction_not_above:.3f} | "
              f"{r.slope:+.3f} ± {r.slope_sigma:.3f} | {r.z_slope:+.2f} |")
    for p in sorted(coarse, reverse=True):
        try:
            c = strain_step_slopes(coarse[p], windows[p], args.boot, args.seed)
        except ValueError as err:
            ap.error(f"p = {p:g}, --coarse: {err}")
        print(f"\np = {p:g}, the same window {c.x_min:.3g} at k δγ (the same minima, steps "
              f"grouped), {args.boot} packing resamples paired across k:\n")
        print("| strain step | " + " | ".join(f"τ, N = {n}" for n in c.n)
              + " | dτ/d ln N ± σ | z |")
        print("|---" * (len(c.n) + 3) + "|")
        rows = [f"{k} δγ" for k in c.k] + ["δγ → 0: 2 τ(δγ) − τ(2 δγ)"]
        for name, tau, slope, sig in zip(rows, c.tau, c.slope, c.slope_sigma, strict=True):
            print(f"| {name} | " + " | ".join(f"{t:.3f}" for t in tau)
                  + f" | {slope:+.3f} ± {sig:.3f} | {slope / sig:+.2f} |")
    for p in sorted(by_p, reverse=True) if args.shapes else ():
        ns = sorted(by_p[p])
        try:
            prof = {n: cutoff_shape_profile(np.concatenate(by_p[p][n]), windows[p],
                                            tuple(args.shapes)) for n in ns}
        except ValueError as err:
            ap.error(f"p = {p:g}, --shapes: {err}")
        grid = prof[ns[0]].stretches
        print(f"\np = {p:g}, the same window {windows[p]:.3g}, each size alone with the cut-off's "
              "shape a held fixed (asymptotic σ, avalanches as units):\n")
        print("| a | " + " | ".join(f"τ, N = {n}" for n in ns) + " | dτ/d ln N ± σ | z |")
        print("|---" * (len(ns) + 3) + "|")
        for i, a in enumerate(grid):
            tau = np.array([prof[n].taus[i] for n in ns])
            sig = np.array([prof[n].tau_stderrs[i] for n in ns])
            # τ = log e^τ: the weighted line of τ on ln N is fit_log_slope's, σ_log = σ
            f = fit_log_slope(ns, np.exp(tau), np.exp(tau) * sig)
            print(f"| {a:g} | " + " | ".join(f"{t:.3f}" for t in tau)
                  + f" | {f.slope:+.3f} ± {f.slope_err:.3f} | {f.slope / f.slope_err:+.2f} |")
        print("| preferred a (2Δlog L against a = 1) | " + " | ".join(
            f"{prof[n].best:g} ({prof[n].lr_exponential:.1f})" for n in ns) + " | | |")
    for p in sorted(by_p, reverse=True) if args.free_shapes else ():
        try:
            f = shared_tau(by_p[p], windows[p], tuple(args.shape_grid), min(args.boot, 500),
                           args.seed)
        except ValueError as err:
            ap.error(f"p = {p:g}, --free-shapes: {err}")
        print(f"\np = {p:g}, the same window {f.x_min:.3g}, each size with its own cut-off scale "
              f"and shape (a on a grid of {len(f.stretches)} from {f.stretches[0]:g} to "
              f"{f.stretches[-1]:g}):\n")
        print("| N | packings | sizes | best a | τ there | shape-free 95 % | a at the one τ |")
        print("|---|---|---|---|---|---|---|")
        for i, n in enumerate(f.n):
            edge = "*" if f.a_each[i] in (f.stretches[0], f.stretches[-1]) else ""
            print(f"| {n} | {f.packings[i]} | {f.tails[i]} | {f.a_each[i]:g}{edge} | "
                  f"{f.tau_each[i]:.3f} | [{f.low_each[i]:.3f}, {f.high_each[i]:.3f}] | "
                  f"{f.a_joint[i]:g} |")
        print("\n(* the best shape is an end of the grid: the maximum may lie beyond, and τ there "
              "is not resolved)" if any(a in (f.stretches[0], f.stretches[-1]) for a in f.a_each)
              else "")
        print(f"dτ/d ln N through the sizes' τ: {f.slope:+.3f} ± {f.slope_sigma:.3f} "
              f"({f.boot_used} packing resamples), z = {f.z_slope:+.2f}; one τ with every "
              f"size's cut-off free: {f.tau:.3f}, 95 % [{f.tau_low:.3f}, {f.tau_high:.3f}] "
              f"(σ ≈ {(f.tau_high - f.tau_low) / 3.92:.3f}); separate against one τ: "
              f"2Δlog L = {f.lr:.2f}, χ²_{f.dof} p = {f.p_value:.3g} (avalanches as units)")
    for p in sorted(by_p, reverse=True) if args.dispersion else ():
        print(f"\np = {p:g}, the same window {windows[p]:.3g}: are the packings alike? "
              "(log S: between / within packings, permutation p; counts: variance / mean, "
              "p of over-dispersion)\n")
        print("| N | packings (with ≥ 2 sizes) | sizes | mean log(S/x_min) | F, p | count mean, "
              "variance / mean, p |")
        print("|---|---|---|---|---|---|")
        for n in sorted(by_p[p]):
            try:
                d = packing_dispersion(by_p[p][n], windows[p], seed=args.seed)
            except ValueError as err:
                ap.error(f"p = {p:g}, N = {n}, --dispersion: {err}")
            print(f"| {n} | {d.n_packings} ({d.packings}) | {d.sizes} | {d.mean_log:.3f} | "
                  f"{d.f_ratio:.2f}, {d.f_p:.3f} | {d.count_mean:.1f}, {d.count_ratio:.2f}, "
                  f"{d.count_p:.3g} |")
    chi2, p_chi2, s, p_s = combined_scores(zs)
    print(f"\nover {len(zs)} pressure(s), bootstrap z of the slopes: Σ z² = {chi2:.2f} "
          f"(χ²_{len(zs)} p = {p_chi2:.2f}); Σ z/√k = {s:+.2f} (two-sided p = {p_s:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
