"""The report's figures: typed results drawn with :mod:`jamlab.plots`, their titles and captions.

Each ``fig*`` function writes one figure into ``figdir`` (a PNG, or the format ``ext`` names:
``".pdf"``, ``".svg"`` …) and returns its path (None when the result
has nothing to draw); the drawing itself is in :mod:`jamlab.plots.report`,
:mod:`jamlab.plots.packings`, :mod:`jamlab.plots.cascade` and :mod:`jamlab.plots.theory`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from jamlab.reproduce.coordination import CoordinationResult
from jamlab.reproduce.criticality import FiniteSizeResult, PackingCriticality
from jamlab.reproduce.measurements import (
    ModuliResult,
    OneTrace,
    StressStrain,
    TauEstimate,
    predicted_tau,
)
from jamlab.reproduce.scales import Scale
from jamlab.reproduce.theory_checks import (
    FIG3_EXACT_DGAMMAS,
    FIG3_EXACT_POINTS,
    LINEAR_Y,
    TheoryChecks,
)

__all__ = [
    "TITLES",
    "captions",
    "fig1",
    "fig2",
    "fig3",
    "fig3_exact",
    "fig4",
    "fig5",
    "fig6",
    "fig7",
    "theory_vs_cascade",
    "criticality",
    "finite_size",
    "criticality_captions",
    "fig5_pressure",
    "tau_pressure",
    "tau_pressure_references",
    "tau_pressure_series",
    "tau_pressure_per_n",
]

TITLES = {
    "fig1": "Fig. 1 — coordination vs packing fraction",
    "fig2": "Fig. 2 — a Derrida–Ruelle cascade",
    "fig3": "Fig. 3 — mean-field jump distribution P(ΔE|δγ)",
    "fig3_exact": "Fig. 3, exact — the printed formula beside the exact jump law",
    "fig4": "Fig. 4 — energy, stress and pressure vs strain, one sample at jamming",
    "fig5": "Fig. 5 — avalanche size distributions",
    "fig6": "Fig. 6 — mean stress–strain curve",
    "fig7": "Fig. 7 — moments of the shear modulus vs δγ",
    "theory_vs_cascade": "Theory vs cascade — probability of no jump",
    "criticality": "Criticality — contact forces and gaps of the jamming ensemble's packings",
    "finite_size": "Finite-size scaling — ⟨S⟩, S_c against N and the collapse P(S) S^τ",
    "fig5_pressure": "Fig. 5 at fixed pressure — avalanche size distributions at each p",
    "tau_pressure": "τ(p) — the avalanche exponent at fixed pressure as p → 0",
}
"""Figure titles, in report order."""

FIG3_DGAMMAS = (1e-2, 1e-3, 1e-4)
"""The strain steps of Fig. 3."""


def fig1(r: CoordinationResult, figdir: Path, ext: str = ".png") -> Path | None:
    """Coordination and pressure of the first packing against ``φ − φ_J``."""
    from jamlab.plots.packings import plot_coordination

    if not r.curves:
        return None
    path = figdir / f"fig1_coordination{ext}"
    plot_coordination(r.curves[0], path)
    return path


def fig2(scale: Scale, figdir: Path, ext: str = ".png") -> Path:
    """A 6-level cascade at δγ = 0.3 (seed ``seed + 2``)."""
    from jamlab.plots.cascade import cascade_tree_figure
    from jamlab.theory import ParisiFunction, sample_cascade_tree

    path = figdir / f"fig2_cascade_tree{ext}"
    q6, y6 = ParisiFunction.linear(*LINEAR_Y).discretise(6)
    cascade_tree_figure(sample_cascade_tree(q6, y6, 0.3, seed=scale.seed + 2), path)
    return path


def fig3(figdir: Path, ext: str = ".png") -> Path:
    """The printed jump distribution at jamming (μ_J) and in the UNSAT phase (μ = 1/2)."""
    from jamlab.plots.report import plot_jump_distributions_two_panels
    from jamlab.plots.theory import jump_distribution_table
    from jamlab.theory import mu_jamming

    path = figdir / f"fig3_theory{ext}"
    plot_jump_distributions_two_panels(
        [(mu_jamming(), jump_distribution_table(mu_jamming(), FIG3_DGAMMAS, n_points=150)),
         (0.5, jump_distribution_table(0.5, FIG3_DGAMMAS, n_points=150))], path)
    return path


def fig3_exact(figdir: Path, ext: str = ".png", tables: dict | None = None) -> Path:
    """Fig. 3 with jamlab's exact law beside the printed formula (same ``y``, cut-off 1 − 1e-5);
    ``tables``: its tables made already (:func:`jamlab.reproduce.theory_checks.exact_law_checks`),
    else it computes them."""
    from jamlab.plots.theory import plot_jump_distributions_exact
    from jamlab.theory import mu_jamming

    path = figdir / f"fig3_exact{ext}"
    plot_jump_distributions_exact((mu_jamming(), 0.5), FIG3_EXACT_DGAMMAS, path,
                                  n_points=FIG3_EXACT_POINTS, tables=tables)
    return path


def fig4(t: OneTrace | None, scale: Scale, figdir: Path, ext: str = ".png") -> Path | None:
    """Energy, stress and pressure against strain of one sample of the jamming ensemble."""
    from jamlab.plots.report import plot_one_trace

    if t is None:
        return None
    path = figdir / f"fig4_one_jammed_sample{ext}"
    plot_one_trace(t.gamma, t.energy_per_particle, t.stress, t.plastic, path,
                   title=f"one sample at jamming: N = {t.n}, sample {t.sample}, "
                         f"φ_J = {t.phi_j:.4f}, δγ = {scale.dgamma:g}",
                   pressure=t.pressure, counted=t.counted, jammed=t.jammed)
    return path


def fig5(estimates: dict[str, TauEstimate], scale: Scale, figdir: Path, ext: str = ".png") -> Path:
    """Avalanche size histograms per N and pooled, with the fits and the theory's τ."""
    from jamlab.plots.report import plot_avalanche_histograms

    path = figdir / f"fig5_avalanches{ext}"
    order = ["0.75", "0.8", "jamming"]
    plot_avalanche_histograms({k: estimates[k].per_n for k in order},
                              {k: estimates[k].pooled for k in order},
                              {k: e.fit for k, e in estimates.items()},
                              {k: predicted_tau(k) for k in estimates}, path,
                              title=f"δγ = {scale.dgamma:g}, γ_max = {scale.gamma_max:g}")
    return path


