"""The report's criticality sections: typed results of :mod:`jamlab.reproduce.criticality` turned
into :class:`jamlab.report.Row` (two sections of their own) and JSON data.

Reference values: ``SPEC.md`` §6 through :data:`jamlab.analysis.criticality.REFERENCE` (from
:mod:`jamlab.paper`); ``τ_J(θ)`` is :func:`jamlab.theory.tau_jamming`, its one implementation.
Nothing is computed here beyond mapping intervals through that formula.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from jamlab.report import Comparison, Row, format_value
from jamlab.reproduce.criticality import FiniteSizeResult, PackingCriticality
from jamlab.reproduce.measurements import TauEstimate, sigma_from_ci95
from jamlab.reproduce.table import TAU_TITLES, fit_text, pressure_text

__all__ = [
    "CRITICALITY_SECTION",
    "FINITE_SIZE_SECTION",
    "SECTION_TEXT",
    "criticality_data",
    "criticality_rows",
    "finite_size_data",
    "finite_size_rows",
]

_EXPONENT_TITLES = {
    "theta_e": ("θ_e, small-force exponent of the extended contacts", "f/⟨f⟩"),
    "theta_l": ("θ_l, small-force exponent of the localized contacts (bucklers' weakest)",
                "f/⟨f⟩"),
    "gamma": ("γ, gap exponent (backbone pairs)", "h"),
}


def _sigma95(ci: tuple[float, float]) -> float:
    """1σ from a 95 % interval (:func:`~jamlab.reproduce.measurements.sigma_from_ci95`)."""
    return sigma_from_ci95(*ci)


def _sizes_text(r: PackingCriticality) -> str:
    return ", ".join(f"N = {n}: {k}" for n, k in sorted(r.packings.items()))


CRITICALITY_SECTION = "Jamming criticality: θ_e, θ_l, γ and the τ_J they predict"
FINITE_SIZE_SECTION = "Finite-size scaling of avalanches"
SECTION_TEXT = {
    CRITICALITY_SECTION: (
        "The small-force and gap exponents of the jamming ensemble's own initial packings "
        "(SPEC §6; docs/criticality.md), and the τ_J they predict through τ_J = 1 + γ = "
        "(3 + θ_e)/(2 + θ_e) beside the τ fitted from the avalanches of the same samples. "
        "These packings are small (the N are given in each row): the exponents are far from "
        "asymptotic at such N."),
    FINITE_SIZE_SECTION: (
        "Mean size ⟨S⟩ and cut-off S_c = ⟨S²⟩/⟨S⟩ against N (jammed steps only), β of "
        "S_c ~ N^β by a weighted fit with a bootstrap over samples, and the collapse "
        "P(S) S^τ against S/N^β (docs/analysis.md §6). With two sizes β is only a rough "
        "number. Above jamming the rows measure the preparation's transient, not a "
        "steady-state cut-off: the packings are sheared from the quench to γ = 0.01–0.02 (the "
        "paper's protocol), and the avalanches release more energy than the shear does work "
        "(5–15× in a quick run) — mostly the as-quenched packing relaxing; ordered "
        "(crystallised) boxes add to the smaller N's sizes (docs/reproduce.md, \"The quick "
        "report\": why ⟨S⟩ and S_c fall with N at φ = 0.75)."),
}
"""The report's two criticality sections (headings and introductory text)."""


