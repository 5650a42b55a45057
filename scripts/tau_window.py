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

``--band W``: also τ on a band of sizes ``[S, S·10^W]`` alone (a power law truncated at both
ends, maximum likelihood; asymptotic error), the band moved up in steps of ``--band-step``
decades from the smallest size to the largest, where it holds at least ``--band-min`` sizes:
the local slope of ``P(S)`` at ``S``, which no size outside the band moves (the fits on
``S ≥ S_min`` above average the slope over the whole tail, cut-off included). A third panel of
the figure draws it against the band's geometric centre. ``--fixed-band LO HI`` (repeatable):
τ on that band alone for every run. Every band fit gives its asymptotic error and a bootstrap
over the samples (``--boot`` resamplings of whole samples with replacement, seed 0): avalanches
of one trajectory need not be independent.

``--n``: one size for every run, or one per run (runs of different N side by side).
``--above S …``: the same rate at each ``S``, and a two-sample Kolmogorov–Smirnov test of
the sizes ≥ ``S`` between every two runs (is the shape of the tail the same?).
``--rate``: the first panel draws the number of avalanches of size ≥ S per particle and per unit
strain (the run's finished samples, their whole strain) instead of the normalised CCDF: where the
rate of events is extensive and their sizes do not depend on N, the curves of several N fall
on each other; a detection floor that moves with N shows as the curves' foot parting.
``--above-permutations K``: each of those KS tests again with its p-value from dealing whole
samples between the two runs (K times): the avalanches of one trajectory need not be
independent, and ``ks_2samp``'s p-value assumes they are.
``--joint S …`` (runs of different N): does the cut-off grow with N? For each floor ``S``, one
maximum-likelihood fit of a shared τ and a cut-off ``S*(N) = S*_ref (N/N_ref)^β`` to every
run's sizes ≥ S (:func:`jamlab.analysis.finite_size.fit_joint_scaling`; bootstrap over whole
samples at each N, ``--boot`` resamples, and the leave-one-sample-out jackknife), beside the
same model with ``β = 0`` (one cut-off for all N: :func:`fit_cutoff_power_law` on the pooled
sizes, the same floor); ``2Δlog L`` between the two is χ² with one degree of freedom if the
avalanches were independent (3.84 at 95 %), the bootstrap interval of β what respects their
correlation within a sample. ``--joint-stretch a …``: the joint fit at the first floor with the
cut-off ``e^(−(S/S*)^a)`` for each ``a``: τ, β and the maximised log-likelihood (its profile over
``a``: is the exponential shape the one the data prefer?), and τ's 95 % interval with the shape
free (:func:`jamlab.analysis.joint_shape_free`: :func:`jamlab.analysis.shape_free_interval`
over the listed ``a`` and 1, with the bootstrap σ of each ``a``). ``--joint-permutations K``:
the likelihood ratio's p-value at the first floor by a permutation test — whole samples dealt at
random to the sizes N, K times — which, unlike the χ²₁ reading, holds with avalanches correlated
within a sample and samples that differ.
``--moments S …`` (runs of different N): the same question without a model of the cut-off. At
each floor ``S``, the cut-off of each N is read as the moment ratio ``S_c = ⟨S²⟩/⟨S⟩`` of its
sizes ≥ S (for ``τ < 2`` and a cut-off far above the floor it is proportional to the cut-off
whatever its shape, as long as the shape does not change with N), and ``β`` is the slope of
``log S_c`` against ``log N`` (:func:`jamlab.analysis.finite_size.fit_cutoff_scaling`: weighted
least squares, errors from ``--boot`` resamples of whole samples). ``--moments-permutations K``:
the one-sided p-value of that slope (permuted ``β`` ≥ observed) with whole samples dealt at
random to the sizes N.
``--joint-figure F``: the sizes ≥ the
first floor of each N (P(size ≥ S), normalised at the floor) with the joint model of each N
(solid) and the one cut-off of β = 0 (dashed).

    PYTHONPATH=src python scripts/tau_window.py RUNS/pressure-1e-04 RUNS/pressure-1e-03 \\
        --n 500 --figure docs/figures/tau_window_medium.png
    PYTHONPATH=src python scripts/tau_window.py RUNS/n250-p1e-6 RUNS/n500-p1e-6 --n 250 500 \\
        --band 1 --figure docs/figures/tau_window_p1e-6.png
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
from scipy import stats

