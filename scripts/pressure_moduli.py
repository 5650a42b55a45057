"""The moduli moments at fixed pressure: is ``⟨μ_1²⟩ ∝ δγ^(−1)`` (the paper's Fig. 7) there?

At constant volume near jamming the packings re-jam to pressures decades apart, so ``⟨μ_1²⟩``
averaged over samples carries the spread of their moduli, flat in ``δγ``, and its fitted slope is
shallow (the quick report: −0.77 ± 0.21 at jamming, N = 128; docs/analysis.md §4). At fixed
pressure every packing of a run is at the same ``p``. This reads fixed-pressure run directories
(``jamlab run … --pressure P``, one N each; realisations of one ``(p, N, δγ_0)`` are pooled) and
prints per ``(p, N, δγ_0)``, from the intensive shear stress ``Σ/V`` of each minimum (each
row's own volume; ``jamlab.reproduce.ensembles.intensive_stress``):

- ``⟨μ_1²⟩`` and the within-sample variance ``mu1_var`` (the jumps' part) at the lags
  ``--lags`` of the fine step (``δγ = m δγ_0``; overlapping differences, only those between
  jammed minima), their slopes against ``δγ`` over the lags ``≤ --fit-max-lag`` (the lags of
  one trace are correlated, so the error is indicative), and the local slope between the two
  smallest lags — :func:`jamlab.reproduce.pressure_moduli.moduli_at_pressure`, the rule of the
  `medium` report's rows;
- the lag-1 correlation of consecutive stress increments between jammed minima (each sample's
  mean increment removed): ``⟨μ_1²⟩`` falls faster than ``δγ^(−1)`` where consecutive
  increments are anticorrelated (``⟨(ΔΣ_1 + ΔΣ_2)²⟩ < 2⟨ΔΣ²⟩``) and slower where they are
  correlated, so this says why a slope is not −1;
- the share of ``Σ ΔΣ²`` (lag 1) carried by the steps flagged plastic; the fraction of the other
  steps (between jammed minima) whose stress falls, and the fraction of those that FIRE did not
  touch (the trace's ``iterations`` 0: the Newton relaxer followed the minimum's branch) — a
  stress that falls along a smooth branch is a negative shear modulus at fixed pressure, not a
  rearrangement below the flag's threshold;
- ``pN²`` (the finite-size variable of jamming) and, among the smooth steps (unflagged, between
  jammed minima, no FIRE iteration), how many there are and the fraction whose stress falls: the
  branches with a negative modulus;
- a second table: ``ρ`` split by what its pairs of consecutive steps hold (neither flagged
  plastic, the second only, the first only, both:
  :func:`jamlab.analysis.increment_correlation_parts`), and where the increments of the steps
  just before and after an isolated event rank among the sample's unflagged increments
  (:func:`jamlab.analysis.event_neighbours`; 0.5 is a typical step): where the minima soften
  before an event and are stiffer after it, the pairs next to events anticorrelate.

For increments correlated at lag 1 only (correlation ``ρ``) the local slope between lags 1 and
2 is ``−1 + log₂(1 + ρ)`` (``⟨(ΔΣ_1 + ΔΣ_2)²⟩ = 2⟨ΔΣ²⟩(1 + ρ)``, up to the squared mean
increment, flat in ``δγ``); the table prints it beside the measured one.

``--figure-branches F``: that fraction against ``pN²``, one point per ``(p, N, δγ_0)``.

``--figure-parts F``: ρ and its parts against N, one panel per pressure (each pressure's
coarsest δγ_0).

``--figure F`` (``.png``, ``.pdf`` or ``.svg``, outside the run directories): one panel per
pressure, ``δγ ⟨μ_1²⟩`` against ``δγ`` for each ``(N, δγ_0)`` (flat where ``⟨μ_1²⟩ ∝
δγ^(−1)``), ``mu1_var`` dotted.

    R=data/runs
    PYTHONPATH=src python scripts/pressure_moduli.py $R/n*-p1e-*-vg* $R/n125-p1e-*-dg1e-6 \
        --figure moduli.png
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jamlab.analysis import (
    CORRELATION_PARTS,
    event_neighbours,
    increment_correlation,
    increment_correlation_parts,
)
from jamlab.reproduce.ensembles import finished, intensive_stress, jammed_flags, plastic_flags
from jamlab.reproduce.pressure_moduli import moduli_at_pressure
from jamlab.runs import check_figure_path, open_pressure_run

LAGS = (1, 2, 3, 5, 10, 20, 50, 100, 200, 500)


@dataclass(frozen=True)
class Group:
    """The pooled finished samples of one ``(p, N, δγ_0)``: intensive stress, jammed and plastic
    flags, FIRE iterations ``(samples, rows)``, the fine strain step, and the run directories
    read."""

    stress: np.ndarray
    jammed: np.ndarray
    plastic: np.ndarray
    iterations: np.ndarray
    dgamma: float
    runs: tuple[str, ...]


def read_groups(ap: argparse.ArgumentParser,
                runs: list[Path]) -> dict[tuple[float, int, float], Group]:
    """The run directories pooled by ``(p, N, δγ_0)``; realisations of one group must have the
    same number of rows (else the parser's error, one line, exit code 2)."""
    parts: dict[tuple[float, int, float], list[tuple]] = {}
    for path in runs:
        ds, pressure, n = open_pressure_run(ap, path)
        done = finished(ds, "jamming", n)
        if not done.any():
            ap.error(f"{path}: no finished sample")
        jm = jammed_flags(ds, "jamming", n)
        if jm is None:
            ap.error(f"{path}: a run without per-minimum jammed flags (trace format 1)")
        plastic = plastic_flags(ds, "jamming", n)
        fire = np.asarray(ds.iterations.sel(phi="jamming", N=n).values)[done]
        stress = intensive_stress(ds, "jamming", n)
        dgamma = float(json.loads(ds.attrs["study"])["dgamma"])
        parts.setdefault((pressure, n, dgamma), []).append((stress, jm, plastic, fire, path.name))
    groups = {}
    for key, items in parts.items():
        shapes = {it[0].shape[1] for it in items}
        if len(shapes) > 1:
            ap.error(f"p = {key[0]:g}, N = {key[1]}, δγ = {key[2]:g}: the runs "
                     f"{[it[4] for it in items]} differ in rows {sorted(shapes)}; give one length")
        groups[key] = Group(*(np.concatenate([it[k] for it in items]) for k in range(4)), key[2],
                            tuple(it[4] for it in items))
    return groups


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="fixed-pressure run directories, one N each")
    ap.add_argument("--lags", type=int, nargs="+", default=list(LAGS),
                    help="lags m of the fine step (δγ = m δγ_0), increasing")
    ap.add_argument("--fit-max-lag", type=int, default=10,
                    help="largest lag of the slope fits (one of --lags)")
    ap.add_argument("--figure", type=Path, default=None,
                    help="δγ ⟨μ_1²⟩ against δγ per pressure (.png, .pdf or .svg)")
    ap.add_argument("--figure-branches", type=Path, default=None,
                    help="the smooth steps' falling fraction against pN² (.png, .pdf or .svg)")
    ap.add_argument("--figure-parts", type=Path, default=None,
                    help="ρ and its parts against N, one panel per pressure (.png, .pdf or .svg)")
    ap.add_argument("--coarse", type=int, nargs="+", default=[],
                    help="also split ρ on the same minima every k-th row (steps of k δγ_0)")
    args = ap.parse_args(argv)
    check_figure_path(ap, args.figure, args.runs)
    check_figure_path(ap, args.figure_branches, args.runs)
    check_figure_path(ap, args.figure_parts, args.runs)
    lags = tuple(args.lags)
    if not (lags[0] >= 1 and all(b > a for a, b in zip(lags, lags[1:], strict=False))):
        ap.error(f"--lags must be increasing integers >= 1, got {list(lags)}")
    if args.fit_max_lag not in lags or lags.index(args.fit_max_lag) < 1:
        ap.error(f"--fit-max-lag must be one of --lags above the first, got {args.fit_max_lag}")
    if any(k < 2 for k in args.coarse):
        ap.error(f"--coarse takes integers >= 2, got {args.coarse}")
    groups = read_groups(ap, args.runs)
    print(f"lags {list(lags)}; slopes of log⟨μ_1²⟩ and log mu1_var against log δγ over the lags "
          f"≤ {args.fit_max_lag} (errors indicative: the lags of one trace are correlated)\n")
    print("| p | N | packings | δγ_0 | ⟨μ_1²⟩ at δγ_0 | slope ⟨μ_1²⟩ | slope mu1_var | local slope "
          "(first two lags) | mu1_var / ⟨μ_1²⟩ at δγ_0 | lag-1 increment correlation ρ | "
          "−1 + log₂(1 + ρ) | plastic share of ΣΔΣ² | unflagged steps with ΔΣ < 0 | … of them "
          "without FIRE | pN² | smooth steps | … with ΔΣ < 0 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    curves, branches, parts, splits = {}, {}, [], {}
    for key in sorted(groups, key=lambda k: (-k[0], k[1], -k[2])):
        p, n, _ = key
        g = groups[key]
        if lags[-1] >= g.stress.shape[1]:
            ap.error(f"p = {p:g}, N = {n}: the largest lag {lags[-1]} is not below the "
                     f"{g.stress.shape[1] - 1} steps")
        e = moduli_at_pressure(g.stress, g.jammed, n, g.dgamma, lags,
                               args.fit_max_lag * g.dgamma)
        m = e.moments
        fits = ["n/a" if f is None else f"{f.slope:+.3f} ± {f.slope_err:.3f}"
                for f in (e.slope, e.var_slope)]
        d = np.diff(g.stress, axis=1)
        ok = g.jammed[:, 1:] & g.jammed[:, :-1]
        share = float(np.sum((d * d)[ok & g.plastic[:, 1:]]) / np.sum((d * d)[ok]))
        falling = ok & ~g.plastic[:, 1:] & (d < 0)
        falls = float(np.count_nonzero(falling) / np.count_nonzero(ok & ~g.plastic[:, 1:]))
        smooth = float(np.mean(g.iterations[:, 1:][falling] == 0)) if falling.any() else np.nan
        branch = ok & ~g.plastic[:, 1:] & (g.iterations[:, 1:] == 0)
        n_branch = int(np.count_nonzero(branch))
        branch_falls = (float(np.count_nonzero(branch & (d < 0)) / n_branch) if n_branch
                        else np.nan)
        corr = e.correlation
        print(f"| {p:g} | {n} | {g.stress.shape[0]} | {g.dgamma:g} | {m.mu1_sq[0]:.4g} | "
              f"{fits[0]} | {fits[1]} | {e.local_slope:+.3f} | {m.mu1_var[0] / m.mu1_sq[0]:.3f} | "
              f"{corr:+.3f} | {np.log2(1 + corr) - 1:+.3f} | {share:.3f} | {falls:.3f} | "
              f"{smooth:.3f} | {p * n * n:.3g} | {n_branch} | {branch_falls:.3f} |")
        curves[key] = m
        branches[key] = (n_branch, branch_falls)
        split = increment_correlation_parts(g.stress, g.plastic, g.jammed)
        sd = resampled_sd(g)
        splits[key] = (corr, split, sd)
        before, after, count = event_neighbours(g.stress, g.plastic, g.jammed)
        parts.append(f"| {p:g} | {n} | {g.dgamma:g} | {corr:+.3f} ± {sd['rho']:.3f} | "
                     + " | ".join(f"{split[k]:+.3f} ± {sd[k]:.3f}" for k in CORRELATION_PARTS)
                     + f" | {count} | {before:.2f} | {after:.2f} |")
        for k in args.coarse:
            if 2 * k >= g.stress.shape[1]:
                ap.error(f"--coarse {k}: p = {p:g}, N = {n} has {g.stress.shape[1] - 1} steps")
            stress, plastic, jammed = coarse_rows(g, k)
            split = increment_correlation_parts(stress, plastic, jammed)
            before, after, count = event_neighbours(stress, plastic, jammed)
            parts.append(f"| {p:g} | {n} | {k} × {g.dgamma:g} | "
                         f"{increment_correlation(stress, jammed):+.3f} | "
                         + " | ".join(f"{split[c]:+.3f}" for c in CORRELATION_PARTS)
                         + f" | {count} | {before:.2f} | {after:.2f} |")
    print("\nρ split by the pairs of consecutive steps (each part Σ a b over its pairs, over "
          "the √(Σ a² Σ b²) of all pairs, so they sum to ρ; ± the sd over "
          f"{RESAMPLES} resamples of the packings), and the increments next to isolated "
          "events: their median rank among the sample's unflagged increments (0.5: typical)\n")
    print("| p | N | δγ_0 | ρ | neither plastic | into an event | out of an event | both | "
          "isolated events | rank of the step before | rank of the step after |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(parts))
    if args.figure is not None:
        draw(curves, args.figure)
        print(f"\nfigure: {args.figure}")
    if args.figure_branches is not None:
        draw_branches(branches, args.figure_branches)
        print(f"figure: {args.figure_branches}")
    if args.figure_parts is not None:
        draw_parts(splits, args.figure_parts)
        print(f"figure: {args.figure_parts}")
    return 0


RESAMPLES = 200


def resampled_sd(g: Group, seed: int = 0) -> dict[str, float]:
    """The sd of ρ (key ``rho``) and of each part over :data:`RESAMPLES` resamples of the
    packings with replacement (a packing's steps stay together: they are correlated)."""
    rng = np.random.default_rng(seed)
    draws: dict[str, list[float]] = {k: [] for k in ("rho", *CORRELATION_PARTS)}
    for _ in range(RESAMPLES):
        pick = rng.integers(0, g.stress.shape[0], g.stress.shape[0])
        split = increment_correlation_parts(g.stress[pick], g.plastic[pick], g.jammed[pick])
        draws["rho"].append(sum(split.values()))
        for k in CORRELATION_PARTS:
            draws[k].append(split[k])
    return {k: float(np.nanstd(v, ddof=1)) for k, v in draws.items()}


def coarse_rows(g: Group, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The same minima every ``k``-th row, as a run with the step ``k δγ_0`` through them would
    flag them: the stress of rows ``0, k, 2k, …``; a coarse row is plastic if any of the ``k``
    fine steps that end in it is, and jammed if every fine minimum since the previous coarse
    row is (so a coarse step counts only if all the ``2k`` fine minima it and its predecessor
    span are jammed: conservative)."""
    rows = (g.stress.shape[1] - 1) // k
    stress = g.stress[:, : rows * k + 1 : k]
    plastic = np.zeros(stress.shape, bool)
    jammed = np.zeros(stress.shape, bool)
    plastic[:, 1:] = g.plastic[:, 1 : rows * k + 1].reshape(-1, rows, k).any(axis=2)
    jammed[:, 0] = g.jammed[:, 0]
    jammed[:, 1:] = g.jammed[:, 1 : rows * k + 1].reshape(-1, rows, k).all(axis=2)
    return stress, plastic, jammed


def draw_parts(splits: dict, path: Path) -> None:
    """One panel per pressure: ρ and its parts (pairs of unflagged steps, pairs next to an
    event, pairs of events) against N, for the groups of the coarsest δγ_0 at that pressure
    (the run's own step; finer steps are other runs of the same packings); error bars: the sd
    over resampled packings (the two neighbours' parts' in quadrature)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pressures = sorted({key[0] for key in splits}, reverse=True)
    fig, axes = plt.subplots(1, len(pressures), figsize=(2.8 * len(pressures), 3.2),
                             squeeze=False, sharey=True, constrained_layout=True)
    series = (("ρ", "k", "o", lambda c, s: c, lambda d: d["rho"]),
              ("unflagged pairs", "C0", "s", lambda c, s: s["smooth"], lambda d: d["smooth"]),
              ("next to an event", "C3", "v", lambda c, s: s["before"] + s["after"],
               lambda d: np.hypot(d["before"], d["after"])),
              ("pairs of events", "C2", "^", lambda c, s: s["events"], lambda d: d["events"]))
    for ax, p in zip(axes[0], pressures, strict=True):
        step = max(key[2] for key in splits if key[0] == p)
        keys = sorted(key for key in splits if key[0] == p and key[2] == step)
        ns = [key[1] for key in keys]
        for label, colour, marker, value, err in series:
            ax.errorbar(ns, [value(*splits[key][:2]) for key in keys],
                        yerr=[err(splits[key][2]) for key in keys], color=colour,
                        marker=marker, ms=4, capsize=2, label=label)
        ax.axhline(0, color="0.6", lw=0.6)
        ax.set_xscale("log")
        ax.set_xticks(ns, [str(n) for n in ns], fontsize=7)
        ax.minorticks_off()
        ax.set_xlim(min(ns) / 1.3, max(ns) * 1.3)
        ax.set_title(f"p = {p:g}, δγ_0 = {step:g}", fontsize=9)
        ax.set_xlabel("N")
    axes[0][0].set_ylabel("lag-1 correlation of ΔΣ, and its parts")
    axes[0][0].legend(fontsize=7)
    fig.savefig(path, dpi=150)
    plt.close(fig)


def draw_branches(branches: dict, path: Path) -> None:
    """The fraction of smooth steps whose stress falls against ``pN²``, one marker per
    ``(p, N, δγ_0)`` (colour: p; filled: δγ_0 = 1e-5, open: others), with its binomial standard
    error; groups with fewer than 100 smooth steps are left out."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pressures = sorted({key[0] for key in branches}, reverse=True)
    colours = {p: f"C{i}" for i, p in enumerate(pressures)}
    fig, ax = plt.subplots(figsize=(4.6, 3.4), constrained_layout=True)
    shown = set()
    for (p, n, dgamma), (count, frac) in sorted(branches.items()):
        if count < 100:
            continue
        err = np.sqrt(frac * (1 - frac) / count)
        ax.errorbar(p * n * n, frac, yerr=err, color=colours[p], marker="o", ms=5,
                    mfc=colours[p] if dgamma == 1e-5 else "none", ls="none",
                    label=None if p in shown else f"p = {p:g}")
        shown.add(p)
    ax.set_xscale("log")
    ax.set_xlabel("p N²")
    ax.set_ylabel("smooth steps with ΔΣ < 0")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=150)
    plt.close(fig)


def draw(curves: dict, path: Path) -> None:
    """One panel per pressure: ``δγ ⟨μ_1²⟩`` (solid) and ``δγ mu1_var`` (dotted) against ``δγ``
    per ``(N, δγ_0)``, log–log."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pressures = sorted({key[0] for key in curves}, reverse=True)
    colours = {n: f"C{i}" for i, n in enumerate(sorted({key[1] for key in curves}))}
    finest = min(key[2] for key in curves)
    legend: dict[tuple[int, float], tuple[Any, str]] = {}
    fig, axes = plt.subplots(1, len(pressures), figsize=(3.2 * len(pressures), 3.8),
                             squeeze=False, constrained_layout=True)
    for ax, p in zip(axes[0], pressures, strict=True):
        for key in sorted((k for k in curves if k[0] == p), key=lambda k: (k[1], -k[2])):
            m = curves[key]
            colour = colours[key[1]]  # one colour per N in every panel; the finest step: squares
            handle = ax.errorbar(m.strain_step, m.strain_step * m.mu1_sq,
                                 yerr=m.strain_step * m.mu1_sq_err, color=colour,
                                 marker="s" if key[2] == finest else "o", ms=3)
            legend.setdefault((key[1], -key[2]), (handle, f"N = {key[1]}, δγ_0 = {key[2]:g}"))
            ax.plot(m.strain_step, m.strain_step * m.mu1_var, color=colour, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"p = {p:g}")
        ax.set_xlabel("δγ")
    axes[0][0].set_ylabel("δγ ⟨μ_1²⟩ (ε²/σ⁶); dotted: δγ mu1_var")
    # one legend for all panels, below them (none hides a curve), by N then step
    entries = [legend[k] for k in sorted(legend)]
    fig.legend([h for h, _ in entries], [t for _, t in entries], loc="outside lower center",
               ncol=min(len(entries), 6), fontsize=8)
    fig.savefig(path, dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
