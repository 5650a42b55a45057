"""The strain step of finished runs, without a rerun: their avalanche sizes seen at ``k δγ``.

For the avalanches of finished run directories (φ label ``jamming`` at each ``--n``, jammed steps
only, as the report counts them), the trace's steps are grouped ``k`` at a time for each ``k`` of
``--k`` (:func:`jamlab.reproduce.ensembles.coarse_avalanches`, by
:func:`jamlab.analysis.coarsen_steps`: what a run at ``k δγ`` through the same minima would have
recorded), and the avalanches recounted with the report's rule (plastic, ``ΔE < 0``, every
minimum of the block jammed). Per ``k``:

- avalanches per unit strain and per sample, and the plastic steps lost because ``ΔE ≥ 0``;
- ``½ δγ ΔΣ`` of the elastic steps (median): the branch's curvature energy over one step, which
  a jump must exceed to show ``ΔE < 0``;
- quantiles of ``S`` (10, 25, 50 %): the lower part of the distribution, the one ``δγ`` can move;
- τ of the exponential cut-off (:func:`jamlab.analysis.fit_cutoff_power_law` at a fixed
  ``S_min``) at the report's window (its KS rule at ``k = 1``) and at ``--smin`` values.

Where the change from ``k = 1`` to ``k = 2`` grows with ``k`` (the sequence shows it), halving
``δγ`` is expected to move a value by less than doubling it does, and the run's ``δγ`` is
converged where that difference is within the statistical error. Where it is not, the sequence
gives the order of the ``δγ → 0`` correction (it is not an upper bound on it: the steps add up).
``k = 1`` must reproduce the report's avalanches exactly (the script stops otherwise).
``scripts/dgamma_convergence.py`` is the direct check: the same packings rerun at smaller ``δγ``.

``--figure``: ``S P(S)`` per unit strain against ``S`` for every ``k``, one panel per run.

    PYTHONPATH=src python scripts/dgamma_coarse.py RUNS/pressure-1e-03 RUNS/pressure-1e-04 \\
        --n 500 1000 --figure docs/figures/dgamma_coarse.png
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from jamlab.analysis import fit_cutoff_power_law, log_histogram
from jamlab.reproduce.ensembles import avalanche_set, coarse_avalanches
from jamlab.reproduce.measurements import fit_tau_cutoff
from jamlab.reproduce.scales import SCALES
from jamlab.runs import open_run


def tau_at(s: np.ndarray, s_min: float) -> str:
    if np.count_nonzero(s >= s_min) < 30:
        return "—"
    f = fit_cutoff_power_law(s, s_min)
    return f"{f.tau:.3f} ± {f.tau_stderr:.3f} ({f.n_tail})"


def figure(path: Path, panels: list, ks: list[int]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = min(4, len(panels))
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.6 * rows), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, (title, per_k) in zip(axes.flat, panels, strict=False):
        lo = min(float(v.sizes.min()) for v in per_k.values())
        hi = max(float(v.sizes.max()) for v in per_k.values())
        for k in ks:
            v = per_k[k]
            # one range for every k; density per size, rescaled to per unit strain (summed
            # over the samples)
            h = log_histogram(v.sizes, 3, range=(lo, hi * 1.0001))
            dens = h.density * v.sizes.size / v.strain * h.centres
            ok = h.counts > 0
            ax.loglog(h.centres[ok], dens[ok], "o-", ms=3, lw=1,
                      label=f"{k} δγ: {v.sizes.size} avalanches")
        ax.set_xlabel("S (ε)")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7)
    for ax in axes[:, 0]:
        ax.set_ylabel("S P(S) per unit strain and sample")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"\nfigure: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--n", type=int, nargs="+", default=[1000], help="sizes N, each on its own")
    ap.add_argument("--k", type=int, nargs="+", default=[1, 2, 4, 8])
    ap.add_argument("--smin", type=float, nargs="*", default=[1e-9, 3e-9, 1e-8, 3e-8, 1e-7])
    ap.add_argument("--scale", default="medium", choices=sorted(SCALES))
    ap.add_argument("--figure", type=Path, default=None)
    a = ap.parse_args()
    if a.k[0] != 1 or sorted(set(a.k)) != a.k:
        raise SystemExit("--k must start at 1 and increase")
    scale = replace(SCALES[a.scale], n_boot=0)
    panels = []
    for run in a.runs:
        ds = open_run(run)
        for n in a.n:
            if n not in ds.N.values:
                continue
            per_k = {k: coarse_avalanches(ds, "jamming", n, k) for k in a.k}
            report = avalanche_set(ds, "jamming", n).sizes
            if not np.array_equal(per_k[1].sizes, report):
                raise SystemExit(f"{run}, N = {n}: k = 1 does not give the report's avalanches")
            dgamma = float(np.median(np.diff(ds.sel(phi="jamming", N=n).gamma.values[0])))
            cut = fit_tau_cutoff(report, scale)
            windows = ([cut.x_min] if cut is not None else []) + list(a.smin)
            pressure = json.loads(ds.attrs["study"]).get("pressure")
            largest = "" if pressure is None or not report.size else (
                f"; the largest size {report.max():.3g} ε = {report.max() / pressure:.2f} p")
            print(f"\n# {run}, N = {n}: {per_k[1].samples} samples, δγ = {dgamma:.3g}; "
                  f"the report's cut-off window S ≥ "
                  f"{'—' if cut is None else f'{cut.x_min:.3g}'}{largest}\n")
            head = ["k δγ", "avalanches per unit strain and sample", "lost (ΔE ≥ 0)",
                    "½ δγ ΔΣ elastic, median", "S at 10 / 25 / 50 %"]
            head += [f"τ, S ≥ {w:.3g}" + (" (report)" if cut is not None and i == 0 else "")
                     for i, w in enumerate(windows)]
            print("| " + " | ".join(head) + " |")
            print("|---" * len(head) + "|")
            for k in a.k:
                v = per_k[k]
                s = v.sizes
                q = np.quantile(s, [0.1, 0.25, 0.5])
                row = [f"{k * dgamma:.2g}", f"{s.size / v.strain:.3g}", str(v.lost),
                       f"{np.median(v.curvature):.2g}",
                       " / ".join(f"{x:.2g}" for x in q)]
                row += [tau_at(s, w) for w in windows]
                print("| " + " | ".join(row) + " |")
            panels.append((f"{run.name}, N = {n}", per_k))
    if a.figure is not None and panels:
        figure(a.figure, panels, a.k)


if __name__ == "__main__":
    main()
