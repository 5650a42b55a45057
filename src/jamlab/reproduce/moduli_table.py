"""The report's rows for the moduli moments (paper Fig. 7): the slope of ``log⟨μ_1²⟩`` against
``log δγ``, the same of the within-sample variance of ``μ_1`` (the jumps' part), and ``⟨μ_1⟩`` at
both ends of the lags; with their JSON data. Rendering only, as :mod:`jamlab.reproduce.table`."""

from __future__ import annotations

import math
from typing import Any

from jamlab.report import Comparison, Row, format_value
from jamlab.reproduce.measurements import MODULI_LABELS, ModuliResult
from jamlab.reproduce.scales import Scale
from jamlab.reproduce.table import TARGETS

__all__ = ["moduli_data", "moduli_rows", "pressure_moduli_data", "pressure_moduli_rows"]

_MODULI_TITLES = {"jamming": "at jamming (constant volume, the paper's protocol)",
                  "0.75": "at φ = 0.75"}


def _moduli_exclusion(m: Any) -> str:
    """How many stress differences the jammed flags left out (at the smallest and largest lag)."""
    if m is None or m.n_excluded is None:
        return "no jammed flags in these runs: no difference excluded"
    total = m.n_samples * m.n_differences
    return (f"differences across an unjammed minimum excluded: {m.n_excluded[0]} of {total[0]} "
            f"at the smallest δγ, {m.n_excluded[-1]} of {total[-1]} at the largest")


_SLOPE_REFERENCE = "−1 (theory; paper Fig. 7: ⟨μ_1²⟩ ∝ δγ⁻¹)"
_SLOPE_COMPARISONS = (Comparison("theory", -1.0),
                      Comparison("|slope + 1| ≤ 0.2", -1.0, tolerance=TARGETS["slope"]))


def _fit_text(n: int, fit_max: float, fit: Any) -> str:
    """`` (N = …, δγ ≤ …, χ²/dof = …)``: where a slope was fitted, and how well."""
    return f" (N = {n}, δγ ≤ {fit_max:g}, χ²/dof = {fit.chi2:.2g}/{fit.dof})"


def moduli_rows(r: ModuliResult, scale: Scale) -> list[Row]:
    """Slope of ``log⟨μ_1²⟩`` per label (theory −1), the same of the within-sample variance of
    ``μ_1``, then ``⟨μ_1⟩`` at both ends of the lags."""
    rows = []
    for label in MODULI_LABELS:
        title = _MODULI_TITLES[label]
        sf = r.slopes[label]
        val, err = (sf[1].slope, sf[1].slope_err) if sf else (float("nan"), float("nan"))
        n_big = sf[0] if sf else (max(r.moments[label]) if r.moments[label] else 0)
        m = r.moments[label].get(n_big)
        rows.append(Row(
            quantity=f"slope of log⟨μ_1²⟩ vs log δγ, {title}",
            reference_text=_SLOPE_REFERENCE,
            value=val, error=err,
            value_text=(format_value(val, err) + (
                _fit_text(n_big, scale.moduli_fit_max_lag * scale.dgamma, sf[1]) if sf else "")),
            samples=f"{m.n_samples if m else 0} samples",
            comparisons=_SLOPE_COMPARISONS,
            note="error indicative: the lags of one trace are correlated; " + _moduli_exclusion(m),
        ))
    for label in MODULI_LABELS:
        sf = r.var_slopes[label]
        if sf is None:
            continue
        n_big, fit = sf[0], sf[1]
        m = r.moments[label][n_big]
        rows.append(Row(
            quantity=(f"slope of the within-sample variance of μ_1 vs log δγ, "
                      f"{_MODULI_TITLES[label]}"),
            reference_text="−1 (the jumps' part of ⟨μ_1²⟩; not in the paper)",
            value=fit.slope, error=fit.slope_err,
            value_text=format_value(fit.slope, fit.slope_err) + _fit_text(n_big, sf[2], fit),
            samples=f"{m.n_samples} samples",
            comparisons=(Comparison("theory", -1.0),),
            note=("each sample's own mean of ΔΣ/δγ removed, so neither ⟨μ_1⟩² nor the spread of "
                  "the modulus between samples (flat in δγ) enters; unbiased for independent "
                  "increments (docs/analysis.md §4); error indicative as above"),
        ))
    for label in MODULI_LABELS:
        if not r.moments[label]:
            continue
        n_big = max(r.moments[label])
        m = r.moments[label][n_big]
        first = format_value(float(m.mu1[0]), float(m.mu1_err[0]))
        last = format_value(float(m.mu1[-1]), float(m.mu1_err[-1]))
        rows.append(Row(
            quantity=f"⟨μ_1⟩ at the smallest and largest δγ, {_MODULI_TITLES[label]} (ε/σ³)",
            reference_text="finite as δγ → 0 (paper Fig. 7a,c)",
            value=float(m.mu1[0]), error=float(m.mu1_err[0]),
            value_text=(f"{first} at δγ = {m.strain_step[0]:g}; {last}"
                        f" at δγ = {m.strain_step[-1]:g} (N = {n_big})"),
            samples=f"{m.n_samples} samples",
            comparisons=(Comparison(f"⟨μ_1⟩ at δγ = {m.strain_step[-1]:g}", float(m.mu1[-1]),
                                    float(m.mu1_err[-1])),),
            note="finite and δγ-independent if it agrees with its value at the largest δγ",
        ))
    return rows


