"""Figures of the reproduction report (paper Figs. 3–7 and theory vs cascade).

Every function takes arrays (already extracted from runs or theory), writes one PNG and returns
nothing of consequence: the numbers quoted in the report are computed in
:mod:`jamlab.reproduce`, never here. Units (``SPEC.md`` §3): sphere diameter ``σ = 1``, energy
scale ``ε = 1``; energies are totals (extensive) unless divided by ``N``; stresses and moduli are
intensive (``Σ/L³``, units ``ε/σ³``). Mean-field quantities (Figs. 3 and theory vs cascade) are
dimensionless (state stresses of unit variance per unit ``1 − q``).
"""

from __future__ import annotations

import os
import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from jamlab.analysis import LogHistogram, ModulusMoments, PowerLawFit, SlopeFit  # noqa: E402
from jamlab.files import atomic_savefig  # noqa: E402

__all__ = [
    "PHI_TITLES",
    "plot_avalanche_histograms",
    "plot_jump_distributions_two_panels",
    "plot_moduli",
    "plot_no_jump_probability",
    "plot_one_trace",
    "plot_stress_strain",
    "plot_tau_against_pressure",
]

FloatArray = NDArray[np.float64]

PHI_TITLES = {"jamming": "at jamming", "0.75": "φ = 0.75", "0.8": "φ = 0.80"}
_SIZE_LABEL = "avalanche size S = −ΔE (total energy, units of ε)"
_DENSITY_LABEL = "P(S) per AQS step (1/ε)"


def _anchor(hist: LogHistogram, x: float) -> float:
    """Density of ``hist`` at ``x`` (log-log interpolation over the non-empty bins)."""
    ok = hist.density > 0
    if ok.sum() == 0:
        return float("nan")
    if ok.sum() == 1:
        return float(hist.density[ok][0])
    return float(np.exp(np.interp(np.log(x), np.log(hist.centres[ok]), np.log(hist.density[ok]))))


def _power_line(ax, x0: float, x1: float, y0: float, tau: float, style: str, label: str) -> None:
    if not (np.isfinite(x0) and np.isfinite(x1) and np.isfinite(y0) and x1 > x0 and y0 > 0):
        return
    xs = np.geomspace(x0, x1, 20)
    ax.loglog(xs, y0 * (xs / x0) ** (-tau), style, lw=1.5, label=label)


def _cutoff_line(ax, fit: Any, x1: float, y0: float) -> None:
    """``y0 (S/x_min)^−τ e^(−(S − x_min)/S_c)`` from the fit's ``x_min`` to ``x1``."""
    x0 = fit.x_min
    if not (np.isfinite(x0) and np.isfinite(x1) and np.isfinite(y0) and x1 > x0 and y0 > 0):
        return
    xs = np.geomspace(x0, x1, 40)
    ax.loglog(xs, y0 * (xs / x0) ** (-fit.tau) * np.exp(-(xs - x0) / fit.x_c), "g-.", lw=1.5,
              label=f"exponential cut-off: τ = {fit.tau:.3f}, S_c = {fit.x_c:.2g} ε")