from jamlab.analysis import (
    fit_cutoff_power_law,
    fit_cutoff_scaling,
    fit_joint_scaling,
    fit_power_law,
    joint_shape_free,
    joint_shape_profile,
)
from jamlab.analysis.cutoff_powerlaw import cutoff_power_law_cdf
from jamlab.reproduce.ensembles import finished, jammed_flags, sample_strains
from jamlab.reproduce.measurements import (
    avalanche_set,
    fit_tau,
    interval_note,
    tau_sigma,
)
from jamlab.reproduce.scales import SCALES
from jamlab.runs import add_run_arguments, open_run, sizes_per_run
from jamlab.spheres.confirm import plastic_threshold
from jamlab.spheres.pressure_shear import PLASTIC_FLOOR


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap, default_n=500)
    ap.add_argument("--scale", default="medium", choices=sorted(SCALES))
    ap.add_argument("--quantiles", type=float, nargs="+",
                    default=[0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])
    ap.add_argument("--band", type=float, default=None,
                    help="width in decades of the bands of the local slope (default: none)")
    ap.add_argument("--band-step", type=float, default=0.25)
    ap.add_argument("--band-min", type=int, default=30)
    ap.add_argument("--fixed-band", type=float, nargs=2, action="append", default=[],
                    metavar=("LO", "HI"), help="τ on [LO, HI] alone (repeatable)")
    ap.add_argument("--boot", type=int, default=200,
                    help="bootstrap resamplings of the samples for the band fits")
    ap.add_argument("--figure", type=Path, default=None)
    ap.add_argument("--rate", action="store_true",
                    help="first panel: avalanches ≥ S per particle per unit strain")
    ap.add_argument("--above", type=float, nargs="+", default=[],
                    help="print the rate of avalanches ≥ S per particle per unit strain at each "
                         "S, and a two-sample KS of the sizes ≥ S between every two runs")
    ap.add_argument("--above-permutations", type=int, default=0,
                    help="with --above: the KS p-value also by dealing whole samples between "
                         "the two runs, this many times")
    ap.add_argument("--joint", type=float, nargs="+", default=[],
                    help="floors S of the joint fit of τ and S*(N) ~ N^β (runs of different N)")
    ap.add_argument("--joint-stretch", type=float, nargs="+", default=[],
                    help="cut-off exponents a of the joint fit's profile at the first floor")
    ap.add_argument("--joint-permutations", type=int, default=0,
                    help="permutations of whole samples among the N for the ratio's p-value")
    ap.add_argument("--moments", type=float, nargs="+", default=[],
                    help="floors S of β from the moment ratio ⟨S²⟩/⟨S⟩ per N (runs of "
                         "different N)")
    ap.add_argument("--moments-permutations", type=int, default=0,
                    help="permutations of whole samples among the N for that β's p-value")
    ap.add_argument("--joint-figure", type=Path, default=None,
                    help="figure of the joint fit at the first floor (with --joint)")
    a = ap.parse_args()
    sizes_n = sizes_per_run(ap, a)
    if a.band is not None and not (a.band > 0 and a.band_step > 0 and a.band_min >= 2):
        ap.error("--band and --band-step must be positive, --band-min at least 2")
    if any(not 0 < lo < hi for lo, hi in a.fixed_band):
        ap.error("--fixed-band needs 0 < LO < HI")
    if a.boot < 0:
        ap.error("--boot must be >= 0")
    if a.joint and (len(set(sizes_n)) != len(sizes_n) or len(sizes_n) < 2 or a.boot < 2
                    or not all(x > 0 for x in a.joint)):
        ap.error("--joint needs two or more runs of different N, --boot >= 2 and floors > 0")
    if a.moments and (len(set(sizes_n)) != len(sizes_n) or len(sizes_n) < 2 or a.boot < 2
                      or not all(x > 0 for x in a.moments)):
        ap.error("--moments needs two or more runs of different N, --boot >= 2 and floors > 0")
    if a.moments_permutations and not (a.moments and a.moments_permutations >= 1):
        ap.error("--moments-permutations needs --moments and a count >= 1")
    if a.joint_stretch and not (a.joint and all(x > 0 for x in a.joint_stretch)):
        ap.error("--joint-stretch needs --joint and exponents > 0")
    if a.joint_figure is not None and not a.joint:
        ap.error("--joint-figure needs --joint")
    if a.above_permutations and not (a.above and a.above_permutations >= 1):
        ap.error("--above-permutations needs --above and a count >= 1")
    if a.joint_permutations and not (a.joint and a.joint_permutations >= 1):
        ap.error("--joint-permutations needs --joint and a count >= 1")
    per_sample_by_n = {}
    samples_by_name = {}
    scale = SCALES[a.scale]
    curves = {}
    for run, n in zip(a.runs, sizes_n, strict=True):
        ds = open_run(run)
        aval = avalanche_set(ds, "jamming", n)
        s = np.sort(aval.sizes)
        strain = total_strain(ds, n)
        if s.size < scale.min_tail:
            print(f"\n{run}: {s.size} avalanches, too few for a fit")
            continue
        per_sample_by_n[n] = aval.per_sample
        rule = fit_tau(s, scale)
        print(f"\n{run} (N = {n}): {s.size} avalanches, S from {s[0]:.2e} to {s[-1]:.2e}; "
              f"the scale's rule: τ = {rule.tau:.3f} ± {tau_sigma(rule):.3f} "
              f"(95 % [{rule.ci_low:.3f}, {rule.ci_high:.3f}]"
              f"{interval_note(rule)}) on S ≥ {rule.x_min:.2e}, "
              f"{rule.n_tail} sizes; {s.size / (n * strain) if strain > 0 else np.nan:.3g} "
              f"avalanches per particle per unit strain; the plastic flag's threshold "
              f"{flag_threshold(ds, n):.3g} ε (median over the samples)\n")
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
        bands = local_slope(s, a.band, a.band_step, a.band_min) if a.band else None
        if bands is not None:
            print(f"\nτ on bands [S, S·10^{a.band:g}] alone (truncated at both ends), moved up "
                  f"by {a.band_step:g} decades; errors asymptotic / bootstrap over the "
                  f"{len(aval.per_sample)} samples:\n")
            print("| band (ε) | sizes | τ |")
            print("|---|---|---|")
            for lo, hi, k, t, e in zip(*bands, strict=True):
                b = band_bootstrap(aval.per_sample, lo, hi, a.boot)
                print(f"| {lo:.2e} – {hi:.2e} | {k} | {t:.3f} ± {e:.3f} / {b:.3f} |")
        if a.fixed_band:
            print("\n| fixed band (ε) | sizes | τ ± asymptotic / bootstrap over samples |")
            print("|---|---|---|")
            for lo, hi in a.fixed_band:
                count, f = band_fit(s, lo, hi, 2)
                if f is None:
                    print(f"| {lo:.2e} – {hi:.2e} | {count} | — |")
                    continue
                b = band_bootstrap(aval.per_sample, lo, hi, a.boot)
                print(f"| {lo:.2e} – {hi:.2e} | {count} | {f.tau:.3f} ± "
                      f"{f.tau_stderr:.3f} / {b:.3f} |")
        samples_by_name[f"{run.name} (N = {n})"] = aval.per_sample
        curves[f"{run.name} (N = {n})"] = (s, np.array(xs), np.array(ts), np.array(es), rule,
                                          np.array(tc), np.array(ec), bands, n * strain)
    if a.above and curves:
        print("\n| run | " + " | ".join(f"≥ {x:.0e} per particle per unit strain" for x in a.above)
              + " |")
        print("|---|" + "---|" * len(a.above))
        for name, c in curves.items():
            s, exposure = c[0], c[-1]
            print(f"| {name} | " + " | ".join(f"{np.count_nonzero(s >= x) / exposure:.3g}"
                                                for x in a.above) + " |")
        names = list(curves)
        for i, first in enumerate(names):
            for second in names[i + 1:]:
                for x in a.above:
                    u, v = curves[first][0], curves[second][0]
                    u, v = u[u >= x], v[v >= x]
                    if min(u.size, v.size) < 2:
                        continue
                    ks = stats.ks_2samp(u, v)
                    perm = ""
                    if a.above_permutations:
                        pair = {0: samples_by_name[first], 1: samples_by_name[second]}
                        _, p_perm = ks_permutation(pair, x, a.above_permutations)
                        perm = (f"; dealing whole samples between the two "
                                f"({a.above_permutations}): p = {p_perm:.3g}")
                    print(f"KS, sizes ≥ {x:.0e}: {first} ({u.size}) against {second} ({v.size}): "
                          f"D = {ks.statistic:.3f}, p = {ks.pvalue:.3g}{perm}")
    if a.joint and len(per_sample_by_n) >= 2:
        fits = joint_table(per_sample_by_n, a.joint, a.boot)
        if a.joint_stretch and a.joint[0] in fits:
            stretch_table(per_sample_by_n, a.joint[0], a.joint_stretch, a.boot,
                          fits[a.joint[0]][0])
        if a.joint_permutations:
            lr, p_value, null = permutation_test(per_sample_by_n, a.joint[0],
                                                 a.joint_permutations)
            q = np.quantile(null, [0.5, 0.9, 0.95, 0.99])
            print(f"\nPermutation test at S ≥ {a.joint[0]:.2e} ({a.joint_permutations} "
                  f"permutations of whole samples among the N): 2Δlog L = {lr:.2f}, p = "
                  f"{p_value:.3f}; permuted 2Δlog L median / 90 / 95 / 99 %: "
                  + " / ".join(f"{x:.2f}" for x in q) + " (χ²₁: 0.45 / 2.71 / 3.84 / 6.63)")
        if a.joint_figure is not None and a.joint[0] in fits:
            joint_figure(per_sample_by_n, a.joint[0], fits[a.joint[0]], a.joint_figure)
    if a.moments and len(per_sample_by_n) >= 2:
        moments_table(per_sample_by_n, a.moments, a.boot, a.moments_permutations)
    if a.figure is not None and curves:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        panels = 3 if a.band else 2
        fig, ax = plt.subplots(1, panels, figsize=(6.5 * panels, 4.4))
        for name, (s, xs, ts, es, rule, tc, ec, bands, exposure) in curves.items():
            above = s.size - np.arange(s.size)  # sizes >= s[i]
            (line,) = ax[0].loglog(s, above / (exposure if a.rate else s.size), ".", ms=3,
                                   label=f"{name} ({s.size})")
            ax[1].errorbar(xs, ts, yerr=es, fmt="o-", ms=3, color=line.get_color(),
                           label=f"{name}: truncated power law")
            ax[1].errorbar(xs * 1.08, tc, yerr=ec, fmt="s--", ms=3, mfc="none",
                           color=line.get_color(), label=f"{name}: with exponential cut-off")
            ax[1].axvline(rule.x_min, color=line.get_color(), ls=":", lw=1)
            if bands is not None:
                lo, hi, _, t, e = bands
                ax[2].errorbar(np.sqrt(lo * hi), t, yerr=e, fmt="o-", ms=3,
                               color=line.get_color(), label=name)
        ax[0].set_xlabel("avalanche size S (ε)")
        ax[0].set_ylabel("avalanches ≥ S per particle per unit strain" if a.rate
                         else "P(size ≥ S)")
        ax[0].set_title(f"N = {', '.join(map(str, sorted(set(sizes_n))))}, jammed steps only")
        ax[0].legend(fontsize=8)
        ax[1].set_xscale("log")
        ax[1].axhline(1.41269, color="k", lw=0.8, label="τ_J = 1.41269 (mean field)")
        ax[1].axhspan(1.52 - 0.075, 1.52 + 0.075, color="0.85", label="paper's fit 1.52 ± 0.075")
        ax[1].set_xlabel("S_min, lower end of the fit window (ε)")
        ax[1].set_ylabel("τ (MLE on S ≥ S_min)")
        ax[1].set_ylim(0.85, 1.9)
        ax[1].set_title("local τ on S ≥ S_min; dotted: S_min of the scale's rule", fontsize=9)
        if not a.band:
            ax[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                         borderaxespad=0)
        else:
            ax[1].legend(fontsize=6, loc="lower right")
            ax[2].set_xscale("log")
            ax[2].axhline(1.41269, color="k", lw=0.8, label="τ_J = 1.41269")
            ax[2].axhline(1.0, color="k", lw=0.8, ls="--", label="τ_UNSAT = 1")
            ax[2].set_xlabel(f"centre of the band [S, S·10^{a.band:g}] (ε)")
            ax[2].set_ylabel("local τ (band alone)")
            ax[2].set_ylim(0.5, 2.6)
            ax[2].set_title("local slope of P(S): no size outside the band enters", fontsize=9)
            ax[2].legend(fontsize=7)
        fig.tight_layout()
        a.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(a.figure, dpi=130)
        print(f"\nfigure: {a.figure}")


