"""Are the avalanches of finished runs extensive in N? Rate, mean size and released energy per
particle and unit strain, one size against another.

If the avalanches of a run at fixed pressure are local events whose sizes do not depend on the
box, the number of avalanches ≥ S per particle and unit strain (the *rate*), their mean size
and the energy they release per particle and unit strain (the *release*, ``Σ S / (N γ)``) are
the same at every N. If instead the largest events span the box, the release per particle can
stay the same while the mean size grows with N and the rate falls as its inverse (the energy
the loading stores must go somewhere): ``rate ∝ N^−α``, ``⟨S⟩ ∝ N^α``.

First, per run, all the counted avalanches (no floor): the plastic fraction (avalanches per AQS
step, with its binomial σ; it depends on the plastic flag's threshold, which grows with N),
``⟨S⟩`` ± a bootstrap over whole samples, the median and the largest size. Then, for each run
directory (φ label ``--phi``, default ``jamming``, at its ``--n``; a run directory named twice
with two sizes is read at each; finished samples, the avalanches the
report counts: :func:`jamlab.reproduce.ensembles.avalanche_set`) and each floor of ``--above``:
the three numbers above for the avalanches with ``S ≥ floor``, each ± its standard error from
``--boot`` resamplings of whole samples (avalanches of one trajectory need not be independent).
Then for every pair of runs, larger N against smaller: the ratio of each, its bootstrap 95 %
interval, the exponent ``ln(ratio)/ln(N₂/N₁)``, and a two-sided permutation p-value
(``--permutations`` deals of whole samples between the two runs; the rate and the release are
compared per particle, so samples of different N can be exchanged under the null of
extensivity, and so can the sizes under the null of one size law).

Beside them, once per run, the energy balance per particle and unit strain: the *work* of the
shear, ``Σ_n (γ_n − γ_{n−1}) Σ_{n−1}`` (the rule of the trace's ``energy_jump``, so that
``Σ_n energy_jump = ΔE − work`` exactly; ``E`` is the enthalpy ``H`` at fixed pressure), the
energy the packings gave up, ``−ΔE`` from the first minimum to the last, and the release of all
counted avalanches (no floor). What the avalanches release is the work plus what the packings
give up, less the elastic steps' small jumps and the uncounted plastic steps (the *rest*; the
balance is exact by the definition of ``energy_jump``, so the rest is the check that nothing
large is left out). At fixed pressure the energy given up is split: its volume part
``p (V_0 − V_last)`` (``V = v/φ`` from the trace's φ), the volume the counted avalanches give
up, ``Σ p (V_{n−1} − V_n)`` over their steps (the other steps store the rest of the work as
dilatancy), and the mean change of φ over the window. For every pair of runs in a group, the
differences of these per particle and unit strain (larger N − smaller) with bootstrap 95 %
intervals: where a difference of the release between sizes comes from.

Where a group has three or more sizes: the least-squares slope of each quantity's logarithm
against ``ln N`` with its bootstrap interval, and the slopes between the first two and the last
two sizes with the interval of their difference (is one power of N enough?).

``--labels`` (one per run, e.g. the pressure) groups the runs: pairs are formed within a group
only. ``--figure F``: one column per group; above, the rate of avalanches ≥ S against S for
each run; below, each larger N's rate divided by the smallest N's, with its bootstrap 95 %
band, on a grid of S from the smallest floor of ``--above`` up to where each run keeps
``--least`` avalanches.

    PYTHONPATH=src python scripts/extensivity.py data/runs/n500-p1e-4-vg \\
        data/runs/n1000-p1e-4-vg --n 500 1000 --above 1.03e-8 1e-7
    PYTHONPATH=src python scripts/extensivity.py data/runs/n{500,1000}-p1e-{2,3,4,5}-vg \\
        --n 500 500 500 500 1000 1000 1000 1000 --labels 1e-2 1e-3 1e-4 1e-5 1e-2 1e-3 \\
        1e-4 1e-5 --above 1e-9 --permutations 0 --figure docs/figures/extensivity.png
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from jamlab.reproduce.ensembles import (
    avalanche_set,
    counted_steps,
    finished,
    last_rows,
    row_volumes,
    sample_strains,
)
from jamlab.runs import add_run_arguments, open_run, sizes_per_run

QUANTITIES = ("rate", "mean size", "release")


class Run(NamedTuple):
    """One run directory's finished samples at its ``N``: the counted sizes of each sample, the
    strain each sheared, the work, given-up energy, its volume part, the volume part of the
    avalanches and the change of φ of :func:`sample_energies`, and the number of AQS steps of
    all samples."""

    name: str
    n: int
    per_sample: tuple
    strains: np.ndarray
    work: np.ndarray
    given_up: np.ndarray
    volume_given_up: np.ndarray
    avalanche_volume: np.ndarray
    dphi: np.ndarray
    steps: int


def log_or_nan(x: float) -> float:
    """``ln x``, or NaN where ``x ≤ 0`` (a bootstrap bound of a ratio of few counts can be 0)."""
    return math.log(x) if x > 0 else math.nan


def sample_energies(ds, n: int, label: str = "jamming") -> tuple[np.ndarray, ...]:
    """``(work, given_up, volume_given_up, avalanche_volume, dphi)`` per finished sample at
    ``(label, n)``: ``Σ_n (γ_n − γ_{n−1}) Σ_{n−1}``, ``E_0 − E_last`` (``E`` the trace's
    ``energy`` column, the enthalpy ``H = U + pV`` at fixed pressure), its volume part
    ``p (V_0 − V_last)``, the part of that given up at the counted avalanches
    (:func:`jamlab.reproduce.ensembles.counted_steps`), ``Σ p (V_{n−1} − V_n)`` over them, and
    ``φ_last − φ_0``. The volume of step ``n`` is ``V_n = v / φ_n``, ``v = L^d φ`` the particles'
    volume (:func:`jamlab.reproduce.ensembles.row_volumes`); at constant volume the volume parts
    and the change of φ are 0."""
    done = finished(ds, label, n)
    sel = {"phi": label, "N": n}
    gam = np.asarray(ds.gamma.sel(**sel).values)[done]
    sig = np.asarray(ds.shear_stress.sel(**sel).values)[done]
    ene = np.asarray(ds.energy.sel(**sel).values)[done]
    work = np.nansum(np.diff(gam, axis=1) * sig[:, :-1], axis=1)
    last = last_rows(ene)
    given_up = ene[:, 0] - ene[np.arange(len(last)), last]
    study = json.loads(ds.attrs.get("study", "{}"))
    pressure = study.get("pressure")
    vol = row_volumes(ds, label, n)
    if pressure is None or vol is None:
        zero = np.zeros(given_up.size)
        return work, given_up, zero, zero, zero
    phi = np.asarray(ds.phi_step.sel(**sel).values)[done]
    rows = np.arange(len(last))
    volume = float(pressure) * (vol[:, 0] - vol[rows, last])
    lost = float(pressure) * np.diff(vol, axis=1)  # p (V_n − V_{n−1})
    phi_last = phi[rows, last]
    counted = counted_steps(ds, label, n)[1]
    avalanche_volume = -np.where(counted, lost, 0.0).sum(axis=1)
    return work, given_up, volume, avalanche_volume, phi_last - phi[:, 0]


def balance(work: np.ndarray, given_up: np.ndarray, volume: np.ndarray, avalanche: np.ndarray,
            released: np.ndarray, exposure: np.ndarray, boot: int,
            rng) -> tuple[np.ndarray, np.ndarray]:
    """``(values, standard errors)`` of ``[work, given up, of which volume, volume given up by
    the avalanches, released, rest]`` per unit of ``Σ exposure`` (``N γ`` per sample), the rest
    being ``work + given up − released``; errors from ``boot`` resamplings of whole samples."""
    def one(k):
        w, g, r = work[k].sum(), given_up[k].sum(), released[k].sum()
        return np.array([w, g, volume[k].sum(), avalanche[k].sum(), r, w + g - r]) / (
            exposure[k].sum())

    m = work.size
    draws = np.array([one(rng.integers(0, m, m)) for _ in range(boot)])
    return one(np.arange(m)), np.std(draws, axis=0, ddof=1)


def balance_difference(first: tuple, second: tuple, boot: int, rng) -> tuple[np.ndarray, ...]:
    """``second`` − ``first`` (each ``(work, given_up, volume, avalanche volume, released,
    dphi, exposure)`` per sample) of ``[work, given up, of which volume, volume given up by the
    avalanches, released]`` per unit of exposure and of the mean change of φ: ``(values, lo,
    hi)``, the bootstrap 95 % interval from resampling each run on its own."""
    def one(x, k):
        w, g, v, a, r, dphi, e = (y[k] for y in x)
        return np.array([w.sum(), g.sum(), v.sum(), a.sum(), r.sum()]) / e.sum(), dphi.mean()

    def both(k1, k2):
        a, da = one(first, k1)
        b, db = one(second, k2)
        return np.append(b - a, db - da)

    m1, m2 = first[0].size, second[0].size
    draws = np.array([both(rng.integers(0, m1, m1), rng.integers(0, m2, m2))
                      for _ in range(boot)])
    lo, hi = np.percentile(draws, [2.5, 97.5], axis=0)
    return both(np.arange(m1), np.arange(m2)), lo, hi


def per_sample_sums(per_sample, floor: float) -> tuple[np.ndarray, np.ndarray]:
    """``(counts, sums)``: per sample, the number and the sum of its sizes ``≥ floor``."""
    counts = np.array([np.count_nonzero(s >= floor) for s in per_sample], dtype=float)
    sums = np.array([float(np.sum(s[s >= floor])) for s in per_sample])
    return counts, sums


def pooled(counts: np.ndarray, sums: np.ndarray, particles: np.ndarray,
           strains: np.ndarray) -> np.ndarray:
    """``[rate, mean size, release]`` of a set of samples: ``Σ counts / Σ N γ``,
    ``Σ sums / Σ counts`` (NaN without a count) and ``Σ sums / Σ N γ``."""
    exposure = float(np.sum(particles * strains))
    total = float(np.sum(counts))
    return np.array([total / exposure, float(np.sum(sums)) / total if total else math.nan,
                     float(np.sum(sums)) / exposure])


def bootstrap(counts, sums, particles, strains, boot: int, rng) -> np.ndarray:
    """``boot`` × 3 values of :func:`pooled` on resamplings of whole samples."""
    m = counts.size
    out = np.empty((boot, 3))
    for b in range(boot):
        k = rng.integers(0, m, m)
        out[b] = pooled(counts[k], sums[k], particles[k], strains[k])
    return out


def permutation_p(a: tuple, b: tuple, observed: np.ndarray, count: int, rng) -> np.ndarray:
    """Two-sided p-values of ``|ln ratio|`` of the three quantities (``b`` against ``a``, each
    ``(counts, sums, particles, strains)``) when whole samples are dealt at random between the
    two runs, ``count`` times (the deal keeps each run's number of samples)."""
    joined = [np.concatenate([x, y]) for x, y in zip(a, b, strict=True)]
    m = a[0].size
    obs = np.abs(np.log(observed))
    hits = np.zeros(3)
    for _ in range(count):
        k = rng.permutation(joined[0].size)
        first = pooled(*(x[k[:m]] for x in joined))
        second = pooled(*(x[k[m:]] for x in joined))
        with np.errstate(divide="ignore", invalid="ignore"):
            hits += np.abs(np.log(second / first)) >= obs - 1e-12
    return (hits + 1) / (count + 1)


def run_values(sets: dict, boot: int, rng) -> dict:
    """For each run of ``sets`` (``{name: (counts, sums, particles, strains)}``, per sample):
    ``(values, standard errors)`` of :func:`pooled`, the errors from ``boot`` resamplings of
    whole samples."""
    return {name: (pooled(*x), np.nanstd(bootstrap(*x, boot, rng), axis=0, ddof=1))
            for name, x in sets.items()}


def slope_values(runs: list[tuple], boot: int, rng) -> dict:
    """Over three or more runs (each ``(N, (counts, sums, particles, strains))``): the
    least-squares slope of ``ln(quantity)`` against ``ln N`` for each of the three quantities,
    its bootstrap 95 % interval (each run resampled on its own), and the slope between the
    first two and between the last two sizes (is one power law enough?)."""
    ln_n = np.log([float(n) for n, _ in runs])
    values = np.log(np.array([pooled(*x) for _, x in runs]))
    draws = np.log(np.array([bootstrap(*x, boot, rng) for _, x in runs]))  # runs, boot, 3
    slope = np.polyfit(ln_n, values, 1)[0]
    boot_slopes = np.array([np.polyfit(ln_n, draws[:, b, :], 1)[0] for b in range(boot)
                            if np.all(np.isfinite(draws[:, b, :]))])
    lo, hi = np.percentile(boot_slopes, [2.5, 97.5], axis=0)
    first = (values[1] - values[0]) / (ln_n[1] - ln_n[0])
    last = (values[-1] - values[-2]) / (ln_n[-1] - ln_n[-2])
    change = (draws[-1] - draws[-2]) / (ln_n[-1] - ln_n[-2]) - (draws[1] - draws[0]) / (
        ln_n[1] - ln_n[0])
    c_lo, c_hi = np.nanpercentile(change, [2.5, 97.5], axis=0)
    return {"slope": slope, "lo": lo, "hi": hi, "first": first, "last": last,
            "change_lo": c_lo, "change_hi": c_hi}


def pair_values(first: tuple, second: tuple, boot: int, permutations: int, rng) -> dict:
    """``second`` against ``first`` (each ``(counts, sums, particles, strains)``): the ratio of
    each of the three quantities, its bootstrap 95 % interval (``lo``, ``hi``: each run
    resampled on its own) and the permutation p-values (NaN for ``permutations`` 0)."""
    ratio = pooled(*second) / pooled(*first)
    b = bootstrap(*second, boot, rng) / bootstrap(*first, boot, rng)
    lo, hi = np.nanpercentile(b, [2.5, 97.5], axis=0)
    p = (permutation_p(first, second, ratio, permutations, rng) if permutations
         else np.full(3, math.nan))
    return {"ratio": ratio, "lo": lo, "hi": hi, "p": p}


def rate_curves(sets_by_run: dict, grid: np.ndarray, boot: int, least: int, rng) -> dict:
    """For each run (``{name: (per_sample sizes, particles, strains)}``): the rate of
    avalanches ``≥ S`` at each ``S`` of ``grid`` and ``boot`` × ``len(grid)`` bootstrap
    resamplings of whole samples (the same resampled samples at every ``S``); NaN where the run
    has fewer than ``least`` such avalanches."""
    out = {}
    for name, (per_sample, particles, strains) in sets_by_run.items():
        counts = np.array([[np.count_nonzero(s >= g) for g in grid] for s in per_sample],
                          dtype=float)
        exposure = particles * strains
        rate = counts.sum(axis=0) / exposure.sum()
        m = counts.shape[0]
        draws = np.empty((boot, grid.size))
        for b in range(boot):
            k = rng.integers(0, m, m)
            draws[b] = counts[k].sum(axis=0) / exposure[k].sum()
        few = counts.sum(axis=0) < least
        rate[few] = np.nan
        draws[:, few] = np.nan
        out[name] = (rate, draws)
    return out


def figure(data: list[Run], labels: list, floor: float, boot: int, least: int, path: Path,
           rng, order: list | None = None) -> None:
    """The figure of ``--figure`` (module docstring); one column per group, in ``order`` (by
    default as the groups first appear in ``labels``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = list(dict.fromkeys(order if order is not None else labels))
    fig, ax = plt.subplots(2, len(groups), figsize=(3.4 * len(groups), 5.6), squeeze=False,
                           sharex="col", gridspec_kw={"height_ratios": [3, 2]})
    for col, group in enumerate(groups):
        members = [d for d, lab in zip(data, labels, strict=True) if lab == group]
        top = max(float(np.max(np.concatenate(r.per_sample))) for r in members)
        grid = np.logspace(math.log10(floor), math.log10(top), 40)
        curves = rate_curves({r.name: (r.per_sample, float(r.n), r.strains) for r in members},
                             grid, boot, least, rng)
        base_name, base_n = members[0].name, members[0].n
        base, base_draws = curves[base_name]
        for name, n in ((r.name, r.n) for r in members):
            rate, draws = curves[name]
            ax[0, col].loglog(grid, rate, "-", label=f"N = {n}")
            if name == base_name:
                continue
            ok = np.isfinite(rate / base)
            with np.errstate(divide="ignore", invalid="ignore"):
                lo, hi = np.full(grid.size, np.nan), np.full(grid.size, np.nan)
                lo[ok], hi[ok] = np.nanpercentile((draws / base_draws)[:, ok], [2.5, 97.5],
                                                  axis=0)
            line, = ax[1, col].semilogx(grid, rate / base, "-", label=f"{n} / {base_n}")
            ax[1, col].fill_between(grid, lo, hi, color=line.get_color(), alpha=0.25, lw=0)
        ax[1, col].axhline(1.0, color="k", lw=0.6)
        ax[0, col].set_title(f"{group}" if group else "")
        ax[1, col].set_xlabel("S (ε)")
        ax[0, col].legend(fontsize=7)
        if ax[1, col].get_legend_handles_labels()[0]:
            ax[1, col].legend(fontsize=7)
    ax[0, 0].set_ylabel("avalanches ≥ S per particle per unit strain")
    ax[1, 0].set_ylabel("rate ratio (95 % band)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"\nfigure: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap)
    ap.add_argument("--above", type=float, nargs="+", required=True, help="floors S (ε)")
    ap.add_argument("--boot", type=int, default=1000)
    ap.add_argument("--permutations", type=int, default=999)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--labels", nargs="+", default=None,
                    help="one group label per run (pairs within a group only)")
    ap.add_argument("--figure", type=Path, default=None)
    ap.add_argument("--least", type=int, default=20,
                    help="the figure's curves stop where a run has fewer avalanches ≥ S")
    ap.add_argument("--phi", default="jamming",
                    help="the φ label read in every run (default jamming; e.g. 0.75 in a "
                    "constant-volume run above jamming)")
    a = ap.parse_args()
    sizes_n = sizes_per_run(ap, a)
    if any(not x > 0 for x in a.above):
        ap.error("--above needs floors > 0")
    if a.boot < 2 or a.permutations < 0 or a.least < 1:
        ap.error("--boot must be >= 2, --permutations >= 0 and --least >= 1")
    if a.labels is not None and len(a.labels) != len(a.runs):
        ap.error(f"--labels takes one label per run ({len(a.runs)}), got {len(a.labels)}")
    rng = np.random.default_rng(a.seed)
    data = []
    repeated = {run for run in a.runs if a.runs.count(run) > 1}
    for run, n in zip(a.runs, sizes_n, strict=True):
        ds = open_run(run)
        if n not in np.asarray(ds.N.values) or a.phi not in np.asarray(ds.phi.values):
            ap.error(f"{run}: no φ label {a.phi} at N = {n}")
        aval = avalanche_set(ds, a.phi, n)
        strains = sample_strains(ds, a.phi, n)
        if not aval.samples or not np.all(strains > 0):
            ap.error(f"{run}: no finished sample at N = {n}")
        # one run directory read at two sizes (a study with several N) is named per size
        name = f"{run} N={n}" if run in repeated else str(run)
        data.append(Run(name, n, aval.per_sample, strains, *sample_energies(ds, n, a.phi),
                        aval.steps))
    labels = a.labels if a.labels is not None else [""] * len(data)
    order = sorted(range(len(data)), key=lambda i: data[i].n)
    data, labels = [data[i] for i in order], [labels[i] for i in order]
    label_of = {r.name: lab for r, lab in zip(data, labels, strict=True)}
    every_sum = {r.name: per_sample_sums(r.per_sample, 0.0) for r in data}  # counted S > 0
    print("\n## All counted avalanches (no floor)\n")
    print("| run | N (samples) | steps | avalanches | plastic fraction (binomial σ) "
          "| ⟨S⟩ (ε) | median S (ε) | largest S (ε) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in data:
        every = np.concatenate(r.per_sample)
        counts, sums = every_sum[r.name]
        mean_err = np.nanstd(bootstrap(counts, sums, np.full(counts.size, float(r.n)), r.strains,
                                       a.boot, rng)[:, 1], ddof=1)
        f = every.size / r.steps
        print(f"| {Path(r.name).name} | {r.n} ({r.strains.size}) | {r.steps} | {every.size} | "
              f"{f:.4f} ({math.sqrt(f * (1 - f) / r.steps):.4f}) | "
              + (f"{every.mean():.3g} ± {mean_err:.2g} | {np.median(every):.3g} | "
                 f"{every.max():.3g} |" if every.size else "— | — | — |"))
    print("\n## Energy balance (ε per particle per unit strain; all counted avalanches)\n")
    print("| run | N (samples) | work of the shear | given up by the packings (−ΔE) "
          "| of which volume p(V₀ − V) | volume given up by the avalanches | released by the "
          "avalanches | rest | Δφ over the window |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in data:
        val, err = balance(r.work, r.given_up, r.volume_given_up, r.avalanche_volume,
                           every_sum[r.name][1], r.n * r.strains, a.boot, rng)
        dphi_err = np.std(r.dphi, ddof=1) / math.sqrt(r.dphi.size) if r.dphi.size > 1 else 0.0
        print(f"| {Path(r.name).name} | {r.n} ({r.strains.size}) | "
              + " | ".join(f"{v:.3g} ± {e:.2g}" for v, e in zip(val, err, strict=True))
              + f" | {r.dphi.mean():+.2e} ± {dphi_err:.1e} |")
    print("\n## Where the release differs between sizes (larger N − smaller, ε per particle per "
          "unit strain; bootstrap 95 %)\n")
    print("| group | pair | work | given up | of which volume | volume given up by the "
          "avalanches | released | Δφ |")
    print("|---|---|---|---|---|---|---|---|")
    for r1, r2 in itertools.combinations(data, 2):
        if label_of[r1.name] != label_of[r2.name]:
            continue
        val, lo, hi = balance_difference(
            *((r.work, r.given_up, r.volume_given_up, r.avalanche_volume, every_sum[r.name][1],
               r.dphi, r.n * r.strains) for r in (r1, r2)), a.boot, rng)
        print(f"| {label_of[r1.name]} | {r2.n} − {r1.n} | "
              + " | ".join(f"{v:+.3g} ({x:+.2g}, {y:+.2g})"
                           for v, x, y in zip(val, lo, hi, strict=True)) + " |")
    for floor in a.above:
        sets = {}
        for r in data:
            counts, sums = per_sample_sums(r.per_sample, floor)
            sets[r.name] = (counts, sums, np.full(counts.size, float(r.n)), r.strains)
        values = run_values(sets, a.boot, rng)
        print(f"\n## S ≥ {floor:.3g} ε\n")
        print("| run | N (samples) | avalanches | rate (per particle per unit strain) "
              "| mean size (ε) | release (ε per particle per unit strain) |")
        print("|---|---|---|---|---|---|")
        for r in data:
            val, err = values[r.name]
            counts = sets[r.name][0]
            print(f"| {Path(r.name).name} | {r.n} ({counts.size}) | {int(counts.sum())} | "
                  + " | ".join(f"{v:.3g} ± {e:.2g}" for v, e in zip(val, err, strict=True))
                  + " |")
        print("\n| group | pair (N₂ against N₁) | quantity | ratio (95 %) | exponent ln ratio / "
              "ln(N₂/N₁) (95 %) | permutation p |")
        print("|---|---|---|---|---|---|")
        for (r1, n1, *_), (r2, n2, *_) in itertools.combinations(data, 2):
            if label_of[r1] != label_of[r2]:
                continue
            v = pair_values(sets[r1], sets[r2], a.boot, a.permutations, rng)
            scale = math.log(n2 / n1) if n2 != n1 else math.nan
            for i, q in enumerate(QUANTITIES):
                print(f"| {label_of[r1]} | {n2} against {n1} | {q} | {v['ratio'][i]:.3f} "
                      f"({v['lo'][i]:.3f}, "
                      f"{v['hi'][i]:.3f}) | {log_or_nan(v['ratio'][i]) / scale:+.2f} "
                      f"({log_or_nan(v['lo'][i]) / scale:+.2f}, "
                      f"{log_or_nan(v['hi'][i]) / scale:+.2f})"
                      f" | {v['p'][i]:.3g} |")
        groups = {}
        for r in data:
            groups.setdefault(label_of[r.name], []).append((r.n, sets[r.name]))
        wide = {g: runs for g, runs in groups.items() if len({n for n, _ in runs}) >= 3}
        if wide:
            print("\n| group | quantity | slope of ln(quantity) on ln N (95 %) | slope first "
                  "two sizes / last two | last − first (95 %) |")
            print("|---|---|---|---|---|")
        for g, runs in wide.items():
            v = slope_values(runs, a.boot, rng)
            for i, q in enumerate(QUANTITIES):
                print(f"| {g} | {q} | {v['slope'][i]:+.2f} ({v['lo'][i]:+.2f}, "
                      f"{v['hi'][i]:+.2f}) | {v['first'][i]:+.2f} / {v['last'][i]:+.2f} | "
                      f"{v['last'][i] - v['first'][i]:+.2f} ({v['change_lo'][i]:+.2f}, "
                      f"{v['change_hi'][i]:+.2f}) |")
    if a.figure is not None:
        figure(data, labels, min(a.above), a.boot, a.least, a.figure, rng,
               order=a.labels)


if __name__ == "__main__":
    main()
