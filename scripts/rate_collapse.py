"""Do the avalanches of several sizes collapse as ``n_N(≥ S) = N^(−b) F(S/N^a)``? And is τ in one
window the same for all N once the window scales with the sizes?

The run directories (``jamlab run`` studies at fixed pressure, one N each; several realisations
of one N are pooled) are grouped by pressure; each pressure needs two sizes or more. For each
pressure, from ``--s-min`` up (ε; above the plastic flag's losses of every size):

- the rate collapse (:func:`jamlab.analysis.rate_collapse`): the exponents ``a`` (sizes ``∝
  N^a``) and ``b`` (rate per particle and unit strain at a fixed scaled size ``∝ N^(−b)``),
  their σ and correlation from ``--boot`` resamples of each size's packings, the collapse's RMS
  (decades) there, unrescaled, and with the rate alone rescaled;
- τ per N with an exponential cut-off (:func:`jamlab.analysis.size_difference`, the slope ``dτ/d
  ln N`` with its σ from the same number of packing resamples) in the pooled KS window
  ``x_min`` (as ``size_dependence.py``), and again in the window ``x_min (N/N_0)^a`` that scales
  with the sizes (``N_0`` the smallest size; ``a`` the collapse's, fitted on the same data).

``--figure F`` (``.png``, ``.pdf`` or ``.svg``, not inside a run directory): one column per
pressure; above, the collapsed curves ``N^b n_N(≥ S)`` against ``S/N^a``; below, each size's
local exponent ``τ(S) = 1 − d ln n_N / d ln S`` (the cumulative rate's slope over half a decade)
against the same scaled size: where the sizes' shapes differ.

The exposure of a packing is the strain it was sheared over
(``jamlab.reproduce.ensembles.sample_strains``; finished samples only, as the report counts
them).

    R=data/runs
    PYTHONPATH=src python scripts/rate_collapse.py $R/n250-p1e-4-vg $R/n500-p1e-4-vg \\
        $R/n1000-p1e-4-vg $R/n2000-p1e-4-vg --s-min 2e-9
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from jamlab.analysis import cumulative_rates, rate_collapse, size_difference
from jamlab.reproduce.ensembles import sample_strains
from jamlab.reproduce.measurements import avalanche_set, fit_tau_cutoff
from jamlab.reproduce.scales import SCALES
from jamlab.runs import check_figure_path, open_pressure_run


def figure(fits: dict, groups: dict, strain: dict, least: int, path: Path) -> None:
    """The figure of ``--figure`` (module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ps = sorted(fits, reverse=True)
    fig, ax = plt.subplots(2, len(ps), figsize=(3.6 * len(ps), 5.8), squeeze=False,
                           gridspec_kw={"height_ratios": [3, 2]})
    half = 10  # grid points per half decade (20 per decade)
    for col, p in enumerate(ps):
        c = fits[p]
        curves = cumulative_rates(groups[p], strain[p], c.s_min, least)
        for n, (s, rate) in curves.items():
            x = s / n**c.a
            line, = ax[0, col].loglog(x, rate * n**c.b, "-", label=f"N = {n}")
            if s.size > half:
                local = 1 - np.log(rate[half:] / rate[:-half]) / np.log(s[half:] / s[:-half])
                mid = np.sqrt(x[half:] * x[:-half])
                ax[1, col].semilogx(mid, local, "-", color=line.get_color())
        ax[0, col].set_title(f"p = {p:g}: a = {c.a:.2f}, b = {c.b:.2f}", fontsize=9)
        ax[1, col].set_xlabel("S / N^a (ε)")
        ax[0, col].legend(fontsize=7)
    ax[0, 0].set_ylabel("N^b n_N(≥ S) (per particle, unit strain)")
    ax[1, 0].set_ylabel("local τ (half-decade slope)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"\nfigure: {path}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="fixed-pressure run directories, one N each")
    ap.add_argument("--s-min", type=float, required=True,
                    help="smallest avalanche size of the collapse (ε)")
    ap.add_argument("--least", type=int, default=20,
                    help="avalanches at or above a size for it to enter the collapse")
    ap.add_argument("--boot", type=int, default=200, help="packing resamples per pressure")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--figure", type=Path, default=None,
                    help="collapsed curves and local exponents (.png, .pdf or .svg)")
    args = ap.parse_args(argv)
    check_figure_path(ap, args.figure, args.runs)
    if not (np.isfinite(args.s_min) and args.s_min > 0):
        ap.error(f"--s-min must be a number > 0, got {args.s_min}")
    if args.least < 1:
        ap.error(f"--least must be >= 1, got {args.least}")
    if args.boot < 2:
        ap.error(f"--boot must be >= 2, got {args.boot}")
    by_p: dict[float, dict[int, list[np.ndarray]]] = {}
    strain: dict[float, dict[int, list[float]]] = {}
    for path in args.runs:
        ds, pressure, n = open_pressure_run(ap, path)
        strain.setdefault(pressure, {}).setdefault(n, []).extend(
            sample_strains(ds, "jamming", n))
        by_p.setdefault(pressure, {}).setdefault(n, []).extend(
            avalanche_set(ds, "jamming", n).per_sample)
    scale = replace(SCALES["medium"], n_boot=0)
    fits = {}
    for p in sorted(by_p, reverse=True):
        groups = by_p[p]
        if len(groups) < 2:
            ap.error(f"p = {p:g}: need two sizes N or more, got {sorted(groups)}")
        try:
            c = rate_collapse(groups, strain[p], args.s_min, least=args.least, boot=args.boot,
                              seed=args.seed)
        except ValueError as err:
            ap.error(f"p = {p:g}: {err}")
        fits[p] = c
        print(f"\np = {p:g}, S ≥ {c.s_min:.3g} ε; N: packings, avalanches, mean strain per "
              "packing: " + "; ".join(f"{n}: {k}, {t}, {np.mean(strain[p][n]):g}" for n, k, t in
                                      zip(c.n, c.packings, c.tails, strict=True)))
        print(f"rate collapse n_N(≥ S) = N^(−b) F(S/N^a): a = {c.a:.3f} ± {c.a_sigma:.3f}, "
              f"b = {c.b:.3f} ± {c.b_sigma:.3f} (correlation {c.correlation:+.2f}, "
              f"{c.boot_used} packing resamples); RMS {c.rms:.4f} decades (unrescaled "
              f"{c.rms_none:.4f}; rate alone, b = {c.b_rate_only:.3f}: {c.rms_rate_only:.4f})")
        cut = fit_tau_cutoff(np.concatenate([np.concatenate(g) for g in groups.values()]), scale)
        if cut is None:
            ap.error(f"p = {p:g}: too few avalanches for the pooled cut-off fit")
        n0 = min(groups)
        print("\n| window | N: window (ε), sizes, τ ± asymptotic σ | dτ/d ln N ± σ (packings) | "
              "z |")
        print("|---|---|---|---|")
        for name, a in (("fixed", 0.0), (f"∝ N^{c.a:.3f}", c.a)):
            # τ of an exponential cut-off is unchanged when the sizes and the window are divided
            # by one number: the window x_min (N/N_0)^a is x_min for the sizes / (N/N_0)^a
            scaled = {n: [s / (n / n0) ** a for s in v] for n, v in groups.items()}
            try:
                r = size_difference(scaled, cut.x_min, args.boot, args.seed)
            except ValueError as err:
                ap.error(f"p = {p:g}, window {name}: {err}")
            per_n = "; ".join(f"{n}: {cut.x_min * (n / n0) ** a:.3g}, {t}, {tau:.3f} ± {s:.3f}"
                              for n, t, tau, s in zip(r.n, r.tails, r.tau, r.sigma, strict=True))
            print(f"| {name} | {per_n} | {r.slope:+.3f} ± {r.slope_sigma:.3f} | "
                  f"{r.z_slope:+.2f} |")
    if args.figure is not None:
        figure(fits, by_p, strain, args.least, args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
