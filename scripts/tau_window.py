"""τ against the lower end of the fit window, for the avalanches of finished run directories.

The scale's rule (:func:`jamlab.reproduce.measurements.fit_tau`: a power law truncated at the
largest size, ``S_min`` by the KS rule, a bootstrap interval that includes the choice of
``S_min``) gives one number; this script shows what it rests on: for each run directory (avalanches
of the φ label ``jamming`` at ``--n``, jammed steps only, as the report counts them) the maximum-
likelihood τ with ``S_min`` at the quantiles ``--quantiles`` of the sizes (its asymptotic error
``(τ − 1)/√n_tail``) beside the τ of a power law with an exponential cut-off at the same
``S_min`` (:func:`jamlab.analysis.cutoff_powerlaw.fit_cutoff_power_law`: the cut-off ``S_c`` fitted
too, so a finite-size bend of the tail does not tilt τ), the rule's fit, and a figure: the
complementary CDFs and both local τ against ``S_min``.

    PYTHONPATH=src python scripts/tau_window.py RUNS/pressure-1e-04 RUNS/pressure-1e-03 \\
        --n 500 --figure docs/figures/tau_window_medium.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from jamlab.analysis import fit_cutoff_power_law, fit_power_law
from jamlab.reproduce.measurements import avalanche_set, fit_tau, tau_sigma
from jamlab.reproduce.scales import SCALES
from jamlab.runs import open_run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--scale", default="medium", choices=sorted(SCALES))
    ap.add_argument("--quantiles", type=float, nargs="+",
                    default=[0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])
    ap.add_argument("--figure", type=Path, default=None)
    a = ap.parse_args()
    scale = SCALES[a.scale]
    curves = {}
    for run in a.runs:
        s = np.sort(avalanche_set(open_run(run), "jamming", a.n).sizes)
        if s.size < scale.min_tail:
            print(f"\n{run}: {s.size} avalanches, too few for a fit")
            continue
        rule = fit_tau(s, scale)
        print(f"\n{run} (N = {a.n}): {s.size} avalanches, S from {s[0]:.2e} to {s[-1]:.2e}; "
              f"the scale's rule: τ = {rule.tau:.3f} ± {tau_sigma(rule):.3f} "
              f"(95 % [{rule.ci_low:.3f}, {rule.ci_high:.3f}]) on S ≥ {rule.x_min:.2e}, "
              f"{rule.n_tail} sizes\n")
        print("| S_min (quantile) | sizes in the tail | τ (MLE, truncated at the largest) "
              "| τ with an exponential cut-off | its S_c |")
        print("|---|---|---|---|---|")
        xs, ts, es, tc, ec = [], [], [], [], []
        for q in a.quantiles:
            xm = float(s[min(int(q * s.size), s.size - 2)])
            f = fit_power_law(s, x_min=xm, x_max=float(s[-1]))
            c = fit_cutoff_power_law(s, xm) if (s >= xm).sum() >= 10 else None
            cut = ("— | —" if c is None else f"{c.tau:.3f} ± {c.tau_stderr:.3f} | "
                   + ("none resolved" if c.at_bound else f"{c.x_c:.2e}"))
            print(f"| {xm:.2e} ({q:g}) | {f.n_tail} | {f.tau:.3f} ± {f.tau_stderr:.3f} | {cut} |")
            xs.append(xm)
            ts.append(f.tau)
            es.append(f.tau_stderr)
            tc.append(np.nan if c is None else c.tau)
            ec.append(np.nan if c is None else c.tau_stderr)
        curves[run.name] = (s, np.array(xs), np.array(ts), np.array(es), rule, np.array(tc),
                            np.array(ec))
    if a.figure is not None and curves:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(13, 4.4))
        for name, (s, xs, ts, es, rule, tc, ec) in curves.items():
            (line,) = ax[0].loglog(s, 1.0 - np.arange(s.size) / s.size, ".", ms=3,
                                   label=f"{name} ({s.size})")
            ax[1].errorbar(xs, ts, yerr=es, fmt="o-", ms=3, color=line.get_color(),
                           label=f"{name}: truncated power law")
            ax[1].errorbar(xs * 1.08, tc, yerr=ec, fmt="s--", ms=3, mfc="none",
                           color=line.get_color(), label=f"{name}: with exponential cut-off")
            ax[1].axvline(rule.x_min, color=line.get_color(), ls=":", lw=1)
        ax[0].set_xlabel("avalanche size S (ε)")
        ax[0].set_ylabel("P(size ≥ S)")
        ax[0].set_title(f"N = {a.n}, jammed steps only")
        ax[0].legend(fontsize=8)
        ax[1].set_xscale("log")
        ax[1].axhline(1.41269, color="k", lw=0.8, label="τ_J = 1.41269 (mean field)")
        ax[1].axhspan(1.52 - 0.075, 1.52 + 0.075, color="0.85", label="paper's fit 1.52 ± 0.075")
        ax[1].set_xlabel("S_min, lower end of the fit window (ε)")
        ax[1].set_ylabel("τ (MLE on S ≥ S_min)")
        ax[1].set_ylim(0.85, 1.9)
        ax[1].set_title("local τ on S ≥ S_min; dotted: S_min of the scale's rule", fontsize=9)
        ax[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0)
        fig.tight_layout()
        a.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(a.figure, dpi=130)
        print(f"\nfigure: {a.figure}")


if __name__ == "__main__":
    main()
