"""The anatomy of fixed-pressure avalanches against S, N and p: pooled ``events.npz`` files of
``scripts/avalanche_anatomy.py`` (one per state), one figure and one table.

    PYTHONPATH=src python scripts/anatomy_by_pressure.py DIR_p1e-3 DIR_p1e-4 DIR_p1e-5 \
        --figure docs/figures/anatomy_pressure.png

Counted: plastic steps between two jammed minima with ``S > 0``
(``avalanche_anatomy.counted``). Left panel: the share of localized events (``N_eff ≤ 10``) per
decade of S, each state, binomial errors, decades with ≥ 10 events. Right panel: the median
``N_eff / N`` of the extended events per decade of S, each state and N (points with ≥ 5
events). Printed: the same per decade with the counts, the growth of the median ``N_eff`` with
N, and a two-sample KS test of the sizes of the two classes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.stats import ks_2samp  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from avalanche_anatomy import counted  # noqa: E402  (scripts run as scripts)

EDGES = np.logspace(-12, -3, 10)
MIN_EVENTS = 10
"""Decades with fewer events are printed, not drawn in the left panel."""
SIZE_STYLES = ["o-", "s--", "^:", "D-."]
"""One marker and line style per size of a state (with three, the fourth size of p = 1e-4 wrapped
onto the first: N = 250 and N = 2000 were drawn alike)."""


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path / "events.npz") as f:
        a = {k: f[k] for k in f.files}
    ok = counted(a)
    return {k: v[ok] for k, v in a.items()}


def neff_growth(a: dict[str, np.ndarray], resamples: int = 2000, seed: int = 0) -> str:
    """The exponent of ``median N_eff ~ N^x`` over the sizes of one state (all counted events),
    least squares in log-log, with a bootstrap over samples (seeds resampled within each N)."""
    sizes = np.unique(a["N"])
    if sizes.size < 2:
        return "one N only"
    by = {n: [a["n_eff"][(a["N"] == n) & (a["seed"] == s)]
              for s in np.unique(a["seed"][a["N"] == n])] for n in sizes}  # fmt: skip

    def fit(groups: list[np.ndarray]) -> float:
        return float(np.polyfit(np.log(sizes), np.log([np.median(g) for g in groups]), 1)[0])

    x = fit([np.concatenate(by[n]) for n in sizes])
    rng = np.random.default_rng(seed)
    boot = [fit([np.concatenate([by[n][i] for i in rng.integers(0, len(by[n]), len(by[n]))])
                 for n in sizes]) for _ in range(resamples)]  # fmt: skip
    lo, hi = np.quantile(boot, [0.025, 0.975])
    meds = ", ".join(f"{np.median(np.concatenate(by[n])):.1f}" for n in sizes)
    return (f"median N_eff = {meds} at N = {', '.join(str(n) for n in sizes)}: N_eff ~ N^{x:.3f} "
            f"± {np.std(boot):.3f} (95 % [{lo:.3f}, {hi:.3f}], {resamples} resamples of the "
            "samples)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", type=Path, nargs="+")
    ap.add_argument("--figure", type=Path, default=None)
    args = ap.parse_args()
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4))
    mid = np.sqrt(EDGES[1:] * EDGES[:-1])
    for k, d in enumerate(args.dirs):
        a = load(d)
        state = str(a["state"][0]) if a["S"].size else d.name
        loc = a["localized"].astype(bool)
        print(f"== {state}: {a['S'].size} avalanches, {int(loc.sum())} localized "
              f"({loc.mean():.3f} of the events, {a['S'][loc].sum() / a['S'].sum():.3f} of ΣS)")
        print("  " + neff_growth(a))
        print("  decade      events  localized share  median N_eff/N (extended) per N")
        share = np.full(mid.size, np.nan)
        for b in range(mid.size):
            m = (a["S"] >= EDGES[b]) & (a["S"] < EDGES[b + 1])
            if not m.any():
                continue
            share[b] = loc[m].mean()
            per_n = []
            for n in np.unique(a["N"]):
                e = m & ~loc & (a["N"] == n)
                per_n.append(f"N={n}: {np.median(a['n_eff'][e]) / n:.3f} ({int(e.sum())})"
                             if e.any() else f"N={n}: -")  # fmt: skip
            print(f"  [{EDGES[b]:.0e}, {EDGES[b + 1]:.0e})  {int(m.sum()):5d}  {share[b]:7.3f}"
                  f"          " + "  ".join(per_n))
        counts = np.histogram(a["S"], bins=EDGES)[0]
        good = counts >= MIN_EVENTS
        err = np.sqrt(share * (1 - share) / np.maximum(counts, 1))
        ax0.errorbar(mid[good], share[good], yerr=err[good], fmt="o-", color=f"C{k}", capsize=2,
                     label=state)  # fmt: skip
        if loc.sum() >= 5 and (~loc).sum() >= 5:
            ks = ks_2samp(a["S"][loc], a["S"][~loc])
            print(f"  S of localized vs extended: KS D = {ks.statistic:.3f}, p = {ks.pvalue:.3g}; "
                  f"median S {np.median(a['S'][loc]):.2e} vs {np.median(a['S'][~loc]):.2e}")
        for j, n in enumerate(np.unique(a["N"])):
            med = np.full(mid.size, np.nan)
            for b in range(mid.size):
                e = (a["S"] >= EDGES[b]) & (a["S"] < EDGES[b + 1]) & ~loc & (a["N"] == n)
                if e.sum() >= 5:
                    med[b] = np.median(a["n_eff"][e]) / n
            g = ~np.isnan(med)
            ax1.plot(mid[g], med[g], SIZE_STYLES[j % len(SIZE_STYLES)], color=f"C{k}",
                     label=f"{state}, N = {n}")  # fmt: skip
    ax0.set(xscale="log", xlabel="S (ε)", ylabel="localized share (N_eff ≤ 10)", ylim=(0, None),
            title=f"localized events per decade of S (≥ {MIN_EVENTS} events)")
    ax1.set(xscale="log", yscale="log", xlabel="S (ε)", ylabel="median N_eff / N (extended)",
            title="extent of the extended events (≥ 5 per point)")
    ax0.legend(fontsize=8)
    ax1.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))  # off the curves
    fig.tight_layout()
    if args.figure is not None:
        args.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.figure, dpi=120)
        print(f"figure -> {args.figure}")


if __name__ == "__main__":
    main()
