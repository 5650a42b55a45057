"""The moduli moments of the fixed-pressure ensembles (issue 18): ``⟨μ_1²⟩`` against ``δγ`` at
each pressure of a scale, where every packing sits at one ``p`` (at constant volume the packings
re-jam to pressures decades apart, and their spread of moduli flattens ``⟨μ_1²⟩``).

Per pressure, at the largest N with two finished samples or more: the moments of the intensive
stress (:func:`jamlab.analysis.moduli_from_trace` at the scale's ``moduli_lags``, differences
between jammed minima only), the slopes of ``log⟨μ_1²⟩`` and of ``log mu1_var`` over the lags
``≤ pressure_moduli_fit_max_lag`` (:func:`jamlab.analysis.fit_log_slope`), the local slope
between the two smallest lags and the lag-1 correlation ``ρ`` of the stress increments
(:func:`jamlab.analysis.increment_correlation`): the local slope is ``−1 + log₂(1 + ρ)``, so a
slope away from −1 with ``ρ ≠ 0`` is a property of the step, not an exponent
(``docs/reproduce.md``, "The moduli moments at fixed pressure").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from jamlab.reproduce.ensembles import finished, intensive_stress, jammed_flags, plastic_flags
from jamlab.reproduce.scales import Scale, pressure_run_name

__all__ = ["PressureModuli", "moduli_at_pressure", "pressure_moduli"]


@dataclass(frozen=True)
class PressureModuli:
    """The moduli moments at one pressure: ``n`` (the largest N with samples), ``moments``
    (:class:`jamlab.analysis.ModulusMoments`), the slope fits of ``⟨μ_1²⟩`` and ``mu1_var``
    (``None`` without two positive points), the largest ``δγ`` fitted, the local slope between
    the two smallest lags, the lag-1 increment correlation, and its parts by the pairs of
    consecutive steps (:func:`jamlab.analysis.increment_correlation_parts`; ``None`` without the
    plastic flags)."""

    n: int
    moments: Any
    slope: Any
    var_slope: Any
    fit_max: float
    local_slope: float
    correlation: float
    correlation_parts: dict[str, float] | None = None


def pressure_moduli(runs: Any, scale: Scale) -> dict[float, PressureModuli]:
    """The rule of the module docstring at every pressure of ``scale`` (run directories
    ``pressure-<p>`` of ``runs``, a :class:`jamlab.reproduce.ensembles.RunSet`); empty for a
    scale without fixed-pressure ensembles, and a pressure without two finished samples at any
    N is left out."""
    out = {}
    for p in scale.pressures:
        ds = runs[pressure_run_name(p)]
        sizes = [n for n in scale.pressure_n if np.count_nonzero(finished(ds, "jamming", n)) >= 2]
        if sizes:
            n = max(sizes)
            out[p] = moduli_at_pressure(
                intensive_stress(ds, "jamming", n), jammed_flags(ds, "jamming", n), n,
                scale.pressure_step, scale.moduli_lags,
                scale.pressure_moduli_fit_max_lag * scale.pressure_step,
                plastic=plastic_flags(ds, "jamming", n))
    return out


def moduli_at_pressure(stress: np.ndarray, jammed: np.ndarray | None, n: int, dgamma: float,
                       lags: tuple[int, ...], fit_max: float,
                       plastic: np.ndarray | None = None) -> PressureModuli:
    """The rule of the module docstring on the intensive stress ``(samples, rows)`` of ``n``
    particles with its ``jammed`` flags (``None``: all jammed), the fine step ``dgamma``, the
    ``lags`` and the largest ``δγ`` fitted (``scripts/pressure_moduli.py`` uses it too); with
    the per-row ``plastic`` flags also the parts of the increment correlation."""
    from jamlab.analysis import (
        fit_log_slope,
        increment_correlation,
        increment_correlation_parts,
        moduli_from_trace,
    )

    m = moduli_from_trace(stress, dgamma, lags, jammed=jammed)
    sel = m.strain_step <= fit_max * (1 + 1e-9)
    fits = []
    for y, err in ((m.mu1_sq, m.mu1_sq_err), (m.mu1_var, m.mu1_var_err)):
        good = sel & np.isfinite(y) & (y > 0) & np.isfinite(err) & (err > 0)
        fits.append(fit_log_slope(m.strain_step[good], y[good], err[good])
                    if good.sum() >= 2 else None)
    local = (math.log(m.mu1_sq[1] / m.mu1_sq[0]) / math.log(m.strain_step[1] / m.strain_step[0])
             if m.strain_step.size >= 2 and m.mu1_sq[0] > 0 and m.mu1_sq[1] > 0 else math.nan)
    parts = (None if plastic is None
             else increment_correlation_parts(stress, plastic, jammed))
    return PressureModuli(n, m, fits[0], fits[1], fit_max, local,
                          increment_correlation(stress, jammed), parts)
