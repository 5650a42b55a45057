"""Jamming criticality of the report's own ensembles, as typed results (no rendering here).

Rules (``docs/reproduce.md``, ``docs/criticality.md``):

- **Packing exponents** ``θ_e``, ``θ_l``, ``γ``: on the *initial* configurations of the finished
  samples of the ``jamming`` run (the ``packing/positions`` of each sample file: the packing
  ``jam`` made at ``p_target``, before any shear; the pair law of the study, diameters from the
  file when stored; gaps up to :data:`GAP_H_MAX`), by
  :func:`jamlab.analysis.criticality.packing_observables` and
  :func:`~jamlab.analysis.criticality.measure_exponents` (the documented window rule, the
  ``cdf`` fit, bootstrap over packings with ``scale.n_boot`` resamples, seed ``scale.seed``),
  pooled over all ``N`` of the ensemble and per ``N``. A fit that cannot be made (too few
  samples to place the window, fewer than :data:`MIN_IN_WINDOW` values in it: small ``N``, few
  packings) is ``None`` with the reason.
- **Finite-size scaling** at each φ label: the avalanches of :func:`ensembles.avalanche_set`
  (plastic steps between jammed minima, ``S = −ΔE``) per sample and ``N``;
  :func:`jamlab.analysis.finite_size.fit_cutoff_scaling` (``S_c = ⟨S²⟩/⟨S⟩``, ``β`` of
  ``S_c ~ N^β`` with a bootstrap over samples) and the collapse ``P(S) S^τ`` against ``S/N^β``
  at that ``β`` and the ``τ`` fitted in the report (:func:`measurements.tau_estimates`), with its
  quality, the quality without rescaling (``β = 0``) and the ``β`` that minimises it on a grid;
  and the joint maximum-likelihood fit of one ``τ``, ``β`` and an exponential cut-off over all
  ``N`` (:func:`jamlab.analysis.finite_size.fit_joint_scaling`) on the sizes at or above that τ
  fit's ``x_min`` (one floor for all ``N``; the same bootstrap), with whether a cut-off is
  resolved at all.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from jamlab.reproduce.ensembles import avalanche_set, finished
from jamlab.reproduce.measurements import TAU_LABELS, TauEstimate, pressure_summary
from jamlab.reproduce.scales import UNSAT_PHI, Scale

__all__ = [
    "COLLAPSE_BETAS",
    "GAP_H_MAX",
    "MIN_IN_WINDOW",
    "FiniteSizeResult",
    "PackingCriticality",
    "finite_size_scaling",
    "packing_criticality",
]

EXPONENTS = ("theta_e", "theta_l", "gamma")

MIN_IN_WINDOW = 50
"""A packing exponent is reported only with at least this many values in its window (fewer, as at
the ``tiny`` scale, give a fit that sits on the fitter's bounds)."""

GAP_H_MAX = 0.25
"""Gaps are collected up to ``h = 0.25`` (not the command's 0.5): every fit window ends at
``h = 1e-2``, and the smallest boxes of the ``tiny`` scale (``L ≈ 3``) hold no pair list beyond
``max(D)(1 + h_max) < L/2``."""

COLLAPSE_BETAS = np.round(np.arange(0.0, 3.0001, 0.05), 10)
"""The grid of ``β`` on which the collapse quality is scanned (the cross-check of ``β``)."""


@dataclass(frozen=True)
class PackingCriticality:
    """``θ_e``, ``θ_l``, ``γ`` of the jamming ensemble's initial packings: ``fits`` pooled over all
    ``N`` and ``fits_by_n`` (an :class:`~jamlab.analysis.criticality.ExponentFit` or None),
    ``reasons`` why a fit is missing, ``packings`` per ``N``, the contact counts (pooled),
    ``pressures`` (median, 10 %, 90 %) of those packings, ``seconds`` of CPU time spent, and the
    per-``N`` observables (``observables``, for the figure)."""

    packings: dict[int, int]
    fits: dict[str, Any]
    fits_by_n: dict[int, dict[str, Any]]
    reasons: dict[str, str]
    counts: dict[str, int]
    pressures: tuple[float, float, float] | None
    seconds: float
    observables: dict[int, list[Any]] = field(default_factory=dict, repr=False)

    @property
    def sizes(self) -> tuple[int, ...]:
        """The ``N`` with at least one packing."""
        return tuple(n for n, k in sorted(self.packings.items()) if k)


def _fit_each(observables: list[Any], scale: Scale) -> tuple[dict[str, Any], dict[str, str]]:
    """Each exponent on its own (one that cannot be fitted does not stop the others)."""
    from jamlab.analysis.criticality import measure_exponents

    fits: dict[str, Any] = {}
    reasons: dict[str, str] = {}
    for name in EXPONENTS:
        if len(observables) < 2:
            fits[name], reasons[name] = None, f"{len(observables)} packing(s): no interval"
            continue
        try:
            fit = measure_exponents(observables, n_boot=scale.n_boot, seed=scale.seed,
                                    names=(name,))[name]
        except ValueError as exc:
            fits[name], reasons[name] = None, str(exc)
            continue
        window = fit.window
        if fit.n_in_window < MIN_IN_WINDOW:
            fits[name], reasons[name] = None, (
                f"{fit.n_in_window} values in the window [{window[0]:.2g}, {window[1]:.2g}], "
                f"fewer than {MIN_IN_WINDOW}")
            continue
        fits[name] = fit
    return fits, reasons


def packing_criticality(jamming: Any, run_path: Any, scale: Scale) -> PackingCriticality:
    """The packing exponents of the module rule, from the ``jamming`` run dataset (for the
    finished samples and their pressures) and its directory ``run_path`` (the sample files)."""
    from pathlib import Path

    import h5py

    from jamlab.analysis.criticality import counts, packing_observables
    from jamlab.runs import RunDir, SampleKey

    t0 = time.process_time()
    study = json.loads(jamming.attrs["study"])
    alpha = float(study.get("alpha", 2.0))
    run = RunDir(Path(run_path))
    groups: dict[int, list[Any]] = {}
    pressures = []
    for n in scale.jamming_n:
        groups[n] = []
        done = np.flatnonzero(finished(jamming, "jamming", n))
        p0 = np.asarray(jamming.pressure.sel(phi="jamming", N=n).values)[:, 0]
        length = np.asarray(jamming.box_length.sel(phi="jamming", N=n).values)
        for i in done:
            with h5py.File(run.sample_path(SampleKey("jamming", int(n), int(i))), "r") as h5:
                pos = h5["packing"]["positions"][()]
                dia = h5["packing"]["diameters"][()] if "diameters" in h5["packing"] else None
            groups[n].append(packing_observables(pos, float(length[i]), 0.0, dia, alpha,
                                                 h_max=GAP_H_MAX))
            pressures.append(float(p0[i]))
    everything = [o for n in scale.jamming_n for o in groups[n]]
    fits, reasons = _fit_each(everything, scale)
    by_n = {n: _fit_each(g, scale)[0] for n, g in groups.items() if g}
    return PackingCriticality(
        packings={n: len(g) for n, g in groups.items()},
        fits=fits,
        fits_by_n=by_n,
        reasons=reasons,
        counts=counts(everything) if everything else {},
        pressures=pressure_summary(np.array(pressures)),
        seconds=time.process_time() - t0,
        observables={n: g for n, g in groups.items() if g},
    )


@dataclass(frozen=True)
class FiniteSizeResult:
    """Per φ label: the :class:`~jamlab.analysis.finite_size.CutoffScaling` (or None), the
    :class:`~jamlab.analysis.finite_size.Collapse` at the fitted ``β`` and τ (or None), the
    collapse quality without rescaling, the ``β`` minimising the quality on
    :data:`COLLAPSE_BETAS`, why a part is missing, and the
    :class:`~jamlab.analysis.finite_size.JointScaling` (or None)."""

    scaling: dict[str, Any]
    collapse: dict[str, Any]
    quality_unscaled: dict[str, float]
    beta_best: dict[str, float]
    reasons: dict[str, str]
    joint: dict[str, Any] = field(default_factory=dict)


def finite_size_scaling(
    jamming: Any, unsat: Any, taus: dict[str, TauEstimate], scale: Scale
) -> FiniteSizeResult:
    """The finite-size rule of the module docstring at each of :data:`TAU_LABELS`."""
    from jamlab.analysis.finite_size import (
        collapse,
        collapse_quality,
        fit_cutoff_scaling,
        fit_joint_scaling,
    )

    sources = {"jamming": (jamming, scale.jamming_n)} | {
        repr(p): (unsat, scale.unsat_n) for p in UNSAT_PHI}
    scaling: dict[str, Any] = {}
    coll: dict[str, Any] = {}
    unscaled: dict[str, float] = {}
    best: dict[str, float] = {}
    reasons: dict[str, str] = {}
    joint: dict[str, Any] = {}
    for label in TAU_LABELS:
        ds, ns = sources[label]
        per_n = {n: list(avalanche_set(ds, label, n).per_sample) for n in ns}
        scaling[label] = coll[label] = joint[label] = None
        unscaled[label] = best[label] = math.nan
        try:
            scaling[label] = fit_cutoff_scaling(per_n, n_boot=max(scale.n_boot, 2),
                                                seed=scale.seed)
        except ValueError as exc:
            reasons[label] = str(exc)
            continue
        fit = taus[label].fit if label in taus else None
        if fit is None or not math.isfinite(scaling[label].beta):
            reasons[label] = "no τ fit at this φ: no collapse"
            continue
        pooled = {n: np.concatenate(s) if s else np.empty(0) for n, s in per_n.items()}
        coll[label] = collapse(pooled, fit.tau, scaling[label].beta, scale.bins_per_decade)
        unscaled[label] = collapse(pooled, fit.tau, 0.0, scale.bins_per_decade).quality
        q = collapse_quality(pooled, fit.tau, COLLAPSE_BETAS, scale.bins_per_decade)
        if np.isfinite(q).any():
            best[label] = float(COLLAPSE_BETAS[int(np.nanargmin(q))])
        try:
            joint[label] = fit_joint_scaling(per_n, float(fit.x_min),
                                             n_boot=max(scale.n_boot, 2), seed=scale.seed)
        except ValueError as exc:
            reasons[label] = f"joint fit: {exc}"
    return FiniteSizeResult(scaling, coll, unscaled, best, reasons, joint)