def moduli_data(r: ModuliResult) -> dict[str, Any]:
    """``slope_<label>``, ``var_slope_<label>``: the slope fits' numbers of ``⟨μ_1²⟩`` and of
    the within-sample variance (None without a fit)."""
    data: dict[str, Any] = {}
    for label in MODULI_LABELS:
        for key, fits in (("slope", r.slopes), ("var_slope", r.var_slopes)):
            sf = fits[label]
            data[f"{key}_{label}"] = None if not sf else dict(
                n=sf[0], slope=sf[1].slope, slope_err=sf[1].slope_err, chi2=sf[1].chi2,
                dof=sf[1].dof)
    return data


def _parts_text(parts: dict[str, float] | None) -> str:
    """ρ's parts as the row says them: the pairs next to an event and the pairs of unflagged
    steps (docs/reproduce.md, "What makes ρ")."""
    if parts is None:
        return ""
    near = parts["before"] + parts["after"]
    return (f", of which {near:+.3f} from the pairs next to an event, {parts['smooth']:+.3f} from "
            f"the pairs of unflagged steps and {parts['events']:+.3f} from pairs of events")


def pressure_moduli_rows(r: dict[float, Any]) -> list[Row]:
    """One row per fixed pressure (:func:`jamlab.reproduce.pressure_moduli.pressure_moduli`): the
    slope of ``log⟨μ_1²⟩`` against −1, with the local slope and the increment correlation that
    say whether it is an exponent."""
    rows = []
    for p, e in sorted(r.items(), reverse=True):
        fit, m = e.slope, e.moments
        val, err = (fit.slope, fit.slope_err) if fit else (float("nan"), float("nan"))
        ratio = float(m.mu1_var[0] / m.mu1_sq[0]) if m.mu1_sq[0] > 0 else float("nan")
        rows.append(Row(
            quantity=f"slope of log⟨μ_1²⟩ vs log δγ at fixed pressure p = {p:g}",
            reference_text=_SLOPE_REFERENCE,
            value=val, error=err,
            value_text=(format_value(val, err) + (
                _fit_text(e.n, e.fit_max, fit)
                + f"; local slope at the two smallest δγ {e.local_slope:+.3f}, lag-1 increment "
                f"correlation ρ = {e.correlation:+.3f} (−1 + log₂(1 + ρ) = "
                f"{math.log2(1 + e.correlation) - 1:+.3f}){_parts_text(e.correlation_parts)}; "
                f"mu1_var/⟨μ_1²⟩ = {ratio:.3f}"
                if fit else " (no fit: fewer than two positive moments)")),
            samples=f"{m.n_samples} samples",
            comparisons=_SLOPE_COMPARISONS,
            note=("every packing at one p, so no spread of moduli between samples; with ρ ≠ 0 "
                  "the slope is the steps' correlation, not an exponent: the pairs next to an "
                  "event anticorrelate more as the step holds more events, a branch's persisting "
                  "modulus correlates the unflagged steps (docs/reproduce.md, \"The moduli "
                  "moments at fixed pressure\", \"What makes ρ\"); error indicative: the lags "
                  "of one trace are correlated; " + _moduli_exclusion(m)),
        ))
    return rows


def pressure_moduli_data(r: dict[float, Any]) -> dict[str, Any]:
    """Per pressure (key ``repr(p)``): N, the slope fits of ``⟨μ_1²⟩`` and ``mu1_var`` (None
    without one), the local slope, the increment correlation and its parts."""
    def fit(f: Any) -> dict[str, float] | None:
        return None if f is None else dict(slope=f.slope, slope_err=f.slope_err, chi2=f.chi2,
                                           dof=f.dof)

    return {repr(p): dict(n=e.n, slope=fit(e.slope), var_slope=fit(e.var_slope),
                          fit_max=e.fit_max, local_slope=e.local_slope,
                          correlation=e.correlation, correlation_parts=e.correlation_parts)
            for p, e in r.items()}