def plot_avalanche_histograms(
    per_n: Mapping[str, Mapping[int, LogHistogram]],
    pooled: Mapping[str, LogHistogram],
    fits: Mapping[str, PowerLawFit | None],
    predicted: Mapping[str, float],
    out: str | os.PathLike,
    title: str = "",
    titles: Mapping[str, str] | None = None,
    cutoffs: Mapping[str, Any] | None = None,
    ensemble: str = "φ",
    size_label: str = _SIZE_LABEL,
) -> None:
    """Paper Fig. 5: one panel per φ label (histograms of ``S`` for each ``N``, density per AQS
    step), the pooled-N fit (solid, over ``[x_min, x_max]``) and the predicted exponent (dashed),
    both drawn through the pooled histogram at the fit's ``x_min``; last panel: all φ together,
    ``S`` divided by each φ's typical size (the geometric mean of its binned sizes) so that the
    shapes can be compared (as the paper shifts them), with guide lines of the predicted slopes.
    ``pooled[label]`` is ``None`` where there are no avalanches (left out of the last panel).
    ``titles[label]``: a panel's title (default :data:`PHI_TITLES`, else ``φ = label``);
    ``cutoffs[label]``: a fit with an exponential cut-off (``tau``, ``x_min``, ``x_c``,
    ``at_bound``: :class:`jamlab.analysis.CutoffPowerLawFit`), drawn dash-dotted through the
    pooled histogram at its own ``x_min`` where a cut-off was resolved; ``ensemble``: what the
    labels are, for the last panel's axes (``φ``, or ``p`` for fixed-pressure ensembles);
    ``size_label``: the size axis's label."""
    titles = {lab: PHI_TITLES.get(lab, "φ = " + lab) for lab in per_n} | dict(titles or {})
    labels = list(per_n)
    n_panels = len(labels) + 1
    ncols = 2
    nrows = (n_panels + 1) // 2
    fig, axes = plt.subplots(nrows, ncols, figsize=(11, 4.2 * nrows), squeeze=False)
    flat = axes.ravel()
    letters = "abcdefgh"
    for i, lab in enumerate(labels):
        ax = flat[i]
        for j, (n, h) in enumerate(sorted(per_n[lab].items())):
            ok = h.counts > 0
            ax.errorbar(h.centres[ok], h.density[ok], h.density_err[ok], fmt="o", ms=3,
                        color=f"C{j}", label=f"N = {n} ({int(h.counts.sum())} avalanches)")
        fit = fits.get(lab)
        h = pooled[lab]
        if fit is not None:
            y0 = _anchor(h, fit.x_min)
            x_hi = fit.x_max if np.isfinite(fit.x_max) else float(h.edges[-1])
            _power_line(ax, fit.x_min, x_hi, y0, fit.tau, "k-",
                        f"fit τ = {fit.tau:.3f} [{fit.ci_low:.2f}, {fit.ci_high:.2f}]")
            if lab in predicted:
                _power_line(ax, fit.x_min, x_hi, y0, predicted[lab], "r--",
                            f"predicted τ = {predicted[lab]:.4g}")
            ax.axvline(fit.x_min, color="0.6", ls=":", lw=1)
        cut = (cutoffs or {}).get(lab)
        if cut is not None and not cut.at_bound and h is not None:
            _cutoff_line(ax, cut, float(h.edges[-1]), _anchor(h, cut.x_min))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(size_label)
        ax.set_ylabel(_DENSITY_LABEL)
        ax.set_title(f"({letters[i]}) {titles[lab]}")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
        else:
            ax.text(0.5, 0.5, "no avalanches", transform=ax.transAxes, ha="center")
    ax = flat[len(labels)]
    for j, lab in enumerate(labels):
        h = pooled[lab]
        if h is None or not (h.counts > 0).any():  # no avalanches at this φ
            continue
        ok = h.counts > 0
        # geometric mean of the binned sizes (bin centres weighted by counts): a scale for the
        # collapse
        med = float(np.exp(np.average(np.log(h.centres[ok]), weights=h.counts[ok])))
        ax.loglog(h.centres[ok] / med, h.density[ok] * med, "o-", ms=3, color=f"C{j}",
                  label=titles[lab])
    for k, tau in enumerate(sorted(set(predicted.values()))):
        xs = np.geomspace(1e-2, 1e2, 10)
        ax.loglog(xs, 0.3 * (10.0**-k) * xs ** (-tau), ("r--", "b--", "g--")[k % 3], lw=1,
                  label=f"predicted slope −{tau:.4g}")
    ax.set_xlabel(f"S / (typical S of that {ensemble})  (dimensionless)")
    ax.set_ylabel("P(S) × typical S per step (dimensionless)")
    ax.set_title(f"({letters[len(labels)]}) all together (rescaled)")
    ax.legend(fontsize=7)
    for extra in flat[n_panels:]:
        extra.set_visible(False)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)


