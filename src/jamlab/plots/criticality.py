"""Figures of jamming criticality: ``P(f)``, ``g(h)``, local exponents against the window and
against ``N`` (``docs/criticality.md``)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np

from jamlab.analysis.criticality import (
    REFERENCE,
    ExponentFit,
    LocalExponents,
    PackingObservables,
    criticality_samples,
    empirical_cdf,
    finite_size_cutoff,
    smallest_per_packing,
)
from jamlab.files import atomic_savefig

__all__ = ["plot_distributions", "plot_local_exponents", "plot_finite_size"]

_LABEL = {"theta_e": r"$\theta_e$", "theta_l": r"$\theta_l$", "gamma": r"$\gamma$"}
_X = {"theta_e": r"$f/\langle f\rangle$", "theta_l": r"$f/\langle f\rangle$", "gamma": "$h$"}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _log_density(samples: Sequence[np.ndarray], per: float, lo: float, hi: float, bins: int = 40):
    x = np.concatenate([np.asarray(s) for s in samples])
    x = x[x > 0]
    edges = np.geomspace(lo, hi, bins + 1)
    counts, _ = np.histogram(x, edges)
    centers = np.sqrt(edges[1:] * edges[:-1])
    dens = counts / (per * np.diff(edges))
    ok = counts > 0
    return centers[ok], dens[ok]


FORCE_RESOLUTION = 1e-3
"""Forces below this fraction of their mean are not resolved at ``ftol = 1e-12`` (measured by
polishing to ``1e-14``, ``docs/criticality.md`` "Resolution"); the figures shade the region."""
GAP_RESOLUTION = 1e-7
"""Gaps below a few overlaps (``h ≲ 1e-7`` at ``p ≈ 1e-7``) are not resolved (near-contacts)."""


def plot_distributions(
    groups: Mapping[int, Sequence[PackingObservables]],
    fits: Mapping[str, ExponentFit],
    out: str | os.PathLike,
    fit_n: int | None = None,
) -> None:
    """Three columns (extended forces, localized forces, gaps); top row the density on log-log
    axes per ``N`` with the ``SPEC.md`` §6 reference slope (``P(f) ~ f^θ``, ``g(h) ~ h^(−γ)``;
    ``g`` per backbone particle); bottom row the CDF per ``N`` with the fitted power law
    ``F ~ x^(1+a)`` over its window (shaded) and the reference slope.

    ``fits`` were made on the packings of ``groups[fit_n]`` (``None``: all of ``groups`` pooled);
    the fit line is drawn on the CDF of those packings and its legend names them. The regions
    below the resolution (``f/⟨f⟩ <`` :data:`FORCE_RESOLUTION`, ``h <`` :data:`GAP_RESOLUTION`)
    are hatched as unresolved."""
    plt = _plt()
    fig, axes = plt.subplots(2, 3, figsize=(14, 8.5))
    names = ("theta_e", "theta_l", "gamma")
    ranges = {"theta_e": (1e-4, 5.0), "theta_l": (1e-4, 5.0), "gamma": (1e-8, 0.5)}
    resolution = {"theta_e": FORCE_RESOLUTION, "theta_l": FORCE_RESOLUTION,
                  "gamma": GAP_RESOLUTION}
    largest = max(groups)
    if fit_n is not None and fit_n not in groups:
        raise ValueError(f"fit_n={fit_n} is not one of the sizes {sorted(groups)}")
    fit_obs = list(groups[fit_n]) if fit_n is not None else [o for n in sorted(groups)
                                                             for o in groups[n]]
    fit_who = (f"N = {fit_n}, {len(fit_obs)} packings" if fit_n is not None else
               f"N = {', '.join(map(str, sorted(groups)))} pooled, {len(fit_obs)} packings")
    for col, name in enumerate(names):
        top, bottom = axes[0, col], axes[1, col]
        ref = REFERENCE[name]
        a_ref = -ref if name == "gamma" else ref
        for n in sorted(groups):
            obs = groups[n]
            samples = criticality_samples(obs)[name]
            per = (
                sum(int(o.backbone.sum()) for o in obs)
                if name == "gamma"
                else sum(s.size for s in samples)
            )
            x, dens = _log_density(samples, per, *ranges[name])
            if x.size < 2:
                continue
            top.loglog(x, dens, "o-", ms=3, lw=0.8, label=f"N={n} ({len(obs)} packings)")
            grid = np.geomspace(*ranges[name], 200)
            cdf = empirical_cdf(samples, grid)
            bottom.loglog(grid, np.where(cdf > 0, cdf, np.nan), "-", lw=1.2, label=f"N={n}")
            if n == largest:
                fit_samples = criticality_samples(fit_obs)[name]
                xs = np.geomspace(ranges[name][0] * 10, ranges[name][1] / 10, 10)
                anchor = np.interp(np.log(xs[5]), np.log(x), np.log(dens))
                top.loglog(
                    xs,
                    np.exp(anchor) * (xs / xs[5]) ** a_ref,
                    "k--",
                    lw=1,
                    label=f"reference {_LABEL[name]} = {ref:.5g}",
                )
                fit = fits.get(name)
                if fit is not None:
                    lo, hi = fit.window
                    a = -fit.value if name == "gamma" else fit.value
                    xw = np.geomspace(lo, hi, 20)
                    c_mid = float(empirical_cdf(fit_samples, [np.sqrt(lo * hi)])[0])
                    mid = np.sqrt(lo * hi)
                    bottom.loglog(
                        xw,
                        c_mid * (xw / mid) ** (1 + a),
                        "r-",
                        lw=2.5,
                        alpha=0.7,
                        label=f"fit ({fit_who}): {_LABEL[name]} = {fit.value:.3f} "
                        f"[{fit.ci95[0]:.3f}, {fit.ci95[1]:.3f}]",
                    )
                    bottom.loglog(
                        grid, c_mid * (grid / mid) ** (1 + a_ref), "k--", lw=1, label="reference"
                    )
                    bottom.axvspan(lo, hi, color="0.9", zorder=0)
        what = "f/⟨f⟩" if name != "gamma" else "h"
        for ax in (top, bottom):
            ax.axvspan(ranges[name][0], resolution[name], facecolor="none", hatch="//",
                       edgecolor="tab:red", alpha=0.35, lw=0, zorder=0,
                       label=f"unresolved ({what} < {resolution[name]:g})" if ax is top else None)
        title = {
            "theta_e": "extended contact forces",
            "theta_l": "localized contact forces (weakest of each buckler)",
            "gamma": "gaps between backbone particles",
        }[name]
        top.set_title(title, fontsize=10)
        top.set_xlabel(_X[name])
        top.set_ylabel("density per gap and particle" if name == "gamma" else "density P(f)")
        bottom.set_xlabel(_X[name])
        bottom.set_ylabel("cumulative F (per N)")
        bottom.set_ylim(bottom=1e-6)
        top.legend(fontsize=7)
        bottom.legend(fontsize=7)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=90)
    plt.close(fig)


def plot_local_exponents(
    local: Mapping[str, Mapping[int, LocalExponents]],
    fits: Mapping[str, ExponentFit],
    out: str | os.PathLike,
) -> None:
    """The exponent fitted on one-decade windows against the window centre, one series per
    ``N``, with the reference value (dashed) and the chosen window (shaded)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.3))
    for ax, name in zip(axes, ("theta_e", "theta_l", "gamma"), strict=True):
        for k, n in enumerate(sorted(local[name])):
            le = local[name][n]
            sign = -1.0 if name == "gamma" else 1.0
            v, lo, hi = sign * le.value, sign * le.ci_low, sign * le.ci_high
            shift = 1.0 + 0.06 * k
            ax.errorbar(
                le.center * shift,
                v,
                yerr=[np.abs(v - np.minimum(lo, hi)), np.abs(np.maximum(lo, hi) - v)],
                fmt="o-",
                ms=4,
                capsize=2,
                label=f"N={n}",
            )
        ax.axhline(
            REFERENCE[name], color="k", ls="--", lw=1, label=f"reference {REFERENCE[name]:.5g}"
        )
        fit = fits.get(name)
        if fit is not None:
            ax.axvspan(*fit.window, color="0.9", zorder=0, label="fit window")
        ax.set_xscale("log")
        ax.set_xlabel(f"window centre ({_X[name]}), windows one decade wide")
        ax.set_ylabel(f"local {_LABEL[name]}")
        ax.set_ylim(-0.6, 1.2)
        ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=90)
    plt.close(fig)


