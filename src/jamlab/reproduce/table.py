"""The report's table: typed results turned into :class:`jamlab.report.Row` and JSON data.

Each ``*_rows`` function renders one part's result as rows (quantity, the paper's value, ours with
its σ, sample counts, comparisons); each ``*_data`` function the machine-readable numbers stored
in ``results.json`` under ``"data"``. The reference values come from :mod:`jamlab.paper`, the
theory's from :mod:`jamlab.theory`; nothing is computed here.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

from jamlab.paper import (
    COORDINATION_EXPONENTS,
    K1_EXACT_SPEC,
    K1_PAPER_CHI,
    OHERN_PHI_J_3D,
    PAPER_PHI_J,
    PAPER_PHI_J_ERR,
    PAPER_TAU,
    PAPER_TAU_J,
    PAPER_TAU_J_DIGITS,
    PRINTED_NO_JUMP_SPEC,
)
from jamlab.report import Comparison, Row, format_value
from jamlab.reproduce.coordination import CoordinationResult
from jamlab.reproduce.measurements import (
    PhiJEstimate,
    TauEstimate,
    interval_note,
    predicted_tau,
    sigma_from_ci95,
)
from jamlab.reproduce.scales import SCALES, Scale
from jamlab.reproduce.size_table import size_difference_data, size_difference_row
from jamlab.reproduce.theory_checks import TheoryChecks

__all__ = [
    "TARGETS",
    "coordination_data",
    "coordination_rows",
    "fit_text",
    "notes",
    "parameters",
    "phi_j_data",
    "pressure_text",
    "TAU_TITLES",
    "phi_j_row",
    "tau_data",
    "tau_rows",
    "pressure_tau_data",
    "pressure_tau_rows",
    "tau_samples_text",
    "theory_data",
    "theory_rows",
]

TARGETS = {"tau_unsat": 0.15, "tau_jamming": 0.2, "slope": 0.2}
"""Acceptance windows of issue 8 at the quick scale (|τ−1|, |τ−1.41|, |slope+1|)."""

TAU_TITLES = {
    "jamming": "τ at jamming (constant volume from p_target, the paper's protocol)",
    "0.75": "τ at φ = 0.75",
    "0.8": "τ at φ = 0.80",
}


def pressure_text(q: tuple[float, float, float] | None) -> str:
    """``median … [10–90 %: …, …]`` of a pressure summary, or ``none``."""
    if q is None:
        return "none"
    return f"median {q[0]:.2g} [10–90 %: {q[1]:.2g}, {q[2]:.2g}]"


def tau_samples_text(e: TauEstimate) -> str:
    """The sample column of a τ row: counts, exclusions, pressures of the fitted avalanches
    and (at jamming) of every minimum sampled."""
    text = (f"{e.samples} samples, {e.steps} steps, {e.n_avalanches} avalanches; "
            f"{e.exclusion_text}; p at the start of the fitted avalanches (S ≥ x_min): "
            f"{pressure_text(e.fit_pressures)}")
    if e.label == "jamming":
        text += f"; p of all minima sampled: {pressure_text(e.sampled_pressures)}"
    return text


def _exp_text(x: float) -> str:
    """``5e-06`` written as ``5e-6``."""
    return f"{x:g}".replace("e-0", "e-").replace("e+0", "e+")


def fit_text(fit: Any, sigma: float) -> str:
    """A τ fit as printed in the table: ``τ ± σ (95% CI, x_min, tail)``, or ``n/a``."""
    if fit is None:
        return "n/a"
    return (f"{fit.tau:.3f} ± {sigma:.3f} (95% CI [{fit.ci_low:.3f}, {fit.ci_high:.3f}], "
            f"x_min = {fit.x_min:.3g} ε, tail {fit.n_tail}{interval_note(fit)})")


def tau_rows(estimates: dict[str, TauEstimate]) -> list[Row]:
    """One row per τ: against the paper's fit, the theory and the issue's target window."""
    rows = []
    for label, title in TAU_TITLES.items():
        e = estimates[label]
        paper, paper_err = PAPER_TAU[label]
        theory = predicted_tau(label)
        tol = TARGETS["tau_jamming"] if label == "jamming" else TARGETS["tau_unsat"]
        rows.append(Row(
            quantity=title,
            reference_text=(f"{paper} ± {paper_err} (paper's fit); theory "
                            f"{theory:.5g}" if label == "jamming" else
                            f"{paper} ± {paper_err} (paper's fit); theory τ_UNSAT = 1"),
            value=e.fit.tau if e.fit is not None else float("nan"),
            error=e.sigma,
            value_text=fit_text(e.fit, e.sigma),
            samples=tau_samples_text(e),
            comparisons=(
                Comparison("the paper's fit", paper, paper_err),
                Comparison("theory", theory),
                Comparison(f"|τ − {theory:.3g}| ≤ {tol:g}", theory, tolerance=tol),
            ),
        ))
        if label == "jamming" and e.cutoff_made:
            cmp = (Comparison("the paper's fit", paper, paper_err), Comparison("theory", theory))
            ref = f"{paper} ± {paper_err} (paper's fit); theory {theory:.5g}"
            rows.append(cutoff_row(
                "τ with an exponential cut-off at jamming (constant volume, the paper's "
                "protocol; S^−τ e^(−S/S_c), KS window)", ref, e, cmp))
            rows.append(shape_row(
                "τ at jamming with the cut-off's shape free (constant volume; "
                + SHAPE_MODEL + ")", ref, e, cmp))
            if e.size_difference is not None:
                rows.append(size_difference_row("at jamming (constant volume)",
                                                e.size_difference))
    return rows


SHAPE_MODEL = ("S^−τ e^(−(S/S_c)^a), profile likelihood over a at the cut-off row's x_min")
"""How the rows of :func:`shape_row` name their model."""


def shape_row(quantity: str, reference_text: str, e: TauEstimate,
              comparisons: tuple[Comparison, ...]) -> Row:
    """The row of ``e``'s profile over the cut-off's shape (the same avalanches and ``x_min`` as
    its cut-off row): τ at the best shape ``a``, with the σ of the 95 % profile interval of τ
    with ``a`` free (its width over 2 × 1.96), so that its verdicts include the spread the
    shape leaves open."""
    p = e.cutoff_shape
    return Row(
        quantity=quantity,
        reference_text=reference_text,
        value=p.tau_best if p is not None else float("nan"),
        error=sigma_from_ci95(p.tau_low, p.tau_high) if p is not None else float("nan"),
        value_text=shape_text(p),
        samples=f"the same {e.n_avalanches} avalanches",
        comparisons=comparisons,
    )


def shape_text(p: Any) -> str:
    """A profile over the cut-off's shape: the best ``a`` and its τ, the 95 % interval of τ
    with ``a`` free, the 95 % set of ``a`` and the likelihood ratio against ``a = 1``."""
    from jamlab.analysis import CHI2_1_95

    if p is None:
        return "n/a"
    lo_end = " (the grid's end)" if p.a_low == p.stretches[0] else ""
    hi_end = " (the grid's end)" if p.a_high == p.stretches[-1] else ""
    verdict = "rejected" if p.lr_exponential > CHI2_1_95 else "not rejected"
    return (f"{p.tau_best:.3f} ± {p.tau_best_stderr:.3f} at a = {p.best:g}; with a free, "
            f"95% interval [{p.tau_low:.3f}, {p.tau_high:.3f}] (a from {p.a_low:g}{lo_end} to "
            f"{p.a_high:g}{hi_end}); exponential cut-off (a = 1): 2Δlog L = "
            f"{p.lr_exponential:.1f}, {verdict} at 5%; x_min = {p.x_min:.3g} ε, tail {p.n_tail}")


def cutoff_row(quantity: str, reference_text: str, e: TauEstimate,
               comparisons: tuple[Comparison, ...]) -> Row:
    """The row of ``e``'s fit with an exponential cut-off (the same avalanches as its τ row)."""
    c = e.cutoff
    return Row(
        quantity=quantity,
        reference_text=reference_text,
        value=c.tau if c is not None else float("nan"),
        error=e.cutoff_sigma,
        value_text="; ".join(t for t in (cutoff_fit_text(c, e.cutoff_sigma),
                                         coarse_text(c, e.cutoff_coarse),
                                         converged_text(e.cutoff_converged)) if t),
        samples=f"the same {e.n_avalanches} avalanches",
        comparisons=comparisons,
    )