def criticality_rows(r: PackingCriticality, tau: TauEstimate) -> list[Row]:
    """``θ_e``, ``θ_l``, ``γ`` of the jamming ensemble's own packings against ``SPEC.md`` §6, then
    the ``τ_J`` they predict (``1 + γ`` and ``(3 + θ_e)/(2 + θ_e)``) against the τ fitted from
    the avalanches of the same samples and the theory's ``τ_J``."""
    from jamlab.analysis.criticality import REFERENCE
    from jamlab.theory import tau_jamming

    nan = float("nan")
    where = (f"the jamming ensemble's own initial packings (small N — {_sizes_text(r)} "
             f"packings; p median {r.pressures[0]:.2g})" if r.pressures else
             "the jamming ensemble's own initial packings (none finished)")
    c = r.counts
    samples = (f"{c.get('packings', 0)} packings ({_sizes_text(r)}), {c.get('contacts', 0)} "
               f"backbone contacts ({c.get('localized_contacts', 0)} localized), "
               f"{c.get('gaps', 0)} gaps; window rule of docs/criticality.md, cdf fit, "
               "95 % bootstrap over packings; all N pooled")
    rows = []
    for name, (title, var) in _EXPONENT_TITLES.items():
        f = r.fits.get(name)
        per_n = "; ".join(
            f"N = {n}: " + (f"{fs[name].value:.3f} [{fs[name].ci95[0]:.3f}, "
                            f"{fs[name].ci95[1]:.3f}]" if fs.get(name) is not None else "n/a")
            for n, fs in sorted(r.fits_by_n.items()))
        text = ("n/a (" + r.reasons.get(name, "no fit") + ")" if f is None else
                f"{f.value:.3f} (95% CI [{f.ci95[0]:.3f}, {f.ci95[1]:.3f}]) on {var} ∈ "
                f"[{f.window[0]:.2g}, {f.window[1]:.2g}], {f.n_in_window} values in the window")
        rows.append(Row(
            quantity=f"{title}, on {where}",
            reference_text=f"{REFERENCE[name]:.5g} (SPEC §6)",
            value=f.value if f is not None else nan,
            error=_sigma95(f.ci95) if f is not None else nan,
            value_text=text + (f"; per N: {per_n}" if per_n else ""),
            samples=samples,
            comparisons=(Comparison("SPEC §6", REFERENCE[name]),),
            note="small N: the window sits close to the finite-size cut-off; docs/criticality.md "
                 "shows θ_e and γ still moving with N up to N = 4000",
            section=CRITICALITY_SECTION,
        ))
    theory = tau_jamming()
    t_fit = tau.fit
    tau_ref = (f"τ fitted from the avalanches of the same samples: {fit_text(t_fit, tau.sigma)}"
               f"; theory τ_J = {theory:.5g}")
    p_fit = pressure_text(tau.fit_pressures)
    note = (f"the packings are at p ≈ p_target; the fitted avalanches start from minima at p "
            f"{p_fit} (the packings unjam and re-jam under shear)")
    comparisons = (Comparison("τ fitted from these samples' avalanches",
                              t_fit.tau if t_fit is not None else nan, tau.sigma),
                   Comparison("theory τ_J", theory))
    g = r.fits.get("gamma")
    rows.append(Row(
        quantity="τ_J predicted by 1 + γ (γ of the same packings)",
        reference_text=tau_ref,
        value=1.0 + g.value if g is not None else nan,
        error=_sigma95(g.ci95) if g is not None else nan,
        value_text=(f"{1 + g.value:.3f} (95% CI [{1 + g.ci95[0]:.3f}, {1 + g.ci95[1]:.3f}])"
                    if g is not None else "n/a"),
        samples=samples, comparisons=comparisons, note=note, section=CRITICALITY_SECTION,
    ))
    t = r.fits.get("theta_e")
    if t is not None:
        lo, hi = sorted((tau_jamming(t.ci95[1]), tau_jamming(t.ci95[0])))
        value, err = tau_jamming(t.value), _sigma95((lo, hi))
        text = f"{value:.3f} (95% CI [{lo:.3f}, {hi:.3f}], from θ_e's interval)"
    else:
        value, err, text = nan, nan, "n/a"
    rows.append(Row(
        quantity="τ_J predicted by (3 + θ_e)/(2 + θ_e) (θ_e of the same packings)",
        reference_text=tau_ref, value=value, error=err, value_text=text,
        samples=samples, comparisons=comparisons, note=note, section=CRITICALITY_SECTION,
    ))
    return rows


def criticality_data(r: PackingCriticality, tau: TauEstimate) -> dict[str, Any]:
    """``criticality``: the pooled and per-N fits, counts, pressures and CPU seconds."""
    def fit(f: Any) -> Any:
        return None if f is None else f.as_dict()

    return {"criticality": dict(
        packings={str(n): k for n, k in r.packings.items()},
        fits={k: fit(f) for k, f in r.fits.items()},
        by_n={str(n): {k: fit(f) for k, f in fs.items()} for n, fs in r.fits_by_n.items()},
        reasons=r.reasons, counts=r.counts, pressures=r.pressures, seconds=r.seconds,
        tau_fit=None if tau.fit is None else dict(tau=tau.fit.tau, sigma=tau.sigma,
                                                  fit_pressures=tau.fit_pressures),
    )}


