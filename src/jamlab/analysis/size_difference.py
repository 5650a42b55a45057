"""τ of two system sizes in one fixed window, with whole packings as the independent units.

The avalanches of one packing are correlated (they share its contact network and history), so
the asymptotic σ of a fit, which counts every avalanche as independent, can understate the error
of a difference between two sizes. :func:`size_difference` fits each size alone with an
exponential cut-off at one fixed lower end ``x_min`` (:func:`fit_cutoff_power_law`) and takes the
σ of ``Δτ = τ(larger N) − τ(smaller N)`` from resamples that draw each size's packings with
replacement; :func:`combined_scores` combines the z-scores of several pressures. Used by
``scripts/size_dependence.py`` (docs/reproduce.md, "Does τ depend on N in one window?").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from jamlab.analysis.cutoff_powerlaw import fit_cutoff_power_law

__all__ = ["SizeDifference", "combined_scores", "size_difference"]


@dataclass(frozen=True)
class SizeDifference:
    """τ of two sizes at one window, and their difference with two errors."""

    x_min: float
    n: tuple[int, int]
    packings: tuple[int, int]
    tails: tuple[int, int]
    tau: tuple[float, float]
    sigma: tuple[float, float]  # asymptotic (avalanches independent)
    boot_sigma: float  # of Δτ, packings resampled
    fraction_not_above: float  # of the resamples with Δτ ≤ 0

    @property
    def delta(self) -> float:
        """``τ(larger N) − τ(smaller N)``."""
        return self.tau[1] - self.tau[0]

    @property
    def z_asymptotic(self) -> float:
        return self.delta / math.hypot(*self.sigma)

    @property
    def z_boot(self) -> float:
        return self.delta / self.boot_sigma


def size_difference(groups: dict[int, list[np.ndarray]], x_min: float, boot: int,
                    seed: int = 0) -> SizeDifference:
    """:class:`SizeDifference` of ``groups`` (``{N: per-packing size arrays}``, two sizes) at
    the fixed lower end ``x_min``; ``boot`` resamples of each size's packings (with
    replacement, ``numpy.random.default_rng(seed)``). ValueError without two sizes, with
    ``boot < 2``, or where a size has fewer than 10 sizes at or above ``x_min``."""
    if len(groups) != 2:
        raise ValueError(f"need two sizes N, got {sorted(groups)}")
    if boot < 2:
        raise ValueError(f"boot must be >= 2, got {boot}")
    ns = sorted(groups)
    packs = [[np.asarray(a, dtype=np.float64) for a in groups[n]] for n in ns]
    for n, p in zip(ns, packs, strict=True):
        tail = int(sum(np.count_nonzero(a >= x_min) for a in p))
        if tail < 10:
            raise ValueError(f"N = {n}: {tail} sizes at or above {x_min:.3g}, fewer than 10")
    fits = [fit_cutoff_power_law(np.concatenate(p), x_min) for p in packs]
    rng = np.random.default_rng(seed)
    deltas = np.empty(boot)
    for b in range(boot):
        taus = []
        for p in packs:
            pick = rng.integers(0, len(p), len(p))
            s = np.concatenate([p[i] for i in pick])
            # (a resample with fewer than 10 sizes in the window has no fit: τ = NaN, dropped)
            taus.append(fit_cutoff_power_law(s, x_min).tau
                        if np.count_nonzero(s >= x_min) >= 10 else math.nan)
        deltas[b] = taus[1] - taus[0]
    deltas = deltas[np.isfinite(deltas)]
    return SizeDifference(
        x_min=float(x_min), n=(ns[0], ns[1]), packings=(len(packs[0]), len(packs[1])),
        tails=(fits[0].n_tail, fits[1].n_tail), tau=(fits[0].tau, fits[1].tau),
        sigma=(fits[0].tau_stderr, fits[1].tau_stderr),
        boot_sigma=float(np.std(deltas, ddof=1)),
        fraction_not_above=float(np.mean(deltas <= 0)))


def combined_scores(zs: list[float]) -> tuple[float, float, float, float]:
    """``(Σ z², its χ²_k p, Σ z/√k, its two-sided normal p)`` of ``k`` z-scores."""
    z = np.asarray(zs, dtype=np.float64)
    chi2 = float(np.sum(z * z))
    s = float(z.sum() / math.sqrt(z.size))
    return chi2, float(stats.chi2.sf(chi2, z.size)), s, float(2 * stats.norm.sf(abs(s)))