def coarse_text(cut: Any, coarse: Any) -> str:
    """The cut-off fit at twice the strain step (steps paired) beside the fit ``cut``, or ``""``
    when either is missing."""
    from jamlab.reproduce.measurements import COARSE_K

    if cut is None or coarse is None:
        return ""
    return (f"at {COARSE_K} δγ (the same minima, steps paired; same x_min): τ = "
            f"{coarse.tau:.3f} (Δ = {coarse.tau - cut.tau:+.3f}), tail {coarse.n_tail}")


def converged_text(w: Any) -> str:
    """The cut-off fit from the lowest floor where the strain step is converged
    (:func:`jamlab.reproduce.measurements.converged_window`), or ``""`` without the check."""
    from jamlab.reproduce.measurements import COARSE_K

    if w is None or not w.tried:
        return ""
    rule = f"|τ at {COARSE_K} δγ − τ| ≤ σ"
    if w.fit is None:
        return (f"no floor with enough sizes has {rule} "
                f"({len(w.tried)} tried from x_min up, a quarter decade apart)")
    f = w.fit
    if w.raised == 0:
        where = "the KS window itself"
    else:
        where = (f"from x_min = {f.x_min:.3g} ε ({w.raised} quarter decade"
                 f"{'s' if w.raised > 1 else ''} above the KS window)")
    band = (f", 95% CI at this floor [{f.ci_low:.3f}, {f.ci_high:.3f}]"
            if math.isfinite(f.ci_low) and math.isfinite(f.ci_high) else "")
    return (f"δγ-converged ({rule}): {where}, τ = {f.tau:.3f} ± {f.tau_stderr:.3f}{band}, "
            f"at {COARSE_K} δγ {w.coarse.tau:.3f}, tail {f.n_tail}")