def pooled(samples) -> np.ndarray:
    """The sizes of a list of samples, in one float64 array."""
    return np.concatenate([np.asarray(x, dtype=np.float64).ravel() for x in samples])


def joint_fits(per_sample_by_n: dict, floor: float, boot: int, jackknife: bool = True):
    """``(joint, pooled, 2Δlog L)`` at one floor (module docstring, ``--joint``): the joint fit
    with β free, the pooled fit (β = 0) and twice the difference of their maximised
    log-likelihoods, both of the sizes S in ε."""
    j = fit_joint_scaling(per_sample_by_n, floor, n_boot=boot, jackknife=jackknife)
    sizes = pooled([x for n in sorted(per_sample_by_n) for x in per_sample_by_n[n]])
    c = fit_cutoff_power_law(sizes[sizes >= floor], floor)
    return j, c, 2.0 * (j.loglik - c.loglik)


def joint_table(per_sample_by_n: dict, floors: list, boot: int) -> dict:
    """The ``--joint`` table (module docstring); returns ``{floor: joint_fits(…)}`` of the floors
    that could be fitted."""
    ns = sorted(per_sample_by_n)
    print(f"\nJoint fit, one τ and S*(N) = S*_ref (N/N_ref)^β, N = {ns}; errors: bootstrap "
          f"over whole samples ({boot}) / leave-one-sample-out jackknife; β = 0: one cut-off "
          "for all N on the pooled sizes (same floor):\n")
    print("| floor (ε) | sizes per N | τ | β (95 %) | S*(N) (ε) | τ, S_c at β = 0 | "
          "2Δlog L (β free − β = 0) |")
    print("|---|---|---|---|---|---|---|")
    fits = {}
    for floor in floors:
        try:
            j, c, lr = fits[floor] = joint_fits(per_sample_by_n, floor, boot)
        except ValueError as err:
            print(f"| {floor:.2e} | — | {err} | | | | |")
            continue
        cut0 = "none resolved" if c.at_bound else f"{c.x_c:.2e}"
        stars = " / ".join(f"{x:.1e}" for x in j.cutoff(j.n))
        print(f"| {floor:.2e} | {' / '.join(map(str, j.tail))} | {j.tau:.3f} ± {j.tau_err:.3f} "
              f"/ {j.tau_err_jack:.3f} | {j.beta:.2f} ± {j.beta_err:.2f} / "
              f"{j.beta_err_jack:.2f} ([{j.beta_ci95[0]:.2f}, {j.beta_ci95[1]:.2f}]; "
              f"{j.boot_at_bound:.0%} of resamples at a bound) | {stars} | "
              f"{c.tau:.3f} ± {c.tau_stderr:.3f}, {cut0} | {lr:.2f} |")
    return fits