def plot_stress_strain(
    gamma: FloatArray,
    stress: FloatArray,
    out: str | os.PathLike,
    example: int = 0,
    title: str = "",
) -> None:
    """Paper Fig. 6: mean intensive shear stress ``⟨σ_xy⟩(γ)`` over samples (rows of
    ``stress``), shaded ± one sample-to-sample standard deviation, and sample ``example``."""
    stress = np.atleast_2d(np.asarray(stress, dtype=np.float64))
    mean = stress.mean(axis=0)
    std = stress.std(axis=0, ddof=1) if stress.shape[0] > 1 else np.zeros_like(mean)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.fill_between(gamma, mean - std, mean + std, color="C0", alpha=0.25,
                    label="± sample-to-sample standard deviation")
    ax.plot(gamma, mean, "C0-", lw=2, label=f"mean over {stress.shape[0]} samples")
    ax.plot(gamma, stress[example], "C3-", lw=0.8, label=f"one sample (#{example})")
    ax.set_xlabel("shear strain γ (dimensionless)")
    ax.set_ylabel("shear stress σ_xy = Σ / L³ (ε/σ³)")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)


def plot_one_trace(
    gamma: FloatArray,
    energy_per_particle: FloatArray,
    stress: FloatArray,
    plastic: NDArray[np.bool_],
    out: str | os.PathLike,
    title: str = "",
    *,
    pressure: FloatArray | None = None,
    counted: NDArray[np.bool_] | None = None,
    jammed: NDArray[np.bool_] | None = None,
) -> None:
    """Paper Fig. 4: ``E/N`` and ``σ_xy`` against ``γ`` for one sample, plastic steps marked
    at the minimum they end in. With ``pressure`` a third panel, ``p(γ)`` on a log axis; with
    ``counted`` (per minimum, as ``plastic``) the counted avalanches are filled and the other
    flagged steps hollow; with ``jammed`` (per minimum) the steps that start or end at an
    unjammed minimum (those the statistics exclude) are shaded in every panel."""
    rows = 3 if pressure is not None else 2
    fig, axes = plt.subplots(rows, 1, sharex=True, figsize=(7, 2.6 * rows + 0.6))
    ax_e, ax_s = axes[0], axes[1]
    ax_e.plot(gamma, energy_per_particle, lw=1)
    ax_s.plot(gamma, stress, lw=1)
    flagged = np.asarray(plastic, dtype=bool)
    if counted is None:
        marks = ((flagged, dict(ms=2.5, color="C3"), "plastic step"),)
    else:
        counted = np.asarray(counted, dtype=bool)
        marks = (
            (counted, dict(ms=3, color="C3"),
             "avalanche counted: plastic, ΔE < 0, both minima jammed"),
            (flagged & ~counted, dict(ms=3, mfc="none", mec="0.4"),
             "flagged plastic, not counted (a minimum unjammed, or ΔE ≥ 0)"),
        )
    for mask, style, label in marks:
        idx = np.flatnonzero(mask)
        ax_e.plot(gamma[idx], energy_per_particle[idx], "o", ls="none", **style,
                  label=f"{label} ({idx.size})")
        ax_s.plot(gamma[idx], stress[idx], "o", ls="none", **style)
    if pressure is not None:
        ax_p = axes[2]
        p = np.asarray(pressure, dtype=np.float64)
        pos = p > 0
        ax_p.semilogy(gamma[pos], p[pos], lw=1, color="C2")
        ax_p.set_ylabel("pressure p (ε/σ³)")
    if jammed is not None:
        jm = np.asarray(jammed, dtype=bool)
        excluded = ~(jm[:-1] & jm[1:])  # step k - 1 -> k, as the statistics exclude it
        for k in np.flatnonzero(excluded):
            for ax in axes:
                ax.axvspan(gamma[k], gamma[k + 1], color="0.88", lw=0, zorder=0)
        axes[0].plot([], [], "s", color="0.88",
                     label=f"shaded: steps from or to an unjammed minimum ({int(excluded.sum())}"
                           f" of {excluded.size}; {int((~jm).sum())} of {jm.size} minima "
                           "unjammed)")
    ax_e.set_ylabel("energy per particle E/N (ε)")
    ax_s.set_ylabel("shear stress σ_xy (ε/σ³)")
    axes[-1].set_xlabel("shear strain γ (dimensionless)")
    ax_e.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)