def pressure_tau_rows(estimates: dict[float, TauEstimate]) -> list[Row]:
    """One row per fixed pressure: τ(p) against τ_J (the p → 0 limit of the theory), the paper's
    constant-volume fit and τ_UNSAT = 1."""
    rows = []
    paper, paper_err = PAPER_TAU["jamming"]
    theory = predicted_tau("jamming")
    for p, e in sorted(estimates.items(), reverse=True):
        rows.append(Row(
            quantity=f"τ at fixed pressure p = {p:g} (S = −ΔH, jamming packings brought to p)",
            reference_text=(f"theory τ_J = {theory:.5g} as p → 0; τ_UNSAT = 1; paper's "
                            f"constant-volume fit {paper} ± {paper_err}"),
            value=e.fit.tau if e.fit is not None else float("nan"),
            error=e.sigma,
            value_text=fit_text(e.fit, e.sigma),
            samples=tau_samples_text(e),
            comparisons=(
                Comparison("theory τ_J (p → 0)", theory),
                Comparison("τ_UNSAT", 1.0),
                Comparison("the paper's fit", paper, paper_err),
            ),
        ))
        ref = (f"theory τ_J = {theory:.5g} as p → 0; τ_UNSAT = 1; paper's "
               f"constant-volume fit {paper} ± {paper_err}")
        cmp = (Comparison("theory τ_J (p → 0)", theory),
               Comparison("τ_UNSAT", 1.0),
               Comparison("the paper's fit", paper, paper_err))
        rows.append(cutoff_row(
            (f"τ at fixed pressure p = {p:g}, power law with an exponential cut-off "
             "(S^−τ e^(−S/S_c), KS window)"), ref, e, cmp))
        rows.append(shape_row(
            f"τ at fixed pressure p = {p:g} with the cut-off's shape free ({SHAPE_MODEL})",
            ref, e, cmp))
        if e.size_difference is not None:
            rows.append(size_difference_row(f"at fixed pressure p = {p:g}", e.size_difference))
    return rows