def permuted(per_sample_by_n: dict, rng: np.random.Generator) -> dict:
    """The samples (whole) dealt at random to the sizes N, each N keeping its number of
    samples."""
    ns = sorted(per_sample_by_n)
    pool = [x for n in ns for x in per_sample_by_n[n]]
    order = rng.permutation(len(pool))
    out, i = {}, 0
    for n in ns:
        k = len(per_sample_by_n[n])
        out[n] = [pool[m] for m in order[i:i + k]]
        i += k
    return out


def ks_permutation(pair: dict, floor: float, count: int, seed: int = 0):
    """``(D, p)``: the two-sample KS distance of the sizes ≥ ``floor`` of ``pair[0]`` and
    ``pair[1]`` (each a list of samples' sizes) and its p-value by dealing whole samples between
    the two (:func:`permuted`, ``count`` times): the KS test for avalanches correlated within a
    sample."""
    def distance(two: dict) -> float:
        u, v = pooled(two[0]), pooled(two[1])
        u, v = u[u >= floor], v[v >= floor]
        return stats.ks_2samp(u, v).statistic if min(u.size, v.size) else 0.0

    rng = np.random.default_rng(seed)
    d = distance(pair)
    null = np.array([distance(permuted(pair, rng)) for _ in range(count)])
    return d, (1 + int(np.count_nonzero(null >= d))) / (count + 1)


