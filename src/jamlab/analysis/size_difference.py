"""τ of two or more system sizes in one fixed window, with whole packings as the independent units.

The avalanches of one packing are correlated (they share its contact network and history), so
the asymptotic σ of a fit, which counts every avalanche as independent, can understate the error
of a difference between two sizes. :func:`size_difference` fits each size alone with an
exponential cut-off at one fixed lower end ``x_min`` (:func:`fit_cutoff_power_law`) and takes the
σ of ``Δτ = τ(largest N) − τ(smallest N)``, and of the least-squares slope ``dτ/d ln N`` through
all the sizes, from resamples that draw each size's packings with replacement;
:func:`combined_scores` combines the z-scores of several pressures. Used by
``scripts/size_dependence.py`` (docs/reproduce.md, "Does τ depend on N in one window?").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats

from jamlab.analysis.cutoff_powerlaw import fit_cutoff_power_law

__all__ = ["SizeDifference", "StrainStepSlopes", "combined_scores", "size_difference",
           "strain_step_slopes"]


@dataclass(frozen=True)
class SizeDifference:
    """τ of two or more sizes (ascending N) at one window; the difference of the largest and the
    smallest with two errors, and the slope ``dτ/d ln N`` through all of them with one."""

    x_min: float
    n: tuple[int, ...]
    packings: tuple[int, ...]
    tails: tuple[int, ...]
    tau: tuple[float, ...]
    sigma: tuple[float, ...]  # asymptotic (avalanches independent)
    boot_sigma: float  # of Δτ, packings resampled
    fraction_not_above: float  # of the resamples with Δτ ≤ 0
    slope: float  # least-squares dτ/d ln N, every size weighted alike
    slope_sigma: float  # of the slope, the same resamples

    @property
    def delta(self) -> float:
        """``τ(largest N) − τ(smallest N)``."""
        return self.tau[-1] - self.tau[0]

    @property
    def z_asymptotic(self) -> float:
        return self.delta / math.hypot(self.sigma[0], self.sigma[-1])

    @property
    def z_boot(self) -> float:
        return self.delta / self.boot_sigma

    @property
    def z_slope(self) -> float:
        """The slope in units of its resampled σ (with two sizes, :attr:`z_boot` up to
        rounding: the slope is then ``Δτ / ln(N₁/N₀)``)."""
        return self.slope / self.slope_sigma


def least_squares_slope(log_n: np.ndarray, tau: np.ndarray) -> float:
    """Least-squares slope of ``tau`` on ``log_n`` (equal weights)."""
    x = log_n - log_n.mean()
    return float(np.dot(x, tau - tau.mean()) / np.dot(x, x))


def size_difference(groups: dict[int, list[np.ndarray]], x_min: float, boot: int,
                    seed: int = 0) -> SizeDifference:
    """:class:`SizeDifference` of ``groups`` (``{N: per-packing size arrays}``, two sizes or
    more) at the fixed lower end ``x_min``; ``boot`` resamples of each size's packings (with
    replacement, ``numpy.random.default_rng(seed)``, the sizes in ascending N, so that two sizes
    draw what they drew before the slope was added). A resample in which a size has fewer than
    10 sizes in the window is dropped. ValueError with fewer than two sizes, with ``boot < 2``,
    or where a size has fewer than 10 sizes at or above ``x_min``."""
    if len(groups) < 2:
        raise ValueError(f"need two sizes N or more, got {sorted(groups)}")
    if boot < 2:
        raise ValueError(f"boot must be >= 2, got {boot}")
    ns = sorted(groups)
    packs = [[np.asarray(a, dtype=np.float64) for a in groups[n]] for n in ns]
    for n, p in zip(ns, packs, strict=True):
        tail = int(sum(np.count_nonzero(a >= x_min) for a in p))
        if tail < 10:
            raise ValueError(f"N = {n}: {tail} sizes at or above {x_min:.3g}, fewer than 10")
    fits = [fit_cutoff_power_law(np.concatenate(p), x_min) for p in packs]
    log_n = np.log(np.asarray(ns, dtype=np.float64))
    taus = resampled_taus(packs, x_min, boot, seed)
    taus = taus[np.all(np.isfinite(taus), axis=1)]
    deltas = taus[:, -1] - taus[:, 0]
    slopes = np.array([least_squares_slope(log_n, t) for t in taus])
    tau = np.array([f.tau for f in fits])
    return SizeDifference(
        x_min=float(x_min), n=tuple(ns), packings=tuple(len(p) for p in packs),
        tails=tuple(f.n_tail for f in fits), tau=tuple(float(t) for t in tau),
        sigma=tuple(f.tau_stderr for f in fits),
        boot_sigma=float(np.std(deltas, ddof=1)),
        fraction_not_above=float(np.mean(deltas <= 0)),
        slope=least_squares_slope(log_n, tau), slope_sigma=float(np.std(slopes, ddof=1)))


def _exponential_tau(sizes: np.ndarray, x_min: float) -> float:
    return fit_cutoff_power_law(sizes, x_min).tau


def resampled_taus(packs: list[list[np.ndarray]], x_min: float, boot: int, seed: int,
                   fit: Callable[[np.ndarray, float], float] = _exponential_tau) -> np.ndarray:
    """``(boot, sizes)`` τ of resamples of each size's packings (``default_rng(seed)``, the sizes
    in order), ``fit(sizes, x_min)`` of each (default: τ with an exponential cut-off,
    :func:`fit_cutoff_power_law`); NaN where a resample has fewer than 10 sizes at or above
    ``x_min``. The picks depend only on ``seed`` and the packing counts, so two calls with the
    same counts draw the same packings (:func:`strain_step_slopes` pairs its strain steps so)."""
    rng = np.random.default_rng(seed)
    taus = np.empty((boot, len(packs)))
    for b in range(boot):
        for k, p in enumerate(packs):
            pick = rng.integers(0, len(p), len(p))
            s = np.concatenate([p[i] for i in pick])
            taus[b, k] = fit(s, x_min) if np.count_nonzero(s >= x_min) >= 10 else math.nan
    return taus


@dataclass(frozen=True)
class StrainStepSlopes:
    """:func:`strain_step_slopes`: per strain step ``k δγ`` (``k`` in :attr:`k`, then the linear
    extrapolation to ``δγ → 0``, ``2 τ(δγ) − τ(2 δγ)``, as the last row) τ of every size, the
    slope ``dτ/d ln N`` and its σ from packing resamples paired across the rows."""

    x_min: float
    n: tuple[int, ...]
    k: tuple[int, ...]
    tau: np.ndarray  # (len(k) + 1, sizes)
    slope: np.ndarray  # (len(k) + 1,)
    slope_sigma: np.ndarray  # (len(k) + 1,)


def strain_step_slopes(groups: dict[int, dict[int, list[np.ndarray]]], x_min: float, boot: int,
                       seed: int = 0) -> StrainStepSlopes:
    """The slope ``dτ/d ln N`` at several strain steps: ``groups[k]`` is ``{N: per-packing
    sizes}`` of the same packings seen at ``k δγ`` (``jamlab.reproduce.ensembles.
    coarse_avalanches``); ``k = 1`` and ``k = 2`` are required (the extrapolation
    ``2 τ(δγ) − τ(2 δγ)`` uses them). Each size is fitted alone at the fixed ``x_min`` as in
    :func:`size_difference`; the ``boot`` resamples draw the same packings at every ``k``
    (resamples where some fit is missing are dropped). ValueError without k = 1, 2, with sizes
    or packing counts that differ between the k, or with ``boot < 2``."""
    ks = sorted(groups)
    if 1 not in groups or 2 not in groups:
        raise ValueError(f"need k = 1 and k = 2, got {ks}")
    if boot < 2:
        raise ValueError(f"boot must be >= 2, got {boot}")
    ns = sorted(groups[1])
    counts = [len(groups[1][n]) for n in ns]
    for k in ks:
        if sorted(groups[k]) != ns or [len(groups[k][n]) for n in ns] != counts:
            raise ValueError(f"k = {k}: not the sizes and packings of k = 1")
    log_n = np.log(np.asarray(ns, dtype=np.float64))
    tau = np.array([[fit_cutoff_power_law(np.concatenate(groups[k][n]), x_min).tau for n in ns]
                    for k in ks])
    boots = np.stack([resampled_taus([groups[k][n] for n in ns], x_min, boot, seed)
                      for k in ks])  # (k, boot, sizes), the same packings in every k
    tau = np.vstack([tau, 2.0 * tau[0] - tau[1]])
    boots = np.concatenate([boots, (2.0 * boots[0] - boots[1])[None]])
    boots = boots[:, np.all(np.isfinite(boots), axis=(0, 2))]
    slopes = np.array([[least_squares_slope(log_n, t) for t in row] for row in boots])
    return StrainStepSlopes(
        x_min=float(x_min), n=tuple(ns), k=tuple(ks), tau=tau,
        slope=np.array([least_squares_slope(log_n, t) for t in tau]),
        slope_sigma=np.std(slopes, axis=1, ddof=1))


def combined_scores(zs: list[float]) -> tuple[float, float, float, float]:
    """``(Σ z², its χ²_k p, Σ z/√k, its two-sided normal p)`` of ``k`` z-scores."""
    z = np.asarray(zs, dtype=np.float64)
    chi2 = float(np.sum(z * z))
    s = float(z.sum() / math.sqrt(z.size))
    return chi2, float(stats.chi2.sf(chi2, z.size)), s, float(2 * stats.norm.sf(abs(s)))