def cutoff_fit_text(fit: Any, sigma: float) -> str:
    """A fit with an exponential cut-off: ``τ ± σ (95% CI, x_min, S_c, tail)``, or ``n/a``."""
    if fit is None:
        return "n/a"
    s_c = "none resolved" if fit.at_bound else f"{fit.x_c:.3g} ε"
    return (f"{fit.tau:.3f} ± {sigma:.3f} (95% CI [{fit.ci_low:.3f}, {fit.ci_high:.3f}], "
            f"x_min = {fit.x_min:.3g} ε, S_c = {s_c}, tail {fit.n_tail}{interval_note(fit)})")


def pressure_tau_data(estimates: dict[float, TauEstimate]) -> dict[str, Any]:
    """``tau_pressure``: per p (as text) the fit numbers (or None) and the counts."""
    out = {}
    for p, e in estimates.items():
        f = e.fit
        out[f"{p:g}"] = dict(
            tau=None if f is None else f.tau, sigma=e.sigma, n_avalanches=e.n_avalanches,
            steps=e.steps, samples=e.samples, n_steps_excluded=e.n_steps_excluded,
            fit_pressures=e.fit_pressures, cutoff=cutoff_data(e),
            size_difference=size_difference_data(e.size_difference))
    return {"tau_pressure": out} if out else {}


def cutoff_data(e: TauEstimate) -> dict[str, Any] | None:
    """The numbers of ``e``'s fit with an exponential cut-off (None without one)."""
    c, p = e.cutoff, e.cutoff_shape
    shape = None if p is None else dict(
        best_a=p.best, tau=p.tau_best, tau_stderr=p.tau_best_stderr, tau_low=p.tau_low,
        tau_high=p.tau_high, a_low=p.a_low, a_high=p.a_high, a_grid=list(p.stretches),
        lr_exponential=p.lr_exponential)
    k = e.cutoff_coarse
    coarse = None if k is None else dict(tau=k.tau, tau_stderr=k.tau_stderr, n_tail=k.n_tail)
    w = e.cutoff_converged
    conv = None if w is None else dict(
        tried=[dict(x_min=x, tau=t, tau_2dgamma=t2, tau_stderr=se) for x, t, t2, se in w.tried],
        fit=None if w.fit is None else dict(
            x_min=w.fit.x_min, tau=w.fit.tau, tau_stderr=w.fit.tau_stderr,
            ci_low=w.fit.ci_low, ci_high=w.fit.ci_high, n_tail=w.fit.n_tail,
            tau_2dgamma=w.coarse.tau))
    return None if c is None else dict(
        tau=c.tau, sigma=e.cutoff_sigma, ci_low=c.ci_low, ci_high=c.ci_high,
        x_min=c.x_min, s_c=None if c.at_bound else c.x_c, n_tail=c.n_tail, shape=shape,
        coarse_2dgamma=coarse, dgamma_converged=conv)


def tau_data(estimates: dict[str, TauEstimate]) -> dict[str, Any]:
    """``tau_<label>`` (fit numbers or None) for each label, then ``avalanche_counts``."""
    data: dict[str, Any] = {}
    for label, e in estimates.items():
        f = e.fit
        data[f"tau_{label}"] = None if f is None else dict(
            tau=f.tau, sigma=e.sigma, ci_low=f.ci_low, ci_high=f.ci_high, x_min=f.x_min,
            n_tail=f.n_tail, n_avalanches=e.n_avalanches)
        if e.cutoff_made:
            data[f"tau_{label}_cutoff"] = cutoff_data(e)
            data[f"tau_{label}_size_difference"] = size_difference_data(e.size_difference)
    data["avalanche_counts"] = {k: e.n_avalanches for k, e in estimates.items()}
    data["exclusions"] = {
        k: dict(jammed_known=e.jammed_known, n_steps=e.steps,
                n_steps_excluded=e.n_steps_excluded,
                n_avalanches_excluded=e.n_avalanches_excluded,
                fit_pressures=e.fit_pressures, sampled_pressures=e.sampled_pressures)
        for k, e in estimates.items()}
    return data