def permutation_test(per_sample_by_n: dict, floor: float, count: int, seed: int = 0):
    """``(2Δlog L observed, its permutation p-value, the permuted values)``: the statistic of
    :func:`joint_fits` recomputed with whole samples dealt at random to the sizes N
    (:func:`permuted`; ``count`` times, ``numpy.random.default_rng(seed)``); the p-value
    ``(1 + #{permuted ≥ observed}) / (count + 1)``. Under the null — every sample's sizes drawn
    alike whatever its N — the samples are exchangeable, so the test holds with avalanches
    correlated within a sample and samples that differ (the χ²₁ reading assumes neither)."""
    rng = np.random.default_rng(seed)
    lr = joint_fits(per_sample_by_n, floor, 2, jackknife=False)[2]
    null = np.array([joint_fits(permuted(per_sample_by_n, rng), floor, 2, jackknife=False)[2]
                     for _ in range(count)])
    return lr, (1 + int(np.count_nonzero(null >= lr))) / (count + 1), null


def above_floor(per_sample_by_n: dict, floor: float) -> dict:
    """Each sample's sizes ≥ ``floor`` (the samples with none kept, empty)."""
    return {n: [x[x >= floor] for x in (np.asarray(y, dtype=np.float64).ravel() for y in v)]
            for n, v in per_sample_by_n.items()}


