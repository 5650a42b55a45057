"""What the τ of a fixed-pressure run rests on: the plastic flag's threshold, the cut-off's shape.

For the avalanches of finished run directories (φ label ``jamming`` at ``--n``, jammed steps only,
as the report counts them; ``S = −ΔH`` at fixed pressure):

1. *Detection near the threshold.* Each sample's threshold of the plastic flag is recomputed from
   its trace (:func:`jamlab.spheres.confirm.plastic_threshold` with the shear's defaults; the
   script stops if a recorded plastic step does not pass it, i.e. if the recomputation is not the
   run's rule). Per bin of ``S / threshold``: how many avalanches, and ``−r_n / S`` (median and
   5–95 %), ``r_n`` the step's trapezoid residual. A step counts only if ``|r_n|`` passes the
   threshold, so where ``−r_n/S`` times the bin's lower end stays above 1 no event is lost.
2. *The cut-off's shape.* The window of the report's cut-off row (its KS rule,
   :func:`jamlab.reproduce.measurements.fit_tau_cutoff` without the bootstrap, which does not move
   ``x_min``), and windows at ``--thresholds`` times the largest threshold:
   :func:`jamlab.analysis.cutoff_shape_profile` there — τ and ``2Δlog L`` per ``a``, the
   likelihood ratio against the exponential cut-off and the interval of τ with ``a`` free.

3. *Which packings the shape rests on* (``--leave-out``): at the report's window (``x_min``
   fixed), the profile again with each packing's avalanches left out in turn
   (:func:`leave_one_out`): the best ``a``, τ there and the 95 % interval of τ with ``a`` free,
   ``2Δlog L`` against the exponential, and τ at ``a = 1``; the packings whose removal moves the
   verdict (exponential rejected or not) or the interval most; and the jackknife standard error
   over packings (packings, not avalanches, as the independent units) of τ at the best ``a``
   chosen again in each (a grid's argmax is not a smooth statistic: when the choice switches
   the jackknife overstates), at the best ``a`` of all the data held fixed, and at ``a = 1``.

Each run directory is analysed alone, pooling the ``--n`` it holds (a run without any of them is
refused); ``--pool`` pools all the runs into one analysis (e.g. the N = 500 and N = 1000 halves
of one pressure, run as two directories). A packing is labelled by its sample id, or, with
several (run, N) sources, by ``N · 10⁶ + id`` (``k · 10⁶ + id``, ``k`` the source's index, when
two sources share an N).

``--figure``: for the first analysis, the complementary CDF of the sizes in the report's window
beside the exponential and the best stretched model, and τ and ``2Δlog L`` against ``a``.

    PYTHONPATH=src python scripts/cutoff_shape.py RUNS/n1000-p1e-5 --n 1000 \\
        --figure docs/figures/cutoff_shape_n1000_p1e-5.png
    PYTHONPATH=src python scripts/cutoff_shape.py RUNS/pressure-1e-02 --n 500 1000
    PYTHONPATH=src python scripts/cutoff_shape.py RUNS/n500-p1e-2 RUNS/n1000-p1e-2 \\
        --n 500 1000 --pool
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from jamlab.analysis import cutoff_power_law_cdf, cutoff_shape_profile
from jamlab.analysis.avalanches import branch_residual, jammed_steps
from jamlab.analysis.cutoff_powerlaw import CHI2_1_95, DEFAULT_STRETCHES
from jamlab.analysis.jackknife import jackknife_variance
from jamlab.reproduce.ensembles import avalanche_set, finished
from jamlab.reproduce.measurements import fit_tau_cutoff
from jamlab.reproduce.scales import SCALES
from jamlab.reproduce.table import shape_text
from jamlab.runs import open_run
from jamlab.spheres.confirm import plastic_threshold
from jamlab.spheres.pressure_shear import CONFIRM_BELOW, PLASTIC_FLOOR

BINS = (1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0, 100.0, np.inf)


def detection(ds, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(S, r_n, threshold, sample)`` of every counted avalanche of ``(jamming, n)``, in the
    order of :func:`~jamlab.reproduce.ensembles.avalanche_set` (samples, then steps); ``sample``
    is the sample id of the packing each comes from."""
    d = ds.sel(phi="jamming", N=n)
    sizes, resid, thr, which = [], [], [], []
    for i in np.flatnonzero(finished(ds, "jamming", n)):
        t = d.isel(sample=int(i))
        hj, sj, g = t.energy_jump.values, t.stress_jump.values, t.gamma.values
        jm, pl = t.jammed.values > 0.5, t.plastic.values > 0.5
        steps = np.diff(g)
        threshold, passes, _ = plastic_threshold(hj, sj, g, jm, float(np.median(steps)),
                                                 PLASTIC_FLOOR, CONFIRM_BELOW)
        counted = pl[1:] & jammed_steps(jm) & (hj[1:] < 0)
        if np.any(counted & ~passes[1:]):
            raise SystemExit(f"sample {i}: a plastic step does not pass the recomputed "
                             f"threshold {threshold:.3g}: not the run's rule")
        r = branch_residual(hj[1:], sj[1:], steps)
        sizes.append(-hj[1:][counted])
        resid.append(r[counted])
        thr.append(np.full(int(counted.sum()), threshold))
        which.append(np.full(int(counted.sum()), int(d.sample.values[i])))
    return (np.concatenate(sizes), np.concatenate(resid), np.concatenate(thr),
            np.concatenate(which))