def phi_j_row(e: PhiJEstimate) -> Row:
    """The φ_J row, against the paper's ≈ 0.64."""
    per_n = "; ".join(f"N={n}: {v:.4f}" for n, v in e.per_n.items())
    return Row(
        quantity="φ_J (3D monodisperse, jamming protocol)",
        reference_text=f"≈ {PAPER_PHI_J} (paper; O'Hern et al. 2003 ≈ {OHERN_PHI_J_3D})",
        value=e.mean, error=e.sem,
        value_text=f"{format_value(e.mean, e.sem)} ({per_n})",
        samples=f"{e.n} packings",
        comparisons=(Comparison(f"{PAPER_PHI_J} ± {PAPER_PHI_J_ERR}", PAPER_PHI_J,
                                PAPER_PHI_J_ERR),),
        note="φ_J rises with N (finite-size shift)",
    )


def phi_j_data(e: PhiJEstimate) -> dict[str, Any]:
    """``phi_j``: mean, standard error, count."""
    return {"phi_j": dict(mean=e.mean, sem=e.sem, n=e.n)}


def coordination_rows(r: CoordinationResult, scale: Scale) -> list[Row]:
    """The two coordination exponents against O'Hern et al."""
    rows = []
    for name, title in (("z_nr - z_iso", "exponent of z_nr − z_iso(N') vs φ − φ_J"),
                        ("p", "exponent of p vs φ − φ_J")):
        e = r.exponents[name]
        rows.append(Row(
            quantity=title,
            reference_text=f"{COORDINATION_EXPONENTS[name]:g} (O'Hern et al. 2003)",
            value=e.exponent, error=e.sigma, value_text=format_value(e.exponent, e.sigma),
            samples=f"{e.packings} packing(s) of N = {scale.coord_n}, fit over Δφ ∈ [1e-4, 0.1]",
            comparisons=(Comparison("O'Hern et al.", COORDINATION_EXPONENTS[name]),),
            note="σ is the spread over packings only; finite-N and fit-window effects "
                 "(systematic) are not in it",
        ))
    return rows


def coordination_data(r: CoordinationResult) -> dict[str, Any]:
    """``coordination``: each exponent's numbers and the first packing's φ_J."""
    data: dict[str, Any] = {k: asdict(v) for k, v in r.exponents.items()}
    data["phi_j_first"] = r.phi_j_first
    return {"coordination": data}


def theory_rows(th: TheoryChecks, scale: Scale) -> list[Row]:
    """τ_J against the paper's digits, the no-jump checks and the one-level case."""
    from jamlab.theory import THETA_JAMMING, tau_jamming

    tau_j = tau_jamming()
    check = th.at(scale.cascade_check_dgamma)
    sampled = f"sampled {format_value(check.sampled, check.sampled_err)}"
    return [
        Row(
            quantity=f"τ_J = (3+θ)/(2+θ), θ = {THETA_JAMMING}",
            reference_text=f"{PAPER_TAU_J} (paper)",
            value=tau_j, error=0.0, value_text=f"{tau_j:.6f}", samples="closed form",
            comparisons=(Comparison(f"|Δ| ≤ {_exp_text(PAPER_TAU_J_DIGITS)} (paper's digits)",
                                    PAPER_TAU_J, tolerance=PAPER_TAU_J_DIGITS),),
        ),
        Row(
            quantity=(f"P(no jump) at δγ = {scale.cascade_check_dgamma:g}, y = 2.5q, "
                      f"q_max = 0.9, k = {th.k}: exact recursion vs cascade sampler"),
            reference_text=f"exact recursion {check.exact:.4f} (computed)",
            value=check.sampled, error=check.sampled_err, value_text=sampled,
            samples=f"{th.n} cascades",
            comparisons=(Comparison("the exact recursion", check.exact),),
        ),
        Row(
            quantity=(f"P(no jump) at δγ = {scale.cascade_check_dgamma:g}: the paper's printed "
                      "formula vs the exact cascade"),
            reference_text=(f"printed formula {check.printed:.4f} "
                            f"(SPEC: {PRINTED_NO_JUMP_SPEC:g})"),
            value=check.sampled, error=check.sampled_err, value_text=sampled,
            samples=f"{th.n} cascades",
            comparisons=(Comparison("the printed formula", check.printed),),
            note="known discrepancy, docs/theory-vs-cascade.md",
        ),
        Row(
            quantity="k = 1 no-jump probability (q_1 = 0, y_1 = 1, δγ = 0.5)",
            reference_text=(f"exact {K1_EXACT_SPEC} (SPEC); paper's χ_1 {K1_PAPER_CHI} "
                            f"(ours: exact {th.k1_exact:.4f}, χ_1 {th.k1_chi:.4f})"),
            value=th.k1_sampled, error=th.k1_sampled_err,
            value_text=f"sampled {format_value(th.k1_sampled, th.k1_sampled_err)}",
            samples=f"{th.n} cascades",
            comparisons=(Comparison("exact (computed)", th.k1_exact),
                         Comparison("the paper's χ_1 (computed)", th.k1_chi)),
        ),
    ]