def moment_beta(per_sample_by_n: dict, floor: float, boot: int, seed: int = 0):
    """:func:`fit_cutoff_scaling` of the sizes ≥ ``floor``: ``S_c = ⟨S²⟩/⟨S⟩`` per N and the
    slope β of ``log S_c`` against ``log N`` (``--moments``)."""
    return fit_cutoff_scaling(above_floor(per_sample_by_n, floor), n_boot=boot, seed=seed)


def moments_table(per_sample_by_n: dict, floors: list, boot: int, permutations: int) -> None:
    """The ``--moments`` table (module docstring), with the permutation p-value of β
    (:func:`moment_permutation`) when ``permutations`` > 0."""
    ns = sorted(per_sample_by_n)
    print(f"\nβ from the moment ratio S_c = ⟨S²⟩/⟨S⟩ of the sizes ≥ floor, N = {ns} (no model "
          f"of the cut-off; errors: bootstrap over whole samples, {boot})"
          + (f"; p: {permutations} permutations of whole samples among the N" if permutations
             else "") + ":\n")
    print("| floor (ε) | sizes per N | S_c per N (ε) | β (95 %) | χ²/dof |"
          + (" p (permuted β ≥ β) |" if permutations else ""))
    print("|---|---|---|---|---|" + ("---|" if permutations else ""))
    for floor in floors:
        try:
            m = moment_beta(per_sample_by_n, floor, boot)
        except ValueError as err:
            print(f"| {floor:.2e} | — | {err} | | |" + (" |" if permutations else ""))
            continue
        cuts = " / ".join(f"{c:.2e} ± {e:.1e}" for c, e in zip(m.cutoff, m.cutoff_err,
                                                                 strict=True))
        row = (f"| {floor:.2e} | {' / '.join(map(str, m.avalanches))} | {cuts} | "
               f"{m.beta:.2f} ± {m.beta_err:.2f} ([{m.beta_ci95[0]:.2f}, "
               f"{m.beta_ci95[1]:.2f}]) | {m.chi2_dof:.2f} |")
        if permutations:
            row += f" {moment_permutation(per_sample_by_n, floor, permutations)[1]:.3f} |"
        print(row)