def fig5_pressure(estimates: dict[float, TauEstimate] | None, scale: Scale, figdir: Path,
                  ext: str = ".png") -> Path | None:
    """Fig. 5 for the fixed-pressure ensembles: one panel per p (histograms per N, the power
    law, the exponential cut-off and τ_J through the pooled histogram), then all p rescaled;
    None without fixed-pressure studies."""
    from jamlab.plots.report import plot_avalanche_histograms

    if not estimates:
        return None
    es = {f"{p:g}": e for p, e in sorted(estimates.items(), reverse=True)}
    path = figdir / f"fig5_pressure{ext}"
    plot_avalanche_histograms({k: e.per_n for k, e in es.items()},
                              {k: e.pooled for k, e in es.items()},
                              {k: e.fit for k, e in es.items()},
                              {k: predicted_tau("jamming") for k in es}, path,
                              title=(f"fixed-pressure AQS (S = −ΔH), δγ = "
                                     f"{scale.pressure_step:g}, γ_max = "
                                     f"{scale.pressure_gamma_max:g}"),
                              titles={k: f"p = {k}" for k in es},
                              cutoffs={k: e.cutoff for k, e in es.items()}, ensemble="p",
                              size_label="avalanche size S = −ΔH (total enthalpy, units of ε)")
    return path


