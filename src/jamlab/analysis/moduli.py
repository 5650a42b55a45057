"""Moments of the shear modulus from finite stress differences (paper eqs. for ⟨μ_1⟩, ⟨μ_1²⟩).

SPEC §3 and Franz & Spigler (2017), section "Consequences on the elastic moduli":

    ⟨μ_1⟩ = ⟨ΔΣ⟩/δγ,    ⟨μ_1²⟩ = ⟨ΔΣ²⟩/δγ²,    ΔΣ = Σ(γ + δγ) − Σ(γ),

at finite ``δγ`` (the paper plots them before the limit ``δγ → 0``); ``⟨μ_1²⟩ ~ δγ^(−1)`` at and
above jamming. ``Σ`` is whatever stress the caller passes (extensive ``Σ`` or intensive
``σ_xy = Σ/L^d``); the moments carry its units (per unit strain, squared for ``μ_1²``).

Averages: first over the differences of one sample (stationarity in ``γ``, as the paper
assumes), then over samples; the standard error is the sample-to-sample one,
``std(per-sample means, ddof=1)/√n_samples``, which stays honest when the differences within a
sample are correlated (overlapping differences, or a sample's own modulus).

``⟨μ_1²⟩`` holds ``⟨μ_1⟩²``, the sample-to-sample spread of the modulus (δγ-independent) and the
part the jumps make (``∝ δγ⁻¹``). :attr:`ModulusMoments.mu1_var` is the last one alone: the
variance of ``ΔΣ/δγ`` about each sample's own mean, averaged over samples, with the overlap
correction that makes it unbiased for independent stationary increments (``docs/analysis.md``
§4). Where the spread between samples is large (small N near jamming) ``⟨μ_1²⟩`` is flat in
``δγ`` while ``mu1_var`` still falls as ``δγ⁻¹``.

Where consecutive increments are correlated (lag-1 correlation ``ρ``,
:func:`increment_correlation`), ``⟨(ΔΣ_1 + ΔΣ_2)²⟩ = 2⟨ΔΣ²⟩(1 + ρ)`` and the local slope of
``⟨μ_1²⟩`` between the lags 1 and 2 is ``−1 + log₂(1 + ρ)``, up to the squared mean increment:
the ``δγ⁻¹`` law needs steps whose increments are independent (``docs/reproduce.md``, "The
moduli moments at fixed pressure").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab.analysis.powerlaw import finite_data

__all__ = [
    "ModulusMoments",
    "SlopeFit",
    "fit_log_slope",
    "CORRELATION_PARTS",
    "event_neighbours",
    "increment_correlation",
    "increment_correlation_parts",
    "moduli_from_stress_jumps",
    "moduli_from_trace",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ModulusMoments:
    """``⟨μ_1⟩`` and ``⟨μ_1²⟩`` with sample-to-sample standard errors, one entry per ``δγ``.

    ``strain_step`` (δγ), ``mu1``, ``mu1_err``, ``mu1_sq``, ``mu1_sq_err`` are arrays of equal
    length; ``n_samples`` is the number of samples, ``n_differences`` the number of differences
    per sample at each ``δγ``; ``overlapping`` says how the differences were taken.
    """

    strain_step: FloatArray
    mu1: FloatArray
    mu1_err: FloatArray
    mu1_sq: FloatArray
    mu1_sq_err: FloatArray
    n_samples: int
    n_differences: NDArray[np.int64]
    overlapping: bool
    n_excluded: NDArray[np.int64] | None = None
    """Differences left out at each ``δγ`` because they span an unjammed minimum, of the
    ``n_samples × n_differences`` there (``None``: no ``jammed`` flags were given)."""
    mu1_var: FloatArray | None = None
    """The within-sample variance of ``ΔΣ/δγ`` (each sample's own mean removed, the overlap
    correction of the module docstring), averaged over the samples with two or more
    differences; NaN where none has."""
    mu1_var_err: FloatArray | None = None


def _mean_and_error(per_sample: FloatArray) -> tuple[float, float]:
    n = per_sample.size
    mean = float(per_sample.mean())
    err = float(per_sample.std(ddof=1) / np.sqrt(n)) if n > 1 else float("nan")
    return mean, err


def _moments_of_jumps(
    jumps: FloatArray,
    dgamma: float,
    keep: NDArray[np.bool_] | None = None,
    dof: FloatArray | None = None,
) -> tuple[float, float, float, float, float, float]:
    """``(⟨μ_1⟩, σ, ⟨μ_1²⟩, σ, within-sample variance, σ)`` from ``jumps`` of shape (samples,
    differences) at one strain step; with ``keep`` (same shape) only the kept differences, and
    only samples that keep at least one. ``dof`` (per sample): the effective number of
    independent differences less one, the divisor of the sum of squares about the sample's mean
    (default: the count less one, as for independent differences); samples with ``dof ≤ 0`` are
    left out of the variance."""
    if keep is None:
        keep = np.ones(jumps.shape, dtype=bool)
    count = keep.sum(axis=1)
    if dof is None:
        dof = count - 1.0
    used = count > 0
    if not used.any():
        return (float("nan"),) * 6
    kept = np.where(keep, jumps, 0.0)
    mean = kept.sum(axis=1) / np.maximum(count, 1)  # per sample (0 where none is kept)
    m1 = mean[used] / dgamma
    m2 = (kept[used] ** 2).sum(axis=1) / count[used] / dgamma**2
    var_ok = used & (dof > 0)
    if var_ok.any():
        centred = np.where(keep, jumps - mean[:, None], 0.0)
        var = (centred[var_ok] ** 2).sum(axis=1) / dof[var_ok] / dgamma**2
        v = _mean_and_error(var)
    else:
        v = (float("nan"), float("nan"))
    return (*_mean_and_error(m1), *_mean_and_error(m2), *v)


def _overlap_dof(keep: NDArray[np.bool_], starts: NDArray[np.int64], m: int, steps: int
                 ) -> FloatArray:
    """Per sample, ``|K| − Σ_k w_k² / (m |K|)``: the divisor that makes the sum of squares of
    the kept differences ``D_n = Σ_{k=n}^{n+m−1} ξ_k`` (``n`` in ``starts[keep]``, ``K`` the kept
    set) about their mean an unbiased estimate of ``Var D`` for independent increments ``ξ_k`` of
    one variance: ``E[SS] = σ² (|K| m − Σ_k w_k²/|K|)``, ``w_k`` the number of kept differences
    that contain the fine step ``k``. Non-overlapping differences give ``|K| − 1``."""
    out = np.zeros(keep.shape[0])
    for i, row in enumerate(keep):
        k = int(row.sum())
        if k < 2:
            continue
        cover = np.zeros(steps + 1)
        np.add.at(cover, starts[row], 1.0)
        np.subtract.at(cover, starts[row] + m, 1.0)
        w = np.cumsum(cover)[:steps]
        out[i] = k - float(w @ w) / (m * k)
    return out


def moduli_from_trace(
    shear_stress: ArrayLike,
    strain_step: float,
    lags: ArrayLike,
    *,
    overlapping: bool = True,
    jammed: ArrayLike | None = None,
) -> ModulusMoments:
    """Moments at ``δγ = m·δγ_0`` from fine traces ``Σ(γ_0 + n δγ_0)`` by subsampling.

    ``shear_stress``: array ``(samples, steps+1)`` (a 1-D array is one sample) on a uniform grid
    of step ``strain_step = δγ_0``. For each lag ``m`` in ``lags`` the differences are
    ``ΔΣ = Σ_{n+m} − Σ_n`` for ``n = 0, 1, 2, …`` (``overlapping=True``: all of them, smaller
    variance, correlated) or ``n = 0, m, 2m, …`` (``overlapping=False``: independent increments
    of one path). Each sample's mean of ``ΔΣ/δγ`` and ``ΔΣ²/δγ²`` is averaged over samples
    (module docstring for the error).

    ``jammed`` (optional, the traces' per-minimum flags, same shape as ``shear_stress``): a
    difference ``Σ_{n+m} − Σ_n`` is used only if every minimum ``n … n+m`` is jammed — a
    difference across a floppy state is not an elastic response (``docs/analysis.md``); a sample
    with no such difference at a lag is left out of that lag's average.
    """
    stress = np.atleast_2d(np.asarray(shear_stress, dtype=np.float64))
    if stress.ndim != 2:
        raise ValueError(f"shear_stress must be 1-D or (samples, steps+1), got {stress.shape}")
    unjammed_before = None
    if jammed is not None:
        flags = np.atleast_2d(np.asarray(jammed))
        if flags.shape != stress.shape:
            raise ValueError(f"jammed has shape {flags.shape}, shear_stress {stress.shape}")
        # unjammed_before[:, k]: unjammed minima among 0 … k−1
        unjammed_before = np.zeros((stress.shape[0], stress.shape[1] + 1), dtype=np.int64)
        np.cumsum(~flags.astype(bool), axis=1, out=unjammed_before[:, 1:])
    if not (strain_step > 0 and math.isfinite(strain_step)):
        raise ValueError(f"strain_step={strain_step!r} must be finite and > 0")
    lags = np.atleast_1d(np.asarray(lags))
    n_points = stress.shape[1]
    if (lags.size == 0 or not np.all(np.isfinite(lags)) or np.any(lags != np.round(lags))
            or np.any(lags < 1) or np.any(lags >= n_points)):
        raise ValueError(f"lags must be integers in [1, {n_points - 1}], got {lags}")
    out = []
    counts = []
    excluded = []
    for m in lags.astype(int):
        jumps = stress[:, m:] - stress[:, :-m]
        keep = None
        if unjammed_before is not None:
            # no unjammed minimum among n … n+m
            keep = (unjammed_before[:, m + 1:] - unjammed_before[:, : n_points - m]) == 0
        starts = np.arange(n_points - m)
        if not overlapping:
            jumps = jumps[:, ::m]
            keep = None if keep is None else keep[:, ::m]
            starts = starts[::m]
        full = np.ones(jumps.shape, dtype=bool) if keep is None else keep
        dof = _overlap_dof(full, starts, m, n_points - 1)
        out.append(_moments_of_jumps(jumps, m * strain_step, keep, dof))
        counts.append(jumps.shape[1])
        excluded.append(0 if keep is None else int(keep.size - keep.sum()))
    arr = np.array(out)
    return ModulusMoments(
        strain_step=lags.astype(np.float64) * strain_step,
        mu1=arr[:, 0],
        mu1_err=arr[:, 1],
        mu1_sq=arr[:, 2],
        mu1_sq_err=arr[:, 3],
        n_samples=stress.shape[0],
        n_differences=np.array(counts, dtype=np.int64),
        overlapping=overlapping,
        n_excluded=None if jammed is None else np.array(excluded, dtype=np.int64),
        mu1_var=arr[:, 4],
        mu1_var_err=arr[:, 5],
    )


def moduli_from_stress_jumps(
    stress_jumps: ArrayLike | list[ArrayLike], strain_steps: ArrayLike
) -> ModulusMoments:
    """Moments from separate runs, one per ``δγ``: ``stress_jumps[i]`` holds the ``ΔΣ_n`` of
    the run at ``strain_steps[i]``, shape ``(samples, steps)`` (1-D: one sample).

    Differences are those of the runs' own steps (non-overlapping by construction); the number
    of samples must be the same for every ``δγ``.
    """
    steps = np.atleast_1d(np.asarray(strain_steps, dtype=np.float64))
    jumps_list = [np.atleast_2d(np.asarray(j, dtype=np.float64)) for j in stress_jumps]
    if len(jumps_list) != steps.size:
        raise ValueError(f"{len(jumps_list)} jump arrays for {steps.size} strain steps")
    if not np.all((steps > 0) & np.isfinite(steps)):
        raise ValueError(f"strain_steps must be finite and > 0, got {steps}")
    n_samples = {j.shape[0] for j in jumps_list}
    if len(n_samples) != 1:
        raise ValueError(f"all runs must have the same number of samples, got {n_samples}")
    arr = np.array([_moments_of_jumps(j, float(s)) for j, s in zip(jumps_list, steps, strict=True)])
    return ModulusMoments(
        strain_step=steps,
        mu1=arr[:, 0],
        mu1_err=arr[:, 1],
        mu1_sq=arr[:, 2],
        mu1_sq_err=arr[:, 3],
        n_samples=n_samples.pop(),
        n_differences=np.array([j.shape[1] for j in jumps_list], dtype=np.int64),
        overlapping=False,
        mu1_var=arr[:, 4],
        mu1_var_err=arr[:, 5],
    )


@dataclass(frozen=True)
class SlopeFit:
    """``log y = intercept + slope · log x`` by weighted least squares (natural logs).

    ``slope_err``/``intercept_err`` from the inverse normal matrix with the given errors taken
    as absolute (not rescaled by χ²); ``chi2`` and ``dof`` let the caller judge the fit.
    """

    slope: float
    slope_err: float
    intercept: float
    intercept_err: float
    chi2: float
    dof: int


def fit_log_slope(x: ArrayLike, y: ArrayLike, y_err: ArrayLike) -> SlopeFit:
    """Weighted least-squares fit of ``log y = a + b log x``, errors ``σ_log = y_err / y``.

    Minimises ``χ² = Σ ((log y_i − a − b log x_i)/σ_i)²``; with ``w_i = σ_i^−2``,
    ``S = Σw``, ``Sx = Σw X``, ``Sxx = Σw X²``, ``Δ = S Sxx − Sx²``:
    ``var(b) = S/Δ``, ``var(a) = Sxx/Δ`` (e.g. Press et al., Numerical Recipes §15.2).
    Errors assume independent points; moments from one subsampled trace at several lags are
    correlated, so treat the error as indicative there (or bootstrap over samples).
    NaN or inf anywhere raises ``ValueError``.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    y_err = np.asarray(y_err, dtype=np.float64)
    if not (x.shape == y.shape == y_err.shape) or x.size < 2:
        raise ValueError(f"x, y, y_err need equal shapes with >= 2 points; got {x.shape}")
    for name, values in (("x", x), ("y", y), ("y_err", y_err)):
        finite_data(values, name)
    if np.any(x <= 0) or np.any(y <= 0) or np.any(~(y_err > 0)):
        raise ValueError("x and y must be positive and y_err > 0 for a log-log fit")
    big_x, big_y = np.log(x), np.log(y)
    w = (y / y_err) ** 2
    s, sx, sxx = w.sum(), (w * big_x).sum(), (w * big_x**2).sum()
    sy, sxy = (w * big_y).sum(), (w * big_x * big_y).sum()
    delta = s * sxx - sx**2
    slope = (s * sxy - sx * sy) / delta
    intercept = (sxx * sy - sx * sxy) / delta
    chi2 = float((w * (big_y - intercept - slope * big_x) ** 2).sum())
    return SlopeFit(
        slope=float(slope),
        slope_err=float(np.sqrt(s / delta)),
        intercept=float(intercept),
        intercept_err=float(np.sqrt(sxx / delta)),
        chi2=chi2,
        dof=x.size - 2,
    )


def _centred_increments(shear_stress: ArrayLike,
                        jammed: ArrayLike | None) -> tuple[np.ndarray, ...]:
    """The increments of each row, the same about its sample's mean increment over the steps
    between jammed minima (0 elsewhere), those steps' mask, and the pairs of consecutive such
    steps."""
    stress = np.atleast_2d(np.asarray(shear_stress, dtype=np.float64))
    flags = (np.ones(stress.shape, bool) if jammed is None
             else np.atleast_2d(np.asarray(jammed, dtype=bool)))
    if flags.shape != stress.shape:
        raise ValueError(f"jammed has shape {flags.shape}, the stress {stress.shape}")
    d = np.diff(stress, axis=1)
    ok = flags[:, 1:] & flags[:, :-1]
    finite_data(d[ok], "shear_stress")
    mean = np.array([row[k].mean() if k.any() else 0.0 for row, k in zip(d, ok, strict=True)])
    dd = np.where(ok, d - mean[:, None], 0.0)
    return d, dd, ok, ok[:, 1:] & ok[:, :-1]


def increment_correlation(shear_stress: ArrayLike, jammed: ArrayLike | None = None) -> float:
    """The lag-1 correlation of consecutive increments ``ΔΣ_k = Σ_k − Σ_{k−1}`` of the rows of
    ``shear_stress`` (``(samples, rows)``), over the pairs of consecutive steps whose three
    minima are jammed (``jammed``, the traces' per-minimum flags; ``None``: all):
    ``Σ a b / √(Σ a² Σ b²)`` over those pairs, so that the steps without a partner do not dilute
    it, each sample's mean increment (over its steps between jammed minima) removed. NaN
    without a pair."""
    _, dd, _, pair = _centred_increments(shear_stress, jammed)
    products, den = _pair_products(dd, pair)
    return float(np.sum(products[pair])) / den if den > 0 else float("nan")


def _pair_products(dd: np.ndarray, pair: np.ndarray) -> tuple[np.ndarray, float]:
    """``a b`` of every pair of consecutive centred increments (``(samples, steps − 1)``) and the
    normalisation ``√(Σ a² Σ b²)`` over the pairs ``pair``."""
    a, b = dd[:, :-1], dd[:, 1:]
    return a * b, float(np.sqrt(np.sum(a[pair] ** 2) * np.sum(b[pair] ** 2)))


CORRELATION_PARTS = ("smooth", "before", "after", "events")
"""The pairs of consecutive steps :func:`increment_correlation_parts` splits ``ρ`` by: neither
step flagged plastic, the second only (the step that leads into an event), the first only (the
step after an event), both."""


def increment_correlation_parts(shear_stress: ArrayLike, plastic: ArrayLike,
                                jammed: ArrayLike | None = None) -> dict[str, float]:
    """:func:`increment_correlation` split by the pairs of :data:`CORRELATION_PARTS`: each part
    is ``Σ a b`` over its pairs, over the same ``√(Σ a² Σ b²)`` of all pairs, so the parts sum to
    ``ρ``. ``plastic``: the traces' per-row flags (``(samples, rows)``; row ``k`` flags the step
    ``k − 1 → k``). NaN parts without a pair."""
    _, dd, _, pair = _centred_increments(shear_stress, jammed)
    flags = np.atleast_2d(np.asarray(plastic, dtype=bool))
    if flags.shape != dd.shape[:1] + (dd.shape[1] + 1,):
        raise ValueError(f"plastic has shape {flags.shape}, the stress "
                         f"{dd.shape[:1] + (dd.shape[1] + 1,)}")
    first, second = flags[:, 1:-1], flags[:, 2:]
    products, den = _pair_products(dd, pair)
    kinds = {"smooth": ~first & ~second, "before": ~first & second,
             "after": first & ~second, "events": first & second}
    return {k: float(np.sum(products[pair & m])) / den if den > 0 else float("nan")
            for k, m in kinds.items()}


def event_neighbours(shear_stress: ArrayLike, plastic: ArrayLike,
                     jammed: ArrayLike | None = None) -> tuple[float, float, int]:
    """Where the stress increments next to isolated events rank: over the steps flagged plastic
    whose two neighbouring steps are not and whose four minima are jammed, the median rank of
    the increment of the step before and of the step after among its sample's unflagged
    increments between jammed minima (the fraction of those below it: 0.5 is a typical step), and
    how many such events. Below 0.5 before and above after: the minima soften as an event nears
    and are stiffer after it. A rank, not a ratio, because near jamming a sample's typical
    unflagged increment can be near 0 or negative (branches that unload). NaN without one."""
    d, _, ok, _ = _centred_increments(shear_stress, jammed)
    flags = np.atleast_2d(np.asarray(plastic, dtype=bool))[:, 1:]
    if flags.shape != d.shape:
        raise ValueError(f"plastic has shape {(flags.shape[0], flags.shape[1] + 1)}, the stress "
                         f"{(d.shape[0], d.shape[1] + 1)}")
    before, after = [], []
    for row, good, pl in zip(d, ok, flags, strict=True):
        elastic = np.sort(row[good & ~pl])
        if elastic.size == 0:
            continue
        k = np.arange(1, row.size - 1)
        iso = k[pl[k] & ~pl[k - 1] & ~pl[k + 1] & good[k] & good[k - 1] & good[k + 1]]
        for out, steps in ((before, iso - 1), (after, iso + 1)):
            below = np.searchsorted(elastic, row[steps], side="left")
            ties = np.searchsorted(elastic, row[steps], side="right") - below
            out += list((below + 0.5 * ties) / elastic.size)  # mid-rank: ties count half
    if not before:
        return float("nan"), float("nan"), 0
    return float(np.median(before)), float(np.median(after)), len(before)