def moment_permutation(per_sample_by_n: dict, floor: float, count: int, seed: int = 0):
    """``(β observed, its one-sided permutation p-value, the permuted β)``: :func:`moment_beta`
    recomputed with whole samples dealt at random to the sizes N (:func:`permuted`, ``count``
    times, ``numpy.random.default_rng(seed)``); p = ``(1 + #{permuted β ≥ β}) / (count + 1)``."""
    rng = np.random.default_rng(seed)
    beta = moment_beta(per_sample_by_n, floor, 2).beta
    null = np.array([moment_beta(permuted(per_sample_by_n, rng), floor, 2).beta
                     for _ in range(count)])
    return beta, (1 + int(np.count_nonzero(null >= beta))) / (count + 1), null


def joint_figure(per_sample_by_n: dict, floor: float, fits: tuple, path: Path) -> None:
    """The ``--joint-figure`` (module docstring); ``fits``: :func:`joint_fits` at ``floor``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    j, c, lr = fits
    fig, ax = plt.subplots(figsize=(6.5, 4.6))
    grid = None
    for n in sorted(per_sample_by_n):
        s = np.sort(pooled(per_sample_by_n[n]))
        s = s[s >= floor]
        if s.size == 0:
            continue
        (line,) = ax.loglog(s, 1.0 - np.arange(s.size) / s.size, ".", ms=3,
                            label=f"N = {n} ({s.size} sizes)")
        grid = np.geomspace(floor, 3.0 * s[-1], 200) if grid is None else grid
        star = float(j.cutoff(n))
        ax.loglog(grid, 1.0 - cutoff_power_law_cdf(grid, j.tau, star, floor), "-",
                  color=line.get_color(), lw=1, label=f"joint fit, S*(N) = {star:.1e}")
    if grid is not None:
        ax.loglog(grid, 1.0 - cutoff_power_law_cdf(grid, c.tau, c.x_c, floor), "k--", lw=1,
                  label=f"β = 0: one cut-off {c.x_c:.1e}, τ = {c.tau:.3f}")
    ax.set_ylim(0.5 / max(j.tail), 1.5)
    ax.set_xlabel("avalanche size S (ε)")
    ax.set_ylabel(f"P(size ≥ S | size ≥ {floor:.0e})")
    ax.set_title(f"joint fit: τ = {j.tau:.3f} ± {j.tau_err:.3f}, β = {j.beta:.2f} ± "
                 f"{j.beta_err:.2f}; 2Δlog L against β = 0: {lr:.1f}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    print(f"\nfigure: {path}")


def stretch_table(per_sample_by_n: dict, floor: float, stretches: list, boot: int,
                  exponential) -> dict:
    """The ``--joint-stretch`` table (module docstring); ``exponential``: the joint fit at
    ``floor`` with ``a = 1`` already made (the same resamples: its jackknife comes after them).
    Returns the fits, ``{a: JointScaling}``."""
    print(f"\nJoint fit on S ≥ {floor:.2e} with the cut-off e^(−(S/S*)^a) (bootstrap over "
          f"samples, {boot}):\n")
    print("| a | τ | β (95 %) | log L − log L(a = 1) |")
    print("|---|---|---|---|")
    fits = joint_shape_profile(per_sample_by_n, floor, stretches, boot, known={1.0: exponential})
    for x, j in fits.items():
        print(f"| {x:g} | {j.tau:.3f} ± {j.tau_err:.3f} | {j.beta:.2f} ± {j.beta_err:.2f} "
              f"([{j.beta_ci95[0]:.2f}, {j.beta_ci95[1]:.2f}]) | "
              f"{j.loglik - fits[1.0].loglik:.2f} |")
    free = joint_shape_free(fits)
    edge = " (an end of the grid: the maximum may lie beyond)" if free.at_edge else ""
    print(f"\nShape free (profile over a, bootstrap σ of each): τ in [{free.tau_low:.3f}, "
          f"{free.tau_high:.3f}] (95 %), half-width / 1.96 = "
          f"{(free.tau_high - free.tau_low) / 3.92:.3f}; best a = {free.best:g}{edge}, "
          f"2Δlog L against a = 1: {free.lr_exponential:.2f}; "
          f"a with 2Δlog L ≤ 3.84: {free.a_low:g} – {free.a_high:g}")
    return fits


def total_strain(ds, n: int) -> float:
    """The strain sheared over all finished samples at ``("jamming", n)`` of a run's dataset
    (each sample's largest ``γ`` less its first; rows past a sample's end are NaN)."""
    return float(np.sum(sample_strains(ds, "jamming", n)))


def flag_threshold(ds, n: int) -> float:
    """Median over the finished samples at ``("jamming", n)`` of a fixed-pressure run of the
    plastic flag's threshold, recomputed from each trace as the run set it
    (:func:`jamlab.spheres.confirm.plastic_threshold`: ``max(10 σ, 0.1 δγ²)``, σ the noise of
    the residual on elastic steps); NaN for a constant-volume run or without jammed flags."""
    study = json.loads(ds.attrs.get("study", "{}"))
    jammed = jammed_flags(ds, "jamming", n)
    if study.get("pressure") is None or jammed is None:
        return float("nan")
    done = finished(ds, "jamming", n)
    cols = [np.asarray(ds[k].sel(phi="jamming", N=n).values)[done]
            for k in ("energy_jump", "stress_jump", "gamma")]
    found = [plastic_threshold(hj, sj, g, j, float(study["dgamma"]), PLASTIC_FLOOR, math.inf)[0]
             for hj, sj, g, j in zip(*cols, jammed, strict=True)]
    return float(np.nanmedian(found)) if found else float("nan")


def band_fit(s: np.ndarray, lo: float, hi: float, least: int):
    """``(count, fit)``: the sizes of ``s`` in ``[lo, hi]`` and the power law truncated to that
    band fitted to them alone (maximum likelihood), or ``None`` for fewer than ``least``."""
    inside = s[(s >= lo) & (s <= hi)]
    if inside.size < max(least, 2):
        return inside.size, None
    return inside.size, fit_power_law(inside, x_min=lo, x_max=hi, min_tail=2)


def band_bootstrap(per_sample, lo: float, hi: float, boot: int) -> float:
    """Standard deviation of τ on ``[lo, hi]`` over ``boot`` resamplings of whole samples
    (NaN without resamplings, or where a resampling leaves fewer than two sizes)."""
    if boot == 0 or not per_sample:
        return float("nan")
    rng = np.random.default_rng(0)
    inside = [x[(x >= lo) & (x <= hi)] for x in per_sample]
    taus = []
    for _ in range(boot):
        pick = np.concatenate([inside[i] for i in rng.integers(len(inside), size=len(inside))])
        if pick.size < 2:
            return float("nan")
        taus.append(fit_power_law(pick, x_min=lo, x_max=hi, min_tail=2).tau)
    return float(np.std(taus, ddof=1))


def local_slope(s: np.ndarray, width: float, step: float, least: int):
    """τ of a power law truncated to ``[S, S·10^width]`` fitted to the sizes in that band
    alone, for bands starting at the smallest size and moved up by ``step`` decades up to the
    largest; bands with fewer than ``least`` sizes (the sparse foot and tail) are left out:
    arrays ``(low, high, count, τ, error)``, or None if no band has enough."""
    rows = []
    lo = float(s[0])
    while lo <= s[-1]:
        hi = lo * 10.0 ** width
        count, f = band_fit(s, lo, hi, least)
        if f is not None:
            rows.append((lo, hi, count, f.tau, f.tau_stderr))
        lo *= 10.0 ** step
    if not rows:
        return None
    return tuple(np.array(c) for c in zip(*rows, strict=True))


if __name__ == "__main__":
    main()