def _columns(points: list[tuple[float, float, float] | None]) -> tuple[list[float], ...]:
    """``(τ, lower, upper)`` per pressure as three columns, NaN where a point is None."""
    rows = [(math.nan,) * 3 if q is None else q for q in points]
    return tuple(list(column) for column in zip(*rows, strict=True)) if rows else ([], [], [])


def tau_pressure_series(estimates: dict[float, TauEstimate],
                        ) -> tuple[list[float], dict[str, tuple[list[float], ...]]]:
    """The pressures (decreasing) and, per fit of the report's τ(p) rows, ``(τ, lower, upper)``
    per pressure (NaN where there is no fit): the exponential cut-off in its KS window (± its
    σ), the same from the lowest δγ-converged floor (± its asymptotic σ) and with the cut-off's
    shape free (τ at the best shape, the 95 % profile interval)."""
    ps = sorted(estimates, reverse=True)
    es = [estimates[p] for p in ps]
    conv = [None if e.cutoff_converged is None else e.cutoff_converged.fit for e in es]
    return ps, {
        "exponential cut-off, KS window (± σ)": _columns([
            None if e.cutoff is None else
            (e.cutoff.tau, e.cutoff.tau - e.cutoff_sigma, e.cutoff.tau + e.cutoff_sigma)
            for e in es]),
        "exponential cut-off, δγ-converged floor (± σ)": _columns([
            None if f is None else (f.tau, f.tau - f.tau_stderr, f.tau + f.tau_stderr)
            for f in conv]),
        "cut-off shape free (best shape; 95 % interval)": _columns([
            None if e.cutoff_shape is None else
            (e.cutoff_shape.tau_best, e.cutoff_shape.tau_low, e.cutoff_shape.tau_high)
            for e in es]),
    }


def tau_pressure_per_n(estimates: dict[float, TauEstimate],
                       ) -> dict[str, tuple[list[float], ...]]:
    """Per N (every N with a fit at some pressure), ``(τ, τ − σ, τ + σ)`` per pressure
    (decreasing; NaN without a fit) of the exponential cut-off fitted to that N alone in the
    pooled row's window, σ asymptotic (:attr:`TauEstimate.cutoff_per_n`)."""
    ps = sorted(estimates, reverse=True)
    per_p = [estimates[p].cutoff_per_n or {} for p in ps]
    ns = sorted({n for fits in per_p for n, f in fits.items() if f is not None})
    return {f"N = {n} alone, the pooled KS window (± asymptotic σ)": _columns([
        None if (f := fits.get(n)) is None else (f.tau, f.tau - f.tau_stderr,
                                                 f.tau + f.tau_stderr)
        for fits in per_p]) for n in ns}


def tau_pressure_title(estimates: dict[float, TauEstimate]) -> str:
    """The first panel's title: the sizes N the rows pool (``TauEstimate.per_n``), as run."""
    names = [str(n) for n in sorted({n for e in estimates.values() for n in e.per_n})]
    if len({frozenset(e.per_n) for e in estimates.values()}) > 1:
        return f"fixed-pressure AQS, N = {', '.join(names)} (not every N at every p)"
    return f"fixed-pressure AQS, N = {' + '.join(names)}" + (" pooled" if len(names) > 1 else "")


def tau_pressure_references() -> dict[str, tuple[float, float]]:
    """The reference lines of a τ(p) figure, ``{label: (value, σ)}``: τ_J (p → 0), the paper's
    constant-volume fit with its quoted uncertainty, τ_UNSAT = 1."""
    from jamlab.paper import PAPER_TAU

    paper, paper_err = PAPER_TAU["jamming"]
    tau_j = predicted_tau("jamming")
    return {f"theory τ_J = {tau_j:.5f} (p → 0)": (tau_j, 0.0),
            f"paper's constant-volume fit {paper} ± {paper_err}": (paper, paper_err),
            "τ_UNSAT = 1": (1.0, 0.0)}


