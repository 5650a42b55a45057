"""Is the strain step small enough? Avalanches at fixed pressure over one strain window, δγ varied.

For each ``δγ`` in ``--dgamma`` and sample seeds ``1 … --samples``: ``jam(N, 3, seed,
p_target=p)`` and fixed-pressure AQS over the same strain window ``--strain`` (``strain/δγ``
steps; :func:`finite_size_pressure.run_samples`, the default Newton path and plastic flag, one
cache file per sample: a rerun continues). The packings are the same for every ``δγ``, so any
difference is the step's.

If ``δγ`` exceeds the strain between events (near jamming the linear-response strain shrinks
with ``p``), one step holds several events and the flag counts them as one: fewer, larger
avalanches. So, per ``δγ``: the number of avalanches per unit strain, ``⟨S⟩``, the dissipation
``ΣS`` per unit strain (a sum over events: unchanged by merging, changed by missed events) and
τ (power law with an exponential cut-off at a fixed floor), all **above one common floor**,
10 × the largest plastic-flag threshold of all runs (the flag's threshold depends on ``δγ``
through the noise of the trapezoid residual; below the floor a smaller ``δγ`` resolves more
small events whether or not the larger one merges them). Errors: bootstrap over samples
(500 resamples). The two-sample KS test compares each ``δγ`` with the smallest above the floor.

    PYTHONPATH=src python scripts/dgamma_convergence.py --n 250 --pressure 1e-5 \\
        --strain 2e-3 --dgamma 1e-5 3e-6 1e-6 --samples 30 --cache dg-cache --workers 2 \\
        --figure docs/figures/dgamma_p1e-5.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from jamlab.analysis.cutoff_powerlaw import fit_cutoff_power_law

sys.path.insert(0, str(Path(__file__).resolve().parent))
from finite_size_pressure import (  # noqa: E402  (scripts run as scripts)
    read_sample,
    run_samples,
    sample_file,
)


def bootstrap(per_sample: list[np.ndarray], stat, n_boot: int = 500, seed: int = 1) -> float:
    """Standard deviation of ``stat(list of samples)`` over resamples of the samples."""
    rng = np.random.default_rng(seed)
    k = len(per_sample)
    vals = [stat([per_sample[i] for i in rng.integers(0, k, k)]) for _ in range(n_boot)]
    vals = np.asarray(vals, dtype=np.float64)
    return float(np.nanstd(vals[np.isfinite(vals)], ddof=1))


def mean_size(samples: list[np.ndarray]) -> float:
    s = np.concatenate(samples)
    return float(s.mean()) if s.size else np.nan


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--pressure", type=float, default=1e-5)
    ap.add_argument("--strain", type=float, default=2e-3)
    ap.add_argument("--dgamma", type=float, nargs="+", default=[1e-5, 3e-6, 1e-6])
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--cache", type=Path, default=Path("dg-cache"))
    ap.add_argument("--figure", type=Path, default=None)
    ap.add_argument("--analyse-only", action="store_true")
    a = ap.parse_args()
    if a.samples < 2 or a.strain <= 0 or any(not dg > 0 for dg in a.dgamma):
        ap.error("need --samples >= 2, --strain > 0 and every --dgamma > 0")
    a.cache.mkdir(parents=True, exist_ok=True)
    steps = {dg: int(round(a.strain / dg)) for dg in a.dgamma}
    tasks = [(a.n, a.pressure, dg, steps[dg], seed, a.cache)
             for dg in a.dgamma for seed in range(1, a.samples + 1)]
    if not a.analyse_only:
        run_samples(tasks, a.workers)
    sizes: dict[float, list[np.ndarray]] = {}
    thresholds: dict[float, list[float]] = {}
    cpu: dict[float, float] = {}
    for task in tasks:
        z = read_sample(task)
        if z is None:
            continue
        if z["threshold"] is None:
            n, p, dg, st, seed, cache = task
            sys.exit(f"error: {sample_file(cache, n, p, dg, st, seed)} has no flag threshold "
                     "(an old cache file)")
        dg = task[2]
        sizes.setdefault(dg, []).append(z["sizes"])
        thresholds.setdefault(dg, []).append(z["threshold"])
        cpu[dg] = cpu.get(dg, 0.0) + z["cpu"]
    if len(sizes) < 2:
        sys.exit("error: fewer than two δγ have samples in the cache")
    # the same seeds for every δγ: keep the seeds all δγ have
    k = min(len(v) for v in sizes.values())
    sizes = {dg: v[:k] for dg, v in sizes.items()}
    floor = 10.0 * max(max(t[:k]) for t in thresholds.values())
    smallest = min(sizes)
    ref = np.concatenate([s[s >= floor] for s in sizes[smallest]])
    print(f"\nN = {a.n}, p = {a.pressure:g}, strain window {a.strain:g} per sample, {k} samples "
          f"(seeds 1–{k}), the same packings for every δγ; common floor S ≥ {floor:.3g} ε "
          f"(10 × the largest flag threshold)\n")
    print("| δγ | steps | median threshold (ε) | avalanches (all) | above the floor | "
          "per unit strain | ⟨S⟩ above the floor | ΣS per unit strain | τ at the floor | "
          f"KS vs δγ = {smallest:g} | CPU s per sample |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    strain = k * a.strain  # the total strain of the k samples

    def count(x: list[np.ndarray]) -> float:
        return sum(y.size for y in x) / strain

    def dissipation(x: list[np.ndarray]) -> float:
        return sum(float(y.sum()) for y in x) / strain

    curves = {}
    for dg in sorted(sizes, reverse=True):
        v = sizes[dg]
        above = [s[s >= floor] for s in v]
        pooled = np.concatenate(above)
        rate = count(above)
        rate_err = bootstrap(above, count)
        mean = mean_size(above)
        mean_err = bootstrap(above, mean_size)
        diss = dissipation(above)
        diss_err = bootstrap(above, dissipation)
        if pooled.size >= 30:
            c = fit_cutoff_power_law(pooled, float(floor))
            tau = f"{c.tau:.3f} ± {c.tau_stderr:.3f}"
        else:
            tau = f"{pooled.size} sizes: no fit"
        ks = "—"
        if dg != smallest:
            r = stats.ks_2samp(pooled, ref)
            ks = f"D = {r.statistic:.3f}, p = {r.pvalue:.2g}"
        print(f"| {dg:g} | {steps[dg]} | {np.median(thresholds[dg][:k]):.3g} | "
              f"{sum(s.size for s in v)} | {pooled.size} | {rate:.4g} ± {rate_err:.2g} | "
              f"{mean:.3e} ± {mean_err:.1e} | {diss:.3e} ± {diss_err:.1e} | {tau} | {ks} | "
              f"{cpu[dg] / k:.0f} |")
        curves[dg] = np.sort(np.concatenate(v))
    # where the δγ differ: avalanches per unit strain in decades of S, every counted size
    lo = np.floor(np.log10(min(float(c[0]) for c in curves.values() if c.size)))
    hi = np.ceil(np.log10(max(float(c[-1]) for c in curves.values() if c.size)))
    edges = 10.0 ** np.arange(lo, hi + 1)
    print("\navalanches per unit strain by decade of S (all counted sizes, each run's own flag):")
    print("| δγ | " + " | ".join(f"[{a:.0e}, {b:.0e})" for a, b in zip(edges[:-1], edges[1:],
                                                                    strict=True)) + " |")
    print("|---|" + "---|" * (edges.size - 1))
    for dg, c in curves.items():
        h = np.histogram(c, edges)[0]
        print(f"| {dg:g} | " + " | ".join(f"{x / strain:.0f}" for x in h) + " |")
    if a.figure is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5.5, 4))
        for dg, s in curves.items():
            # counts per unit strain above S: the rate, so merging shows as a lower curve
            ax.loglog(s, (s.size - np.arange(s.size)) / strain, ".-", ms=3,
                      label=f"δγ = {dg:g}")
        ax.set_xlabel("avalanche size S = −ΔH (ε)")
        ax.set_ylabel("avalanches of size ≥ S per unit strain")
        ax.axvline(floor, color="0.5", ls="--", lw=1, label="common floor")
        ax.set_title(f"N = {a.n}, p = {a.pressure:g}, {k} packings, strain {a.strain:g} each")
        ax.legend()
        fig.tight_layout()
        a.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(a.figure, dpi=130)
        print(f"figure: {a.figure}")


if __name__ == "__main__":
    main()
