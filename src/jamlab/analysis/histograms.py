"""Logarithmically binned histograms normalised as probability densities.

Normalisation (see ``docs/analysis.md``): with ``c_j`` counts in bin ``[e_j, e_{j+1})`` of width
``w_j = e_{j+1} − e_j`` and a normaliser ``N``,

    density_j = c_j / (N w_j),     error_j = √c_j / (N w_j)   (Poisson),

so ``Σ_j density_j w_j = (number of data inside the range) / N``. By default ``N`` is the number
of data given (``len(x)``, counting non-positive and out-of-range values), so the histogram is the
density of the given sample restricted to the range. Pass ``n_total`` (e.g. the number of AQS
steps including those without a jump) to get a density per step, comparable across runs whose
jump fractions differ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab.analysis.powerlaw import finite_data

__all__ = ["LogHistogram", "log_histogram"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class LogHistogram:
    """A log-binned density histogram.

    ``edges`` (n_bins+1), ``centres`` (geometric means of the edges), ``widths``, ``counts``,
    ``density`` and ``density_err`` (n_bins each); ``n_total`` is the normaliser ``N`` and
    ``n_in_range`` the number of data counted in the bins.
    """

    edges: FloatArray
    centres: FloatArray
    widths: FloatArray
    counts: NDArray[np.int64]
    density: FloatArray
    density_err: FloatArray
    n_total: int
    n_in_range: int


def log_histogram(
    x: ArrayLike,
    bins_per_decade: int = 10,
    range: tuple[float, float] | None = None,  # named as in numpy.histogram
    n_total: int | None = None,
) -> LogHistogram:
    """Histogram of positive data in logarithmic bins, normalised as a density.

    Bins: ``bins_per_decade`` equal bins per factor 10. With ``range=None`` the edges lie on the
    universal grid ``10^(k/bins_per_decade)`` (integer ``k``) covering the positive data, so
    histograms of different data sets share bins; with ``range=(lo, hi)`` the edges run from
    ``lo`` to ``hi`` in ``ceil(bins_per_decade·log10(hi/lo))`` equal logarithmic steps. Data
    outside the range and non-positive data are not binned but count in the default normaliser.
    ``density_j = c_j/(N w_j)`` with ``N = n_total`` if given, else ``len(x)``; Poisson error
    ``√c_j/(N w_j)`` (zero for empty bins). Centres are geometric: ``√(e_j e_{j+1})``.
    NaN or inf data raise ``ValueError``.
    """
    if not (math.isfinite(bins_per_decade) and bins_per_decade >= 1):
        raise ValueError(f"bins_per_decade={bins_per_decade} must be finite and >= 1")
    if n_total is not None and not (math.isfinite(n_total) and n_total == math.floor(n_total)):
        raise ValueError(f"n_total={n_total!r} must be a whole number")
    x = finite_data(x)
    norm = x.size if n_total is None else int(n_total)
    if n_total is not None and n_total < np.count_nonzero(x > 0):
        raise ValueError(f"n_total={n_total} is smaller than the number of positive data")
    if range is None:
        pos = x[x > 0]
        if pos.size == 0:
            raise ValueError("no positive finite data to bin; give range=(lo, hi)")
        k_lo = math.floor(bins_per_decade * math.log10(pos.min()))
        k_hi = math.ceil(bins_per_decade * math.log10(pos.max()))
        k_hi = max(k_hi, k_lo + 1)
        if 10 ** (k_hi / bins_per_decade) <= pos.max():
            k_hi += 1  # float rounding must not leave the maximum on the closed right edge
        edges = 10.0 ** (np.arange(k_lo, k_hi + 1) / bins_per_decade)
    else:
        lo, hi = float(range[0]), float(range[1])
        if not (0 < lo < hi and math.isfinite(hi)):
            raise ValueError(f"range={range!r} must satisfy 0 < lo < hi < inf")
        n_bins = max(1, math.ceil(bins_per_decade * math.log10(hi / lo) - 1e-9))
        edges = np.geomspace(lo, hi, n_bins + 1)
    counts, _ = np.histogram(x, bins=edges)
    widths = np.diff(edges)
    scale = 1.0 / (norm * widths) if norm > 0 else np.zeros_like(widths)
    return LogHistogram(
        edges=edges,
        centres=np.sqrt(edges[:-1] * edges[1:]),
        widths=widths,
        counts=counts.astype(np.int64),
        density=counts * scale,
        density_err=np.sqrt(counts) * scale,
        n_total=norm,
        n_in_range=int(counts.sum()),
    )