def plan(held: list[tuple[str, list[int]]], wanted: list[int],
         pool: bool) -> list[list[tuple[int, int]]]:
    """The analyses to make: per analysis the ``(run index, N)`` sources it pools. ``held``:
    per run its name and the N it holds; each run contributes the ``wanted`` N it holds, alone
    or (``pool``) all into one. ValueError naming a run that holds none of ``wanted``."""
    out = []
    for k, (name, ns) in enumerate(held):
        mine = [(k, n) for n in wanted if n in ns]
        if not mine:
            raise ValueError(f"{name}: holds N = {sorted(ns)}, none of --n {wanted}")
        out.append(mine)
    return [[src for part in out for src in part]] if pool else out


def packing_labels(ns: list[int], ids: list[np.ndarray]) -> np.ndarray:
    """One label per avalanche naming its packing, from each source's N and sample ids: the ids
    themselves for one source, else ``N · 10⁶ + id`` (``k · 10⁶ + id``, ``k`` the source's
    index, when two sources share an N)."""
    if len(ids) == 1:
        return np.asarray(ids[0])
    keys = ns if len(set(ns)) == len(ns) else list(range(len(ns)))
    return np.concatenate([k * 1_000_000 + np.asarray(i) for k, i in zip(keys, ids, strict=True)])


def leave_one_out(s: np.ndarray, groups: np.ndarray, x_min: float,
                  stretches: tuple[float, ...] = DEFAULT_STRETCHES) -> list[dict]:
    """The shape profile at ``x_min`` (over the grid ``stretches`` of ``a``) with each group's
    data left out in turn: per group (in increasing order of its label) ``group``, ``removed``
    (its data at or above ``x_min``) and the :class:`~jamlab.analysis.CutoffShapeProfile`
    ``profile`` of the rest. ValueError when the arrays differ in length or fewer than two
    groups have data."""
    s, groups = np.asarray(s, dtype=np.float64), np.asarray(groups)
    if s.shape != groups.shape:
        raise ValueError(f"{s.size} sizes but {groups.size} group labels")
    labels = np.unique(groups)
    if labels.size < 2:
        raise ValueError("leaving one out needs at least two groups")
    out = []
    for g in labels:
        keep = groups != g
        out.append({"group": g.item(), "removed": int(np.count_nonzero(~keep & (s >= x_min))),
                    "profile": cutoff_shape_profile(s[keep], x_min, stretches)})
    return out


def jackknife_se(values: np.ndarray) -> float:
    """The jackknife standard error from the leave-one-out estimates ``values``: the square root
    of :func:`jamlab.analysis.jackknife.jackknife_variance`."""
    return float(np.sqrt(jackknife_variance(np.ravel(values))))