def exponent_rows(th: TheoryChecks) -> list[Row]:
    """``τ = 2μ`` in the exact jump law (``docs/theory-vs-cascade.md`` §9): the median local
    slope over the window, half its range over the window as the uncertainty."""
    from jamlab.reproduce.theory_checks import EXPONENT_DGAMMA, EXPONENT_WINDOW

    rows = []
    for e in th.exponents:
        half = 0.5 * (e.tau_exact_max - e.tau_exact_min)
        rows.append(Row(
            quantity=(f"τ of the exact jump law, μ = {e.mu:.6g}: −d log P/d log|ΔE| at "
                      f"δγ = {EXPONENT_DGAMMA:g}, |ΔE|/δγ ∈ [{EXPONENT_WINDOW[0]:g}, "
                      f"{EXPONENT_WINDOW[1]:g}] (median; ± half its range over the window)"),
            reference_text=f"2μ = {2 * e.mu:.6f} (theory); printed formula {e.tau_printed:.4f}",
            value=e.tau_exact, error=half,
            value_text=f"{format_value(e.tau_exact, half)} (exact law, computed)",
            samples="continuum exact law, q_max = 1 − 1e-5",
            comparisons=(Comparison("2μ", 2 * e.mu),),
            note="jamlab's exact law (not in the paper); μ = 1/2 has log corrections",
        ))
    return rows


def theory_data(th: TheoryChecks) -> dict[str, Any]:
    """``theory``: every number of the checks."""
    return {"theory": asdict(th)}


def parameters(scale: Scale, runs: Path) -> dict[str, str]:
    """The report's list of parameters of the scale."""
    return {
        "run directories": str(runs),
        "avalanche ensembles": (
            f"jamming: N = {', '.join(map(str, scale.jamming_n))}, {scale.jamming_samples} "
            f"samples each, γ_max = {scale.jamming_gamma_max:g} "
            f"({round(scale.jamming_gamma_max / scale.dgamma)} steps); φ = 0.75, 0.80: "
            f"N = {', '.join(map(str, scale.unsat_n))}, {scale.unsat_samples} samples each, "
            f"γ_max = {scale.gamma_max:g} ({round(scale.gamma_max / scale.dgamma)} steps); "
            f"δγ = {scale.dgamma:g}; the jamming ensemble's floppy steps by "
            f"{'projection' if scale.floppy == 'project' else 'FIRE'}"
            + (f"; every sample saved every {scale.checkpoint_every} steps (an interrupted "
               "sample resumes from its last save)" if scale.checkpoint_every else "")
        ),
        "stress–strain ensemble": (
            f"φ = {scale.stress_phi:g}, N = {scale.stress_n}, {scale.stress_samples} samples, "
            f"δγ = {scale.stress_dgamma:g} to γ = {scale.stress_gamma_max:g}"
        ),
        "coordination": (f"{scale.coord_samples} jammed packing(s) of N = {scale.coord_n}, "
                         f"{scale.coord_steps} compression steps"),
        "fits": (f"min tail {scale.min_tail}, {scale.n_boot} bootstrap resamples, "
                 f"seed {scale.seed}"),
        "cascade": f"k = {scale.cascade_k} levels, {scale.cascade_samples} samples per δγ",
        "space dimension, potential": (
            "d = 3, V(r) = (1 − r)² for r < 1 (σ = 1, ε = 1)"
            if scale.sizes == "mono" and scale.alpha == 2.0
            else f"d = 3, V(r) = (1 − r/σ_ij)^{scale.alpha:g} for r < σ_ij = (D_i + D_j)/2, "
            f"diameters {scale.sizes} (SPEC.md §5) — not the paper's system: its reference "
            f"values are shown for orientation only"
        ),
        "expected cost of this scale": scale.expected,
        "projected cost of every scale": "; ".join(
            f"{name}: {s.expected}" for name, s in SCALES.items()),
        **({"fixed-pressure ensembles": (
            f"p = {', '.join(f'{p:g}' for p in scale.pressures)}: N = "
            f"{', '.join(map(str, scale.pressure_n))}, {scale.pressure_samples} samples each, "
            f"γ_max = {scale.pressure_gamma_max:g} "
            f"({round(scale.pressure_gamma_max / scale.pressure_step)} steps), "
            f"δγ = {scale.pressure_step:g}; "
            "the jamming protocol's packings brought to p (jam_at_pressure route), "
            "enthalpy minimised at every step")} if scale.pressures else {}),
    }