def tau_pressure(estimates: dict[float, TauEstimate] | None, figdir: Path,
                 ext: str = ".png") -> Path | None:
    """τ(p) of the report's fixed-pressure rows against τ_J, the paper's constant-volume fit
    and τ_UNSAT (None without fixed-pressure studies)."""
    from jamlab.plots.report import plot_tau_against_pressure

    if not estimates:
        return None
    ps, fits = tau_pressure_series(estimates)
    refs = tau_pressure_references()
    panels = [(tau_pressure_title(estimates), fits)]
    per_n = tau_pressure_per_n(estimates)
    if per_n:
        panels.append(("each N alone, exponential cut-off in the pooled window", per_n))
    path = figdir / f"tau_pressure{ext}"
    plot_tau_against_pressure(ps, panels, refs, path)
    return path


def fig6(s: StressStrain | None, scale: Scale, figdir: Path, ext: str = ".png") -> Path | None:
    """Mean stress–strain curve with its spread and one sample."""
    from jamlab.plots.report import plot_stress_strain

    if s is None:
        return None
    path = figdir / f"fig6_stress_strain{ext}"
    plot_stress_strain(s.gamma, s.stress, path, example=0,
                       title=f"φ = {scale.stress_phi:g}, N = {scale.stress_n}, "
                             f"δγ = {scale.stress_dgamma:g}")
    return path


def fig7(r: ModuliResult, scale: Scale, figdir: Path, ext: str = ".png") -> Path:
    """⟨μ_1⟩ and ⟨μ_1²⟩ against δγ with the slope fits."""
    from jamlab.plots.report import plot_moduli

    how = ("Moments from subsampling one fine trace per sample (overlapping differences "
           f"Σ(γ+mδγ₀) − Σ(γ), δγ₀ = {scale.dgamma:g}, lags m = "
           f"{', '.join(map(str, scale.moduli_lags))}); no separate runs. Error bars: standard "
           "error over samples.")
    path = figdir / f"fig7_moduli{ext}"
    plot_moduli(r.moments, r.slopes, path, how)
    return path


def theory_vs_cascade(th: TheoryChecks, figdir: Path, ext: str = ".png") -> Path:
    """P(no jump) of the printed formula, its first order, the exact recursion, the sampler."""
    from jamlab.plots.report import plot_no_jump_probability

    path = figdir / f"theory_vs_cascade{ext}"
    rr = th.rows
    plot_no_jump_probability(
        np.array(th.fine_dgamma), np.array(th.fine_printed), np.array(th.fine_first_order),
        np.array([r.dgamma for r in rr]), np.array([r.exact for r in rr]),
        np.array([r.sampled for r in rr]), np.array([r.sampled_err for r in rr]), path,
        title=f"y(q) = 2.5 q, q_max = 0.9; cascade and recursion with k = {th.k} levels, "
              f"{th.n} samples per point")
    return path


def criticality(r: PackingCriticality, figdir: Path, ext: str = ".png") -> Path | None:
    """``P(f)``, ``g(h)`` and their CDFs per N of the jamming ensemble's initial packings, with
    the pooled fits (:func:`jamlab.plots.criticality.plot_distributions`)."""
    from jamlab.plots.criticality import plot_distributions

    if not r.observables:
        return None
    path = figdir / f"criticality{ext}"
    plot_distributions(r.observables, {k: f for k, f in r.fits.items() if f is not None}, path)
    return path


def finite_size(r: FiniteSizeResult, figdir: Path, ext: str = ".png") -> Path | None:
    """``⟨S⟩``, ``S_c`` against N and the collapse, per φ label."""
    from jamlab.plots.finite_size import plot_finite_size_scaling

    if all(v is None for v in r.scaling.values()):
        return None
    path = figdir / f"finite_size{ext}"
    titles = {"jamming": "at jamming", "0.75": "φ = 0.75", "0.8": "φ = 0.80"}
    plot_finite_size_scaling(r.scaling, r.collapse, titles, path)
    return path