def finite_size_rows(r: FiniteSizeResult) -> list[Row]:
    """One row per φ label: ``β`` of ``S_c ~ N^β`` with ``⟨S⟩`` and ``S_c`` per ``N``, against the
    ``β`` that minimises the collapse RMS."""
    rows = []
    for label, title in TAU_TITLES.items():
        sc = r.scaling.get(label)
        co = r.collapse.get(label)
        if sc is None:
            rows.append(Row(
                quantity=f"β of the avalanche cut-off S_c = ⟨S²⟩/⟨S⟩ ~ N^β, {title}",
                reference_text="no value in the paper", value=float("nan"),
                error=float("nan"), value_text=f"n/a ({r.reasons.get(label, 'no data')})",
                samples="", comparisons=(Comparison("β of the best collapse", float("nan")),),
                section=FINITE_SIZE_SECTION))
            continue
        per_n = "; ".join(
            f"N = {n}: {k} samples, {a} avalanches, ⟨S⟩ = {m:.3g} ε, S_c = "
            f"{c:.3g} ± {e:.2g} ε"
            for n, k, a, m, c, e in zip(sc.n, sc.samples, sc.avalanches, sc.mean, sc.cutoff,
                                        sc.cutoff_err, strict=True))
        text = (f"{format_value(sc.beta, sc.beta_err)} (95% CI [{sc.beta_ci95[0]:.2f}, "
                f"{sc.beta_ci95[1]:.2f}]); ⟨S⟩ ~ N^"
                f"({format_value(sc.mean_exponent, sc.mean_exponent_err)})")
        if co is not None:
            text += (f"; collapse P(S) S^τ vs S/N^β at τ = {co.tau:.3f}: RMS {co.quality:.3f} "
                     f"decades (unrescaled {r.quality_unscaled[label]:.3f}); best β on the grid "
                     f"{r.beta_best[label]:.2f}")
        jt = r.joint.get(label)
        if jt is not None:
            text += (f"; joint maximum-likelihood fit on S ≥ {jt.floors[0]:.3g} ε (one τ, "
                     f"exponential cut-off S* ~ N^β): β = {format_value(jt.beta, jt.beta_err)}, "
                     f"τ = {format_value(jt.tau, jt.tau_err)}, "
                     + ("cut-off resolved" if jt.resolved else "no cut-off resolved (β void)")
                     + f" (2 Δlog L = {jt.cutoff_lr:.1f})")
        ok = jt is not None and jt.resolved
        joint_beta, joint_err = (jt.beta, jt.beta_err) if ok else (float("nan"), 0.0)
        two = len(sc.n) == 2
        rows.append(Row(
            quantity=(f"β of the avalanche cut-off S_c = ⟨S²⟩/⟨S⟩ ~ N^β, {title} "
                      f"(N = {', '.join(map(str, sc.n))}; jammed steps only)"),
            reference_text="no value in the paper; cross-check: the β that minimises the "
                           "collapse RMS",
            value=sc.beta, error=sc.beta_err, value_text=text, samples=per_n,
            comparisons=(Comparison("β of the best collapse", r.beta_best[label]),
                         Comparison("β of the joint maximum-likelihood fit", joint_beta,
                                    joint_err)),
            note=("two sizes give β only roughly: a line through two cut-offs, its bootstrap "
                  "interval likely too narrow" if two else
                  "bootstrap over samples, widened by √(χ²/dof) when > 1"),
            section=FINITE_SIZE_SECTION,
        ))
    return rows


def finite_size_data(r: FiniteSizeResult) -> dict[str, Any]:
    """``finite_size``: per label the scaling numbers, collapse quality and best β."""
    def clean(x: float) -> Any:
        return None if x is None or not np.isfinite(x) else float(x)

    return {"finite_size": {
        label: None if sc is None else sc.as_dict() | dict(
            collapse_quality=None if r.collapse.get(label) is None
            else clean(r.collapse[label].quality),
            collapse_tau=None if r.collapse.get(label) is None else r.collapse[label].tau,
            quality_unscaled=clean(r.quality_unscaled[label]),
            beta_best=clean(r.beta_best[label]),
            joint=None if r.joint.get(label) is None else r.joint[label].as_dict())
        for label, sc in r.scaling.items()}}