FINITE_SIZE_PN2 = 10.0
"""The upper end of the ``p N²`` crossover out of the finite-size regime of jammed packings
(Goodrich, Liu & Nagel, PRL 109, 095704 (2012): ``p N² ≈ 1–10``; docs/packings.md)."""


def notes(scale: Scale) -> list[str]:
    """The report's notes: the avalanche rule, and how the protocol departs from the paper's."""
    out = [
        "Avalanches are the steps the AQS runner flags as plastic (the pre-step minimum's "
        "branch ends) with ΔE < 0 between two jammed minima (rigid backbone and p above the "
        "resolution floor 10·ftol·N/L³; steps that start or end unjammed are excluded and "
        "counted in each τ row); S = −ΔE is a total energy. The jamming ensemble is the "
        "paper's protocol: constant-volume shear of packings jammed at p_target, which unjam "
        "and re-jam under shear — its τ rows give the pressures actually sampled. Fits: "
        "truncated power law by maximum likelihood, x_max = largest size, x_min by the "
        "Kolmogorov–Smirnov rule (Clauset et al. 2009), pooled over N at each φ.",
    ]
    if scale.floppy == "project":
        out.append(
            "Floppy steps of the jamming ensemble (those that start from an unjammed minimum) "
            "end at the overlap-free configuration nearest to the affine start (projection, "
            "docs/aqs.md) instead of at the end of FIRE's slide; FIRE takes every other step. "
            "Such steps are excluded from every statistic; the projection changes only where "
            "the system goes next (measured against FIRE on 40 samples at N = 250 and 12 at "
            "N = 500: two-sample KS on the sizes p = 1.000, τ within 0.2σ)."
        )
    if scale.pressures:
        pn2 = "; ".join(f"p N² = {p * n * n:.3g} at p = {p:g}, N = {n}"
                        for p in scale.pressures for n in scale.pressure_n)
        small = any(p * n * n < FINITE_SIZE_PN2 for p in scale.pressures for n in scale.pressure_n)
        out.append(
            "The fixed-pressure ensembles shear the jamming protocol's packings brought to p and "
            "minimise the enthalpy H = E + pV at every step (docs/aqs.md): the pressure is held "
            "at every minimum, so their avalanches (S = −ΔH) are at a known distance from "
            "jamming, and none is excluded as unjammed unless its row says so. Jammed packings "
            f"leave their finite-size regime at p N² ≈ 1–{FINITE_SIZE_PN2:g} (Goodrich, Liu & "
            f"Nagel 2012): here {pn2}"
            + (". Where p N² is below that, τ is the small box's; τ(p) at N = 125–2000: "
               "docs/reproduce.md, \"τ(p) at a glance\"." if small else ".")
        )
    if scale.dgamma != 1e-5 or scale.gamma_max != 0.01 or scale.jamming_gamma_max != 0.01:
        out.append(
            f"**Protocol differs from the paper at this scale:** δγ = {scale.dgamma:g}, "
            f"γ_max = {scale.gamma_max:g} above jamming and {scale.jamming_gamma_max:g} at "
            "jamming (paper: 10⁻⁵ and 0.01), smaller N and fewer samples, to collect enough "
            "avalanches in the time budget; exponents are compared all the same."
        )
    return out