def plot_moduli(
    moments: Mapping[str, Mapping[int, ModulusMoments]],
    fits: Mapping[str, tuple[int, SlopeFit, float] | None],
    out: str | os.PathLike,
    how: str,
) -> None:
    """Paper Fig. 7: for each φ label a row with ``⟨μ_1⟩`` (log δγ axis) and ``⟨μ_1²⟩``
    (log-log) against ``δγ``, one curve per ``N``, with the within-sample variance of ``μ_1``
    (``mu1_var``, dotted, where the moments have it); ``fits[label] = (N, slope fit, δγ_max of
    the fit)`` is drawn on the ``⟨μ_1²⟩`` panel. ``how`` says where the moments come from."""
    labels = list(moments)
    fig, axes = plt.subplots(len(labels), 2, figsize=(11, 4 * len(labels)), squeeze=False)
    letters = iter("abcdefgh")
    for i, lab in enumerate(labels):
        ax1, ax2 = axes[i]
        for j, (n, m) in enumerate(sorted(moments[lab].items())):
            ax1.errorbar(m.strain_step, m.mu1, m.mu1_err, fmt="o-", ms=3, color=f"C{j}",
                         label=f"N = {n} ({m.n_samples} samples)")
            ax2.errorbar(m.strain_step, m.mu1_sq, m.mu1_sq_err, fmt="o-", ms=3, color=f"C{j}",
                         label=f"N = {n}")
            if m.mu1_var is not None:
                ax2.errorbar(m.strain_step, m.mu1_var, m.mu1_var_err, fmt="s:", ms=2.5, lw=1,
                             mfc="none", color=f"C{j}",
                             label=f"N = {n}: within-sample variance of μ_1")
        fit = fits.get(lab)
        if fit is not None:
            n, sf, dg_max = fit
            m = moments[lab][n]
            xs = m.strain_step[m.strain_step <= dg_max * (1 + 1e-9)]
            ax2.loglog(xs, np.exp(sf.intercept) * xs**sf.slope, "k--", lw=1.5,
                       label=f"fit N={n}: slope {sf.slope:.2f} ± {sf.slope_err:.2f}")
        ax1.set_xscale("log")
        ax1.set_xlabel("strain step δγ (dimensionless)")
        ax1.set_ylabel("⟨μ_1⟩ = ⟨ΔΣ⟩/(L³ δγ) (ε/σ³)")
        ax1.set_title(f"({next(letters)}) ⟨μ_1⟩, {PHI_TITLES.get(lab, lab)}")
        ax1.legend(fontsize=7)
        ax2.set_xscale("log")
        ax2.set_yscale("log")
        ax2.set_xlabel("strain step δγ (dimensionless)")
        ax2.set_ylabel("⟨μ_1²⟩ = ⟨ΔΣ²⟩/(L⁶ δγ²) (ε²/σ⁶)")
        ax2.set_title(f"({next(letters)}) ⟨μ_1²⟩, {PHI_TITLES.get(lab, lab)}")
        ax2.legend(fontsize=7)
    fig.suptitle("\n".join(textwrap.wrap(how, 150)), fontsize=9)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)


def plot_jump_distributions_two_panels(
    tables: Sequence[tuple[float, Mapping[float, Mapping[str, FloatArray]]]],
    out: str | os.PathLike,
) -> None:
    """Paper Fig. 3: ``P(ΔE|δγ)`` of the printed formula against ``|ΔE|``, one panel per ``μ``
    (``tables = [(μ, jamlab.plots.theory.jump_distribution_table(μ, ...)), ...]``), with a guide of
    slope ``−2μ``."""
    fig, axes = plt.subplots(1, len(tables), figsize=(6 * len(tables), 4.6), squeeze=False)
    for ax, (mu, table), letter in zip(axes[0], tables, "abcd", strict=False):
        tops = []
        for dg, t in sorted(table.items(), key=lambda kv: -abs(kv[0])):
            ok = t["pdf"] > 0
            ax.loglog(t["abs_dE"][ok], t["pdf"][ok], label=f"δγ = {dg:g}")
            tops.append(float(np.max(t["pdf"])))
        dg_min = min(table, key=abs)
        t = table[dg_min]
        centre = abs(dg_min) * 1e-3
        p_c = float(np.exp(np.interp(np.log(centre), np.log(t["abs_dE"]),
                                     np.log(np.maximum(t["pdf"], 1e-300)))))
        xs = centre * np.logspace(-2, 2, 2)
        ax.loglog(xs, 3 * p_c * (xs / centre) ** (-2 * mu), "k--", lw=1,
                  label=f"slope −2μ = {-2 * mu:.4g}")
        floor = min(float(np.interp(np.log(5 * abs(d)), np.log(tt["abs_dE"]), tt["pdf"]))
                    for d, tt in table.items())
        if floor > 0:
            ax.set_ylim(floor, 10 * max(tops))
        ax.set_xlabel("|ΔE| (mean-field units, dimensionless)")
        ax.set_ylabel("P(ΔE | δγ) (1/energy, mean-field units)")
        ax.set_title(f"({letter}) μ = {mu:.6g}")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)