def plot_finite_size(
    groups: Mapping[int, Sequence[PackingObservables]],
    fits_by_n: Mapping[int, Mapping[str, ExponentFit]],
    out: str | os.PathLike,
) -> None:
    """(a) ``θ_e``, ``θ_l``, ``γ`` on the rule's window against ``N`` with the reference values;
    (b) the measured finite-size cut-offs (median over packings of the smallest extended force and
    of the smallest gap) against ``N`` with ``N^(−1/(1+θ_e))`` and ``N^(−1/(1−γ))``."""
    plt = _plt()
    ns = np.array(sorted(groups))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.3))
    for k, name in enumerate(("theta_e", "theta_l", "gamma")):
        vals = np.array([fits_by_n[n][name].value if name in fits_by_n[n] else np.nan for n in ns])
        los = np.array([fits_by_n[n][name].ci95[0] if name in fits_by_n[n] else np.nan for n in ns])
        his = np.array([fits_by_n[n][name].ci95[1] if name in fits_by_n[n] else np.nan for n in ns])
        (line,) = ax1.plot([], [])
        ax1.errorbar(
            ns * (1 + 0.05 * k),
            vals,
            yerr=[vals - los, his - vals],
            fmt="o-",
            capsize=3,
            color=line.get_color(),
            label=_LABEL[name],
        )
        ax1.axhline(REFERENCE[name], color=line.get_color(), ls="--", lw=1)
    ax1.set_xscale("log")
    ax1.set_xlabel("N")
    ax1.set_ylabel("exponent (dashed: reference)")
    ax1.legend()
    for name, a_ref, marker in (
        ("theta_e", REFERENCE["theta_e"], "o"),
        ("gamma", -REFERENCE["gamma"], "s"),
    ):
        mins = np.array(
            [np.median(smallest_per_packing(criticality_samples(groups[n])[name])) for n in ns]
        )
        ax2.loglog(ns, mins, marker, label=f"median over packings of the smallest {_X[name]}")
        pred = finite_size_cutoff(ns, a_ref)
        ax2.loglog(ns, pred * mins[-1] / pred[-1], "k--", lw=1)
    ax2.set_xlabel("N")
    ax2.set_ylabel("finite-size cut-off")
    ax2.set_title("dashed: $N^{-1/(1+a)}$, a = θ_e (forces), −γ (gaps), through the largest N",
                  fontsize=9)
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):  # the sizes themselves as ticks (log minor labels overlap)
        ax.set_xticks(ns, [str(n) for n in ns])
        ax.xaxis.set_minor_formatter(plt.NullFormatter())
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=90)
    plt.close(fig)