def leave_out_report(s: np.ndarray, groups: np.ndarray, full) -> None:
    """Print :func:`leave_one_out` at the window of the profile ``full`` (of all the data)."""
    rows = leave_one_out(s, groups, full.x_min, full.stretches)
    one = full.stretches.index(1.0)
    rejected = full.lr_exponential > CHI2_1_95
    flips = [r["group"] for r in rows if (r["profile"].lr_exponential > CHI2_1_95) != rejected]
    print(f"\nleaving one packing out at S ≥ {full.x_min:.3g} (all: best a = {full.best:g}, "
          f"τ {full.tau_best:.3f}, [{full.tau_low:.3f}, {full.tau_high:.3f}], 2Δlog L vs "
          f"exponential {full.lr_exponential:.1f}):\n")
    print("| packing left out | its sizes in the window | best a | τ there | 95 % interval, a free "
          "| 2Δlog L vs exponential | τ at a = 1 |")
    print("|---|---|---|---|---|---|---|")
    order = sorted(rows, key=lambda r: -abs(r["profile"].tau_low - full.tau_low))
    for r in order:
        p = r["profile"]
        flip = " (verdict flips)" if r["group"] in flips else ""
        print(f"| {r['group']} | {r['removed']} | {p.best:g} | {p.tau_best:.3f} | "
              f"[{p.tau_low:.3f}, {p.tau_high:.3f}] | {p.lr_exponential:.1f}{flip} | "
              f"{p.taus[one]:.3f} |")
    low = np.array([r["profile"].tau_low for r in rows])
    lr = np.array([r["profile"].lr_exponential for r in rows])
    print(f"\n{len(rows)} packings: lower end of the interval {low.min():.3f} … {low.max():.3f}; "
          f"best a {min(r['profile'].best for r in rows):g} … "
          f"{max(r['profile'].best for r in rows):g}; 2Δlog L vs exponential {lr.min():.1f} … "
          f"{lr.max():.1f}; the verdict flips without packing(s) {flips or 'none'}")
    best = full.stretches.index(full.best)
    print(f"jackknife over packings: τ at the best a {full.tau_best:.3f} ± "
          f"{jackknife_se(np.array([r['profile'].tau_best for r in rows])):.3f} (a chosen again "
          f"from the grid in each: not smooth, so the jackknife overstates), at a = "
          f"{full.best:g} held fixed ± "
          f"{jackknife_se(np.array([r['profile'].taus[best] for r in rows])):.3f} (asymptotic "
          f"{full.tau_best_stderr:.3f}); τ at a = 1 {full.taus[one]:.3f} ± "
          f"{jackknife_se(np.array([r['profile'].taus[one] for r in rows])):.3f} (asymptotic "
          f"{full.tau_stderrs[one]:.3f})")