def criticality_captions(crit: PackingCriticality | None,
                         fss: FiniteSizeResult | None) -> dict[str, str]:
    """Captions of the two criticality figures."""
    sizes = ", ".join(f"N = {n}: {k}" for n, k in sorted(crit.packings.items())) if crit else ""
    return {
        "criticality": (
            "Extended and localized contact forces f/⟨f⟩ and gaps h of the initial packings of "
            f"the jamming ensemble ({sizes} packings, p ≈ p_target): densities per N (top) with "
            "the SPEC §6 reference slopes, CDFs per N (bottom) with the fit of all N pooled (red,"
            " its window shaded grey). Hatched: below the resolution (forces < 1e-3 ⟨f⟩ at "
            "ftol = 1e-12, gaps < 1e-7). Small N: far from the asymptotic regime "
            "(docs/criticality.md)."),
        "finite_size": (
            "Top: mean size ⟨S⟩ and cut-off S_c = ⟨S²⟩/⟨S⟩ (ε, total) against N, error bars "
            "from a bootstrap over samples, dashed the weighted power-law fits. Bottom: P(S)S^τ "
            "against S/N^β at the fitted β and the report's τ (jammed steps only, log bins with "
            "≥ 3 avalanches). With two sizes β is only a rough estimate."
            + (" Missing: " + "; ".join(f"{k}: {v}" for k, v in fss.reasons.items())
               if fss is not None and fss.reasons else "")),
    }


