"""Finite-size scaling of avalanches at fixed pressure near jamming: ⟨S⟩, S_c and β over 3+ sizes.

For each ``N`` in ``--n`` and sample seeds ``1 … k`` (``--samples``, one count per ``N``):
``jam(N, 3, seed, p_target=p)``, then fixed-pressure AQS (``shear_at_pressure``, the default
Newton path and plastic flag) for ``--steps`` steps of ``--dgamma``; the avalanche sizes
``S = −ΔH > 0`` of the plastic steps between jammed minima
(:func:`jamlab.analysis.avalanches.avalanche_sizes`) are kept per sample (``--cache``, one file
per sample: a rerun continues). Then :func:`jamlab.analysis.finite_size.fit_cutoff_scaling`
(``⟨S⟩``, ``S_c = ⟨S²⟩/⟨S⟩`` and ``β`` of ``S_c ~ N^β``, bootstrap over samples), τ fitted on the
pooled sizes of the largest ``N`` (:func:`jamlab.analysis.powerlaw.fit_power_law`, its KS rule
for ``S_min``), the collapse ``P(S) S^τ`` against ``S/N^β`` at the fitted β (its RMS in decades,
beside the RMS without rescaling and the β that minimises it on a grid), a markdown table and a
figure (``--figure``). Where the samples store the plastic flag's threshold: τ above floors set by
it, ``⟨S²⟩/⟨S⟩`` above the comparison floor (10 × the largest threshold of all N), and the joint
maximum-likelihood fit of one τ, β and the cut-off to every N
(:func:`jamlab.analysis.finite_size.fit_joint_scaling`) above that floor and above 10 × each N's
own largest threshold; the figure then shows the collapse with the joint fit's τ and β and its
model curves.

    PYTHONPATH=src python scripts/finite_size_pressure.py --n 250 500 1000 --samples 40 20 10 \\
        --pressure 1e-3 --dgamma 1e-4 --steps 50 --workers 2 --cache fss-cache \\
        --figure docs/figures/fss_pressure_1e-3.png
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from jamlab.analysis.avalanches import avalanche_sizes, jammed_steps
from jamlab.analysis.cutoff_powerlaw import (
    CutoffPowerLawFit,
    cutoff_power_law_cdf,
    cutoff_power_law_ks,
    cutoff_power_law_log_norm,
    fit_cutoff_power_law,
)
from jamlab.analysis.finite_size import (
    Collapse,
    CutoffScaling,
    JointScaling,
    collapse,
    collapse_quality,
    fit_cutoff_scaling,
    fit_joint_scaling,
    joint_shape_free,
    joint_shape_profile,
)
from jamlab.analysis.moduli import SlopeFit, fit_log_slope
from jamlab.analysis.powerlaw import fit_power_law


def sample_file(cache: Path, n: int, p: float, dg: float, steps: int, seed: int) -> Path:
    return cache / f"n{n}_p{p:g}_dg{dg:g}_steps{steps}_s{seed}.npz"


def run_sample(args: tuple) -> str:
    n, p, dg, steps, seed, cache = args
    from jamlab.spheres.packing import jam
    from jamlab.spheres.pressure_shear import shear_at_pressure

    f = sample_file(cache, n, p, dg, steps, seed)
    if f.is_file():
        return f"N={n} seed={seed}: cached"
    t = time.process_time()
    pk = jam(n, 3, seed=seed, p_target=p).packing
    r = shear_at_pressure(pk, dg, pressure=p, n_steps=steps)
    c = r.columns
    ok = jammed_steps(c["jammed"])
    # plastic steps between jammed minima with S > 0 (the analysis' one rule)
    sizes = avalanche_sizes(c["enthalpy_jump"][1:], c["plastic"][1:], jammed=c["jammed"])
    tmp = f.with_suffix(".tmp.npz")
    np.savez(tmp, sizes=sizes, n_plastic=int(c["plastic"].sum()), jammed_steps=int(ok.sum()),
             pressure=c["pressure"], threshold=float(r.threshold), cpu=time.process_time() - t)
    os.replace(tmp, f)
    return (f"N={n} seed={seed}: {sizes.size} avalanches, {int(ok.sum())} jammed steps, "
            f"{time.process_time() - t:.0f} CPU s")


def run_samples(tasks: list[tuple], workers: int) -> None:
    """:func:`run_sample` for every task (``(N, p, δγ, steps, seed, cache)``), ``workers``
    processes, a line printed per sample."""
    with ProcessPoolExecutor(max_workers=workers) as ex:
        for msg in ex.map(run_sample, tasks):
            print(msg, flush=True)


def read_sample(task: tuple) -> dict | None:
    """The cached sample of a task (``(N, p, δγ, steps, seed, cache)``): ``sizes``, ``cpu`` (s)
    and ``threshold`` (the plastic flag's, ε; ``None`` in files written before it was stored);
    ``None`` if not run yet."""
    n, p, dg, steps, seed, cache = task
    f = sample_file(cache, n, p, dg, steps, seed)
    if not f.is_file():
        return None
    with np.load(f) as z:
        return {"sizes": np.asarray(z["sizes"]), "cpu": float(z["cpu"]),
                "threshold": float(z["threshold"]) if "threshold" in z.files else None}


def report_collapse(sizes: dict[int, np.ndarray], tau: float, beta: float, head: str,
                    at: str) -> Collapse:
    """The collapse ``P(S) S^τ`` vs ``S/N^β`` of the pooled ``sizes`` at ``beta``, printed as
    ``head: RMS … decades at {at}, …`` beside no rescaling and the best β on a grid 0–3."""
    grid = np.linspace(0.0, 3.0, 61)
    q = collapse_quality(sizes, tau, grid)
    col = collapse(sizes, tau, beta)
    print(f"{head}: RMS {col.quality:.3f} decades at {at}, "
          f"{collapse_quality(sizes, tau, [0.0])[0]:.3f} without rescaling (β = 0); "
          f"best on the grid β = {grid[int(np.nanargmin(q))]:.2f} (RMS {np.nanmin(q):.3f})")
    return col


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[250, 500, 1000])
    ap.add_argument("--samples", type=int, nargs="+", default=[40, 20, 10])
    ap.add_argument("--pressure", type=float, default=1e-3)
    ap.add_argument("--dgamma", type=float, default=1e-4)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--cache", type=Path, default=Path("fss-cache"))
    ap.add_argument("--figure", type=Path, default=None)
    ap.add_argument("--analyse-only", action="store_true")
    ap.add_argument("--reverse", action="store_true",
                    help="run the samples in reverse order (a second process on the same cache)")
    a = ap.parse_args()
    if len(a.samples) != len(a.n):
        ap.error("give one --samples count per --n")
    a.cache.mkdir(parents=True, exist_ok=True)
    tasks = [(n, a.pressure, a.dgamma, a.steps, seed, a.cache)
             for n, k in zip(a.n, a.samples, strict=True) for seed in range(1, k + 1)]
    if not a.analyse_only:
        run_samples(tasks[::-1] if a.reverse else tasks, a.workers)
    sizes_by_n: dict[int, list[np.ndarray]] = {}
    thresholds: dict[int, list[float]] = {}
    cpu: dict[int, float] = {}
    for task in tasks:
        z = read_sample(task)
        if z is not None:
            n = task[0]
            sizes_by_n.setdefault(n, []).append(z["sizes"])
            cpu[n] = cpu.get(n, 0.0) + z["cpu"]
            if z["threshold"] is not None:
                thresholds.setdefault(n, []).append(z["threshold"])
    fit = fit_cutoff_scaling(sizes_by_n, n_boot=500, seed=1)
    largest = max(sizes_by_n)
    pooled = {n: np.concatenate(v) for n, v in sizes_by_n.items()}
    pl = fit_power_law(pooled[largest], min_tail=50)
    print(f"\np = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps per sample, d = 3\n")
    print("| N | samples | avalanches | ⟨S⟩ | S_c = ⟨S²⟩/⟨S⟩ | CPU s per sample |")
    print("|---|---|---|---|---|---|")
    for i, n in enumerate(fit.n):
        print(f"| {n} | {fit.samples[i]} | {fit.avalanches[i]} | {fit.mean[i]:.3e} ± "
              f"{fit.mean_err[i]:.1e} | {fit.cutoff[i]:.3e} ± {fit.cutoff_err[i]:.1e} | "
              f"{cpu[int(n)] / fit.samples[i]:.0f} |")
    print(f"\nβ (S_c ~ N^β) = {fit.beta:.3f} ± {fit.beta_err:.3f} "
          f"(95 %: [{fit.beta_ci95[0]:.3f}, {fit.beta_ci95[1]:.3f}]); "
          f"⟨S⟩ ~ N^{fit.mean_exponent:.3f} ± {fit.mean_exponent_err:.3f}")
    print(f"τ at N = {largest}: {pl.tau:.3f} ± {pl.tau_stderr:.3f} from {pl.n_tail} sizes above "
          f"S_min = {pl.x_min:.3g}")
    col = report_collapse(pooled, pl.tau, fit.beta, "collapse P(S) S^τ vs S/N^β", "the fitted β")
    # one size floor for all N: the counted sizes start higher at larger N (the plastic flag's
    # threshold is 10 σ of a residual noise that grows with N), so compare N above the largest
    # of the per-N floors (each N's 5 % quantile)
    floor = max(float(np.quantile(v, 0.05)) for v in pooled.values())
    fit_f, cuts = scaling_above(sizes_by_n, floor)
    print(f"\nwith one floor for all N, S >= {floor:.3g} (the largest per-N 5 % quantile):")
    print("| N | avalanches | ⟨S⟩ | S_c = ⟨S²⟩/⟨S⟩ | τ, cut-off fit at the floor "
          "| S_c of that fit |")
    print("|---|---|---|---|---|---|")
    for i, n in enumerate(fit_f.n):
        c = cuts[int(n)]
        sc = "none resolved" if c.at_bound else f"{c.x_c:.3e} ± {c.x_c_stderr:.1e}"
        print(f"| {n} | {fit_f.avalanches[i]} | {fit_f.mean[i]:.3e} ± {fit_f.mean_err[i]:.1e} | "
              f"{fit_f.cutoff[i]:.3e} ± {fit_f.cutoff_err[i]:.1e} | "
              f"{c.tau:.3f} ± {c.tau_stderr:.3f} | {sc} |")
    print(f"β from ⟨S²⟩/⟨S⟩ above the floor = {fit_f.beta:.3f} ± {fit_f.beta_err:.3f} "
          f"(95 %: [{fit_f.beta_ci95[0]:.3f}, {fit_f.beta_ci95[1]:.3f}]); "
          f"⟨S⟩ ~ N^{fit_f.mean_exponent:.3f} ± {fit_f.mean_exponent_err:.3f}")
    slope = beta_from_cutoffs(cuts)
    if slope is not None:
        print(f"β from the cut-off fits' S_c (weighted least squares in log-log) = "
              f"{slope.slope:.3f} ± {slope.slope_err:.3f}")
    joint = None
    if thresholds and all(len(thresholds.get(n, [])) == len(v) for n, v in sizes_by_n.items()):
        threshold_floors(sizes_by_n, pooled, thresholds)
        joint = joint_fits(sizes_by_n, thresholds)
        # the figure's collapse: above the comparison floor, where no N is depleted
        above = {n: v[v >= joint.floors[0]] for n, v in pooled.items()}
        col = collapse(above, joint.tau, joint.beta)
    if a.figure is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 3 if joint is not None else 2,
                               figsize=(15 if joint is not None else 10, 4))
        for n in sorted(pooled):
            s = np.sort(pooled[n])
            ax[0].loglog(s, 1.0 - np.arange(s.size) / s.size, ".", ms=3, label=f"N = {n}")
            if n in col.x:
                line = ax[1].loglog(col.x[n], col.y[n], "o", ms=4, label=f"N = {n}")
                if joint is not None:  # the joint model: P(S) S^τ = e^(−S/S*(N)) / Z_N
                    f0 = float(joint.floors[0])
                    sx = np.geomspace(f0, float(pooled[n].max()), 100)
                    s_star = float(joint.cutoff(n))
                    y = np.exp(-sx / s_star - cutoff_power_law_log_norm(joint.tau, s_star, f0))
                    ax[1].loglog(sx / float(n) ** joint.beta, y, "-", color=line[0].get_color())
        ax[0].set_xlabel("avalanche size S = −ΔH (ε)")
        ax[0].set_ylabel("P(size ≥ S)")
        ax[0].set_title(f"fixed p = {a.pressure:g}, δγ = {a.dgamma:g}")
        ax[0].legend()
        ax[1].set_xlabel(f"S / N^β (β = {col.beta:.2f})")
        ax[1].set_ylabel(f"P(S) S^τ (τ = {col.tau:.2f})")
        ax[1].set_title(f"collapse: RMS {col.quality:.2f} decades"
                        + ("" if joint is None else "; lines: joint fit"))
        ax[1].legend()
        if joint is not None:  # the data above the comparison floor against the joint model
            f0 = float(joint.floors[0])
            for n in sorted(pooled):
                s = np.sort(pooled[n][pooled[n] >= f0])
                line = ax[2].loglog(s, 1.0 - np.arange(s.size) / s.size, ".", ms=3,
                                    label=f"N = {n}")
                sx = np.geomspace(f0, float(s.max()), 200)
                ax[2].loglog(sx, 1.0 - cutoff_power_law_cdf(sx, joint.tau, float(joint.cutoff(n)),
                                                             f0), "-",
                             color=line[0].get_color())
            ax[2].set_xlabel("S (ε)")
            ax[2].set_ylabel(f"P(size ≥ S | S ≥ {f0:.2g})")
            ax[2].set_title(f"joint fit: τ = {joint.tau:.2f}, β = {joint.beta:.2f} ± "
                            f"{joint.beta_err:.2f}")
            ax[2].legend()
        fig.tight_layout()
        a.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(a.figure, dpi=130)
        print(f"figure: {a.figure}")


def scaling_above(sizes_by_n: dict[int, list[np.ndarray]],
                  floor: float) -> tuple[CutoffScaling, dict[int, CutoffPowerLawFit]]:
    """The sizes ``S ≥ floor`` of every sample: their :func:`fit_cutoff_scaling`, and per N
    (those with avalanches above the floor) the power law with an exponential cut-off fitted at
    that fixed floor."""
    above = {n: [x[x >= floor] for x in v] for n, v in sizes_by_n.items()}
    fit = fit_cutoff_scaling(above, n_boot=500, seed=1)
    cuts = {int(n): fit_cutoff_power_law(np.concatenate(above[int(n)]), float(floor))
            for n in fit.n}
    return fit, cuts


def beta_from_cutoffs(cuts: dict[int, CutoffPowerLawFit]) -> SlopeFit | None:
    """β as the slope of log S_c against log N over the cut-off fits that resolved S_c
    (:func:`jamlab.analysis.fit_log_slope`, weights from their errors); ``None`` below 2."""
    ok = [n for n, c in cuts.items() if not c.at_bound and np.isfinite(c.x_c_stderr)]
    if len(ok) < 2:
        return None
    return fit_log_slope(ok, [cuts[n].x_c for n in ok], [cuts[n].x_c_stderr for n in ok])


def threshold_floors(sizes_by_n: dict[int, list[np.ndarray]], pooled: dict[int, np.ndarray],
                     thresholds: dict[int, list[float]]) -> None:
    """τ per N above floors set by the plastic flag's threshold (each sample's run threshold on
    the residual ``|r_n|``, in ε): per N at ``k`` × that N's largest threshold, and for all N at
    ``k`` × the largest threshold of all samples. If τ at a fixed low floor falls with N because
    the depletion just above a threshold that grows with N flattens more of the fitted range, the
    per-N τ must stop falling once every N is cut at the same multiple of its own threshold, and
    at a common floor above every threshold. ``pooled[N]``: the sizes of all samples of N.
    Ends with the collapse above the comparison floor (10 × the largest threshold), printed."""
    print("\nthe plastic flag's threshold per N (ε; median and largest over samples):")
    print("| N | median threshold | largest threshold | 5 % quantile of S |")
    print("|---|---|---|---|")
    t_max = {n: float(np.max(thresholds[n])) for n in sizes_by_n}
    for n in sorted(sizes_by_n):
        q5 = float(np.quantile(pooled[n], 0.05))
        print(f"| {n} | {np.median(thresholds[n]):.3g} | {t_max[n]:.3g} | {q5:.3g} |")
    top = max(t_max.values())
    print("\nτ (power law with an exponential cut-off, fixed floor) above threshold-based floors:")
    print("| floor | " + " | ".join(f"N = {n}" for n in sorted(sizes_by_n)) + " |")
    print("|---|" + "---|" * len(sizes_by_n))
    rows = [(f"{k:g} × each N's largest threshold", {n: k * t_max[n] for n in sizes_by_n})
            for k in (1.0, 3.0, 10.0)]
    rows += [(f"{k:g} × the largest threshold of all N ({k * top:.2g})",
              {n: k * top for n in sizes_by_n}) for k in (1.0, 3.0, 10.0)]
    for label, floors in rows:
        cells = []
        for n in sorted(sizes_by_n):
            s = pooled[n][pooled[n] >= floors[n]]
            if s.size < 30:
                cells.append(f"{s.size} sizes: no fit")
                continue
            c = fit_cutoff_power_law(s, float(floors[n]))
            cells.append(f"{c.tau:.3f} ± {c.tau_stderr:.3f} ({s.size})")
        print(f"| {label} | " + " | ".join(cells) + " |")
    # β above the comparison floor (10 × the largest threshold of all N: no N depleted there)
    floor = 10.0 * top
    fit, cuts = scaling_above(sizes_by_n, floor)
    for i, n in enumerate(fit.n):
        c = cuts[int(n)]
        print(f"N = {n}: S >= {floor:.2g}: ⟨S⟩ = {fit.mean[i]:.3e}, "
              f"S_c = ⟨S²⟩/⟨S⟩ = {fit.cutoff[i]:.3e}; cut-off fit S_c = "
              + ("none resolved" if c.at_bound else f"{c.x_c:.3e} ± {c.x_c_stderr:.1e}"))
    print(f"above S >= {floor:.2g}: β from ⟨S²⟩/⟨S⟩ = {fit.beta:.3f} ± {fit.beta_err:.3f} "
          f"(95 %: [{fit.beta_ci95[0]:.3f}, {fit.beta_ci95[1]:.3f}]); ⟨S⟩ ~ "
          f"N^{fit.mean_exponent:.3f} ± {fit.mean_exponent_err:.3f}")
    slope = beta_from_cutoffs(cuts)
    if slope is not None:
        print(f"above S >= {floor:.2g}: β from the cut-off fits' S_c = {slope.slope:.3f} ± "
              f"{slope.slope_err:.3f}")
    # the collapse above the same floor, with the τ of the largest N fitted there (not the KS
    # rule's τ of the whole range, which sits in the cut-off's bend at the largest N)
    above = {n: np.concatenate(v)[np.concatenate(v) >= floor] for n, v in sizes_by_n.items()}
    tau = cuts[int(max(fit.n))].tau
    report_collapse(above, tau, fit.beta,
                    f"above S >= {floor:.2g}: collapse P(S) S^τ vs S/N^β with τ = "
                    f"{tau:.3f} (largest N, cut-off fit at the floor)",
                    f"β = {fit.beta:.3f}")


def joint_fits(sizes_by_n: dict[int, list[np.ndarray]],
               thresholds: dict[int, list[float]]) -> JointScaling:
    """The joint maximum-likelihood fit of τ, β and the cut-off
    (:func:`jamlab.analysis.finite_size.fit_joint_scaling`, 500 resamples of the samples, and the
    jackknife) above 10 × each N's largest threshold and above the comparison floor (10 × the
    largest of all), printed as a table with the jackknife errors and the three samples whose
    omission moves β most (seeds are 1-based: sample i of N is seed i + 1 when every seed
    1 … k is cached); returns the fit above the comparison floor."""
    per_n = {n: 10.0 * float(np.max(thresholds[n])) for n in sizes_by_n}
    common = max(per_n.values())
    print("\njoint maximum-likelihood fit, P(S|N) ∝ S^-τ exp(-S/S*(N)), S* = S*_ref (N/N_ref)^β, "
          "one τ (errors and 95 % intervals: bootstrap over samples):")
    print("| floors | avalanches per N | τ | β (95 %) | S* at N_ref | 2 Δlog L vs no cut-off |")
    print("|---|---|---|---|---|---|")
    fits = []
    for label, floors in (("10 × each N's largest threshold", per_n),
                          (f"10 × the largest threshold of all N ({common:.2g})", common)):
        j = fit_joint_scaling(sizes_by_n, floors, n_boot=500, seed=1, jackknife=True)
        fits.append((label, j))
        flags = ("" if j.resolved else " (no cut-off resolved)") + (
            f" ({j.boot_at_bound:.0%} of resamples at a bound)" if j.boot_at_bound else "")
        print(f"| {label} | {' / '.join(str(t) for t in j.tail)} | {j.tau:.3f} ± {j.tau_err:.3f}"
              f" | {j.beta:.3f} ± {j.beta_err:.3f} ([{j.beta_ci95[0]:.2f}, "
              f"{j.beta_ci95[1]:.2f}]) | {j.cutoff_ref:.3g} (N_ref = {j.n_ref:.0f}) | "
              f"{j.cutoff_lr:.1f}{flags} |")
    # a second error estimate and the influence of single samples: each sample left out in turn
    for label, j in fits:
        loo = j.leave_one_out
        top = np.argsort(-np.abs(loo[:, 4] - j.beta))[:3]
        print(f"{label}: jackknife errors τ ± {j.tau_err_jack:.3f}, β ± {j.beta_err_jack:.3f}; "
              "β without the most influential samples: " + ", ".join(
                  f"{loo[i, 4]:.3f} (N = {loo[i, 0]:.0f}, seed {loo[i, 1] + 1:.0f})" for i in top))
        # does the exponential cut-off describe each N? KS distance of that N's tail to the
        # joint model beside the 5 % critical value 1.36/√n (for a fully specified model; with
        # fitted parameters the true critical value is smaller, so exceeding it is a rejection)
        cells = []
        for i, n in enumerate(j.n):
            t = np.concatenate([x[x >= j.floors[i]] for x in sizes_by_n[int(n)]])
            d = cutoff_power_law_ks(t, j.tau, float(j.cutoff(n)), float(j.floors[i]))
            cells.append(f"N = {n}: D = {d:.3f} (5 %: {1.36 / np.sqrt(t.size):.3f})")
        print(f"{label}: KS of each N's tail against the joint model: " + "; ".join(cells))
    profile_stretch(sizes_by_n, per_n)
    # where does the shape preference come from: the same profile above higher common floors
    print("\nthe profile above common floors (10, 30, 100 × the largest threshold of all N; "
          "100 resamples): log L − log L(a = 1), τ, β per a")
    print("| floor | avalanches per N | " + " | ".join(f"a = {a:g}" for a in STRETCH_SCAN)
          + " |")
    print("|---|---|" + "---|" * len(STRETCH_SCAN))
    for mult in (10.0, 30.0, 100.0):
        fl = mult * common / 10.0
        cells, ref, tails = [], None, ""
        for a in STRETCH_SCAN[::-1]:  # a = 1 first: the reference
            j = fit_joint_scaling(sizes_by_n, fl, n_boot=100, seed=1, stretch=a)
            ref = j.loglik if ref is None else ref
            tails = " / ".join(str(t) for t in j.tail)
            cells.append(f"{j.loglik - ref:+.1f}, {j.tau:.2f}, {j.beta:.2f} ± {j.beta_err:.2f}")
        print(f"| {fl:.2g} | {tails} | " + " | ".join(cells[::-1]) + " |")
    return fits[-1][1]


STRETCH_SCAN = (0.2, 0.3, 0.5, 0.7, 1.0)


STRETCHES = (0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.7, 1.0, 1.5)


def profile_stretch(sizes_by_n: dict[int, list[np.ndarray]], floors: dict[int, float]) -> None:
    """The joint fit with the cut-off e^(−(S/S*)^a) on a grid of a (100 resamples each) above
    the given floors: the profile likelihood of a, the τ and β it implies, the grid points inside
    the 95 % profile interval (2Δlog L ≤ 3.84 from the best), and the best a refitted with 500
    resamples and the jackknife."""
    print("\nthe shape of the cut-off, e^(-(S/S*)^a), above 10 × each N's largest threshold "
          "(profile likelihood over a):")
    print("| a | log L − log L(a = 1) | τ | β | S* at N_ref |")
    print("|---|---|---|---|---|")
    fits = joint_shape_profile(sizes_by_n, floors, STRETCHES, n_boot=100, seed=1)
    ref = fits[1.0].loglik
    for a, j in fits.items():
        print(f"| {a:g} | {j.loglik - ref:+.2f} | {j.tau:.3f} ± {j.tau_err:.3f} | "
              f"{j.beta:.3f} ± {j.beta_err:.3f} | {j.cutoff_ref:.3g} |")
    free = joint_shape_free(fits)
    best, inside = free.best, free.inside
    j = fit_joint_scaling(sizes_by_n, floors, n_boot=500, seed=1, stretch=best, jackknife=True)
    print(f"best a on the grid = {best:g} (2 Δlog L against a = 1: "
          f"{free.lr_exponential:.1f}); inside the 95 % profile interval: "
          f"a = {', '.join(f'{a:g}' for a in inside)}, where β runs "
          f"{min(fits[a].beta for a in inside):.3f} – {max(fits[a].beta for a in inside):.3f} "
          f"and τ {min(fits[a].tau for a in inside):.3f} – {max(fits[a].tau for a in inside):.3f}")
    print(f"at a = {best:g} (500 resamples): β = {j.beta:.3f} ± {j.beta_err:.3f} (95 %: "
          f"[{j.beta_ci95[0]:.2f}, {j.beta_ci95[1]:.2f}]; jackknife ± {j.beta_err_jack:.3f}), "
          f"τ = {j.tau:.3f} ± {j.tau_err:.3f}")


if __name__ == "__main__":
    main()