def figure(path: Path, s: np.ndarray, p, title: str) -> None:
    """The complementary CDF in the window with the exponential and best models; the profile."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tail = np.sort(s[s >= p.x_min])
    ccdf = 1.0 - np.arange(tail.size) / tail.size
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    ax.loglog(tail, ccdf, "k.", ms=2, label=f"data ({tail.size} sizes)")
    grid = np.geomspace(p.x_min, tail[-1], 300)
    for a, style in ((1.0, "C0-"), (p.best, "C3--")):
        i = p.stretches.index(a)
        ccdf_model = 1.0 - cutoff_power_law_cdf(grid, p.taus[i], p.x_cs[i], p.x_min, stretch=a)
        ax.loglog(grid, ccdf_model, style,
                  label=f"a = {a:g}: τ = {p.taus[i]:.3f}, S_c = {p.x_cs[i]:.2g}")
    ax.set_xlabel("S (ε)")
    ax.set_ylabel("P(S' > S)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    best = max(p.logliks)
    bx.plot(p.stretches, p.taus, "C0o-")
    bx.set_xscale("log")
    bx.set_xticks([0.2, 0.3, 0.5, 1.0, 2.0], ["0.2", "0.3", "0.5", "1", "2"])
    bx.minorticks_off()
    bx.set_xlabel("cut-off shape a")
    bx.set_ylabel("τ at fixed a", color="C0")
    bx.axhspan(p.tau_low, p.tau_high, color="C0", alpha=0.12,
               label=f"95 % interval of τ, a free [{p.tau_low:.2f}, {p.tau_high:.2f}]")
    bx.legend(fontsize=8, loc="center right")
    cx = bx.twinx()
    cx.plot(p.stretches, [2 * (v - best) for v in p.logliks], "C3s--")
    cx.axhline(-3.84, color="C3", lw=0.8, ls=":")
    cx.set_ylabel("2Δlog L against the best a (dotted: −3.84)", color="C3")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"\nfigure: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--n", type=int, nargs="+", default=[1000], help="sizes N, pooled")
    ap.add_argument("--scale", default="medium", choices=sorted(SCALES))
    ap.add_argument("--thresholds", type=float, nargs="*", default=[2.0, 5.0, 20.0],
                    help="further windows, S >= this many times the largest threshold")
    ap.add_argument("--figure", type=Path, default=None)
    ap.add_argument("--leave-out", action="store_true",
                    help="the report's window again with each packing left out in turn")
    ap.add_argument("--pool", action="store_true",
                    help="pool all the runs into one analysis (default: each run alone)")
    a = ap.parse_args()
    scale = SCALES[a.scale]
    datasets = [open_run(run) for run in a.runs]
    try:
        analyses = plan([(str(run), [int(n) for n in ds.N.values])
                         for run, ds in zip(a.runs, datasets, strict=True)], a.n, a.pool)
    except ValueError as err:
        ap.error(str(err))
    for first, sources in enumerate(analyses):
        parts = [detection(datasets[k], n) for k, n in sources]
        s, r, thr, _ = (np.concatenate(v) for v in zip(*parts, strict=True))
        which = packing_labels([n for _, n in sources], [p[3] for p in parts])
        counted = np.concatenate([avalanche_set(datasets[k], "jamming", n).sizes
                                  for k, n in sources])
        paths = [a.runs[k] for k in dict.fromkeys(k for k, _ in sources)]
        run = " + ".join(str(q) for q in paths)
        ns = sorted({n for _, n in sources})
        if not np.array_equal(np.sort(s), np.sort(counted)):
            raise SystemExit(f"{run}: the recomputed avalanches are not the report's")
        print(f"\n# {run}, N = {ns}: {s.size} avalanches; thresholds of the plastic flag "
              f"{thr.min():.3g} … {thr.max():.3g} (median {np.median(thr):.3g}) ε\n")
        print("| S / threshold | avalanches | −r_n/S, median | −r_n/S, 5–95 % |")
        print("|---|---|---|---|")
        x = s / thr
        for lo, hi in zip(BINS[:-1], BINS[1:], strict=True):
            k = (x >= lo) & (x < hi)
            if k.any():
                q = np.quantile(-r[k] / s[k], [0.05, 0.5, 0.95])
                print(f"| {lo:g}–{hi:g} | {int(k.sum())} | {q[1]:.3f} | {q[0]:.3f}–{q[2]:.3f} |")
        cut = fit_tau_cutoff(s, replace(scale, n_boot=0))
        if cut is not None:
            print(f"\nthe report's cut-off row: τ = {cut.tau:.3f} (exponential cut-off, "
                  f"S ≥ {cut.x_min:.3g}, {cut.n_tail} sizes)")
        windows = [("the report's cut-off row (KS window)", None if cut is None else cut.x_min)]
        windows += [(f"{k:g} × the largest threshold", k * float(thr.max()))
                    for k in a.thresholds]
        for name, x_min in windows:
            if x_min is None or np.count_nonzero(s >= x_min) < 10:
                print(f"\n{name}: too few sizes")
                continue
            p = cutoff_shape_profile(s, x_min)
            print(f"\n{name}, S ≥ {x_min:.3g}: {shape_text(p)}\n")
            print("| a | " + " | ".join(f"{v:g}" for v in p.stretches) + " |")
            print("|---" * (len(p.stretches) + 1) + "|")
            print("| τ | " + " | ".join(f"{v:.3f}" for v in p.taus) + " |")
            best = max(p.logliks)
            print("| 2Δlog L | " + " | ".join(f"{2 * (v - best):.1f}" for v in p.logliks) + " |")
            if a.leave_out and x_min == windows[0][1]:
                leave_out_report(s, which, p)
            if a.figure is not None and first == 0 and x_min == windows[0][1]:
                figure(a.figure, s, p, " + ".join(q.name for q in paths)
                       + f", N = {ns}: the report's cut-off window")


if __name__ == "__main__":
    main()