def captions(
    scale: Scale,
    coordination: CoordinationResult | None = None,
    taus: dict[str, TauEstimate] | None = None,
    theory: TheoryChecks | None = None,
) -> dict[str, str]:
    """The caption of each figure; the results fill in φ_J, the avalanche counts and the
    cascade's size (without them: NaN, none, and the scale's settings)."""
    from jamlab.theory import mu_jamming, tau_jamming

    phi_j = coordination.phi_j_first if coordination is not None else math.nan
    counts = {k: e.n_avalanches for k, e in (taus or {}).items()}
    k, n = (theory.k, theory.n) if theory is not None else (scale.cascade_k,
                                                            scale.cascade_samples)
    return {
        "fig1": (f"Mean coordination z (all particles) and z_nr (rattlers removed) of one "
                 f"packing of N = {scale.coord_n} compressed from its jamming point "
                 f"φ_J = {phi_j:.5f}; right: z_nr − 2d, z_nr − z_iso(N') "
                 "and pressure p (ε/σ³) against φ − φ_J with least-squares power laws over the "
                 "shaded range."),
        "fig2": ("A 6-level cascade (y = 2.5 q, q_max = 0.9 discretised) at δγ = 0.3: states "
                 "coloured by energy U, old ground state circled, new ground state starred. "
                 "Vertical axis: levels labelled by overlap q (dimensionless)."),
        "fig3": ("The printed formula P(ΔE|δγ) (SPEC §1) for y'(q) ~ (1−q)^(−μ−1) without "
                 f"cut-off: (a) μ = μ_J = {mu_jamming():.6f} (jamming), (b) μ = 1/2 (UNSAT, "
                 "SK); dashed: slope −2μ = −τ."),
        "fig3_exact": ("P(ΔE|δγ) for y(q) = (1−q)^(−μ) − 1 cut at q_max = 1 − 1e-5: jamlab's "
                       "exact law (solid, docs/theory-vs-cascade.md §7–9) and the paper's printed "
                       "formula with the same cut-off (dashed) and without (grey), at δγ = 1e-2 "
                       "and 1e-3; below, the local log-slopes against −2μ, and at the bottom "
                       "the ratio exact/printed (their difference is first order in δγ)."),
        "fig4": ("Energy per particle E/N (ε), intensive shear stress σ_xy = Σ/L³ and "
                 "pressure p (ε/σ³) against strain for the first finished sample of the largest "
                 "jamming ensemble (constant volume from p_target, the paper's protocol). Red: "
                 "the avalanches the report counts (plastic, ΔE < 0, both minima jammed); "
                 "hollow: steps flagged plastic but not counted; grey bands: steps that start or "
                 "end at an unjammed minimum (no rigid backbone, or p below the resolution "
                 "floor), which every statistic excludes."),
        "fig5": ("Histograms of S = −ΔE (total energy, ε) per AQS step for each N, at "
                 "φ = 0.75, 0.80 and at jamming, and (d) all together with S rescaled by a "
                 "typical size of each φ. Black: maximum-likelihood truncated power law fitted "
                 "to all N pooled (x_min dotted); red dashed: predicted τ (1 above jamming, "
                 f"{tau_jamming():.5f} at jamming). Avalanches: "
                 + ", ".join(f"{k}: {v}" for k, v in counts.items()) + "."),
        "fig6": (f"Mean intensive shear stress over {scale.stress_samples} samples at "
                 f"φ = {scale.stress_phi:g} (N = {scale.stress_n}, δγ = "
                 f"{scale.stress_dgamma:g}), shaded ± one sample-to-sample standard deviation, "
                 "and one sample. The paper does not state its φ for this figure."),
        "fig7": ("⟨μ_1⟩ and ⟨μ_1²⟩ against δγ at jamming and at φ = 0.75, from subsampling one "
                 f"fine trace per sample (δγ₀ = {scale.dgamma:g}, overlapping differences), not "
                 "from separate runs. Dashed: weighted least-squares slope over δγ ≤ "
                 f"{scale.moduli_fit_max_lag * scale.dgamma:g} at the largest N. Dotted: the "
                 "within-sample variance of μ_1 (each sample's own mean removed), the part of "
                 "⟨μ_1²⟩ the jumps make; ⟨μ_1²⟩ adds ⟨μ_1⟩² and the spread of the modulus "
                 "between samples, flat in δγ."),
        "fig5_pressure": (
            "Sizes S = −ΔH of the fixed-pressure avalanches (density per AQS step, log bins, "
            "± Poisson), one panel per pressure with each N; solid: the power law fitted to all "
            "N pooled above its KS x_min (the τ row); dash-dotted: the power law with an "
            "exponential cut-off (its own KS x_min); dashed: the mean-field τ_J, the p → 0 "
            "limit. Every line is drawn through the pooled histogram at its x_min (guides, not "
            "normalised densities). Below x_min the histogram turns over at the plastic flag's "
            f"threshold, at least 0.1 δγ² = {0.1 * scale.pressure_step ** 2:.2g} ε (docs/aqs.md, "
            "\"Fixed-pressure AQS\"). Last panel: every p, S divided by its typical size."),
        "tau_pressure": (
            "τ of the avalanches S = −ΔH of fixed-pressure AQS (all N pooled) against the "
            "pressure: the power law with an exponential cut-off in its KS window (± the "
            "bootstrap σ, the choice of x_min included), the same fit from the lowest floor "
            "where doubling the strain step moves τ by less than its σ (± asymptotic σ at that "
            "floor), and τ at the best stretched cut-off e^(−(S/S_c)^a) with the 95 % profile "
            "interval of τ with the shape free; right (with more than one N): the exponential "
            "cut-off fitted to each N alone in the pooled row's KS window (± asymptotic σ; one "
            "window for all N, since the local τ rises with the window's floor). Lines: the "
            "mean-field τ_J (the p → 0 limit), the paper's constant-volume fit (band ± its "
            "error) and τ_UNSAT = 1."),
        "theory_vs_cascade": (
            "Probability of no jump R(0) against δγ for y(q) = 2.5 q, q_max = 0.9: the "
            f"paper's printed formula, its first-order form, the exact recursion with k = "
            f"{k} levels and the exact cascade sampler ({n} samples per point). "
            "The printed formula departs from the exact cascade at finite δγ "
            "(docs/theory-vs-cascade.md)."),
    }