def plot_no_jump_probability(
    dgamma_fine: FloatArray,
    printed_fine: FloatArray,
    first_order_fine: FloatArray,
    dgamma: FloatArray,
    exact: FloatArray,
    sampled: FloatArray,
    sampled_err: FloatArray,
    out: str | os.PathLike,
    title: str,
) -> None:
    """Theory vs cascade: ``R(0) = P(no jump)`` against ``δγ`` — printed formula, its
    first-order exponential, the exact recursion and the cascade sampler."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(dgamma_fine, printed_fine, "C3-", label="printed formula (paper)")
    ax.plot(dgamma_fine, first_order_fine, "C2:", label="exp(−δγ·rate), no δγ²Y term")
    ax.plot(dgamma, exact, "ks", mfc="none", ms=7, label="exact recursion (k levels)")
    ax.errorbar(dgamma, sampled, sampled_err, fmt="C0o", ms=4, label="cascade sampler (k levels)")
    ax.set_xlabel("strain step δγ (dimensionless)")
    ax.set_ylabel("P(no jump) = R(0) (probability)")
    ax.set_title("\n".join(textwrap.wrap(title, 80)), fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)


def plot_tau_against_pressure(
    pressures: Sequence[float],
    panels: Sequence[tuple[str, Mapping[str, tuple[Sequence[float], Sequence[float],
                                                   Sequence[float]]]]],
    references: Mapping[str, tuple[float, float]],
    out: str | os.PathLike,
) -> None:
    """τ against the pressure of fixed-pressure AQS (log axis), one panel per ``(title, fits)``
    of ``panels`` (sharing the τ axis), one series per fit: ``fits[label] = (τ, lower end,
    upper end)`` per pressure (NaN: no fit there), drawn as points with bars, offset a little
    in ``p`` so that the bars do not hide each other; ``references[label] = (value, σ)`` as
    horizontal lines in every panel (a band of ± σ where ``σ > 0``); the ``p`` axis runs half
    a decade beyond the pressures on each side."""
    p = np.asarray(pressures, dtype=np.float64)
    fig, axes = plt.subplots(1, len(panels), figsize=(6.2 * len(panels), 5.6), sharey=True,
                             squeeze=False)
    for ax, (title, fits) in zip(axes[0], panels, strict=True):
        for i, (label, (value, σ)) in enumerate(references.items()):
            colour = f"C{7 + i % 3}" if i else "k"
            ax.axhline(value, color=colour, ls="--", lw=1, label=label)
            if σ > 0:
                ax.axhspan(value - σ, value + σ, color=colour, alpha=0.12)
        n = len(fits)
        for i, (label, (tau, lo, hi)) in enumerate(fits.items()):
            t, a, b = (np.asarray(v, dtype=np.float64) for v in (tau, lo, hi))
            ok = np.isfinite(t)
            x = p[ok] * 10 ** (0.06 * (i - (n - 1) / 2))
            ax.errorbar(x, t[ok], yerr=np.vstack([t[ok] - a[ok], b[ok] - t[ok]]),
                        fmt="os^Dv<>"[i % 7], color=f"C{i}", capsize=3, ms=5, lw=1.2,
                        label=label)
        ax.set_xscale("log")
        if p.size:  # half a decade beyond the pressures: one pressure alone is not a sliver
            ax.set_xlim(p.min() / 10 ** 0.5, p.max() * 10 ** 0.5)
        ax.set_xlabel("pressure p (ε/σ³)")
        ax.set_title(title, fontsize=10)
        # below the panel: the reference lines and the bars span the whole axes, so no corner
        # inside is free (a legend there hid part of a bar)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    axes[0][0].set_ylabel("avalanche exponent τ")
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=110)
    plt.close(fig)
