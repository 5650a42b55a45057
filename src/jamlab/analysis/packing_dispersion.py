"""Are the packings of one ensemble alike? Over-dispersion of their avalanches between packings.

A pooled size distribution is a mixture over packings. If packings differed in their cut-off or
their rate of avalanches (a structure that some packings carry and others not), the pooled law
would be a mixture whose shape, and so the fitted τ, could move with N as the spread between
packings shrinks. :func:`packing_dispersion` tests the two things a mixture would show, each
against the null hypothesis that every packing draws from the same law:

- **sizes**: the packings' means of ``log(S / x_min)`` over their sizes ``S ≥ x_min`` — the
  between-packing variance against the within-packing one (the one-way ANOVA ratio ``F``), with a
  permutation p-value (the sizes dealt to the packings at random, each keeping its count; no
  normality assumed: ``log S`` of a power law is exponential, not normal);
- **counts**: the packings' numbers of sizes ``≥ x_min``, their variance over their mean
  (1 for Poisson counts; the dispersion index ``(k − 1) var/mean ~ χ²_{k−1}`` gives the one-sided
  p of over-dispersion).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = ["PackingDispersion", "packing_dispersion"]


@dataclass(frozen=True)
class PackingDispersion:
    """:func:`packing_dispersion`. ``packings``: packings with two sizes or more in the window
    (the sizes test uses these); ``sizes``: their sizes; ``mean_log``: the pooled mean of
    ``log(S/x_min)``; ``f_ratio``: between- over within-packing variance of ``log(S/x_min)``
    (≈ 1 when packings are alike) and ``f_p`` its permutation p (``permutations`` draws);
    ``count_mean``, ``count_ratio`` (variance / mean over all ``n_packings``) and ``count_p``
    (one-sided, over-dispersion)."""

    n_packings: int
    packings: int
    sizes: int
    mean_log: float
    f_ratio: float
    f_p: float
    permutations: int
    count_mean: float
    count_ratio: float
    count_p: float


def _f_ratio(values: np.ndarray, bounds: np.ndarray) -> float:
    """One-way ANOVA ratio of ``values`` split at ``bounds`` (cumulative counts, from 0)."""
    sums = np.add.reduceat(values, bounds[:-1])
    counts = np.diff(bounds)
    means = sums / counts
    grand = values.mean()
    between = float(np.sum(counts * (means - grand) ** 2)) / (counts.size - 1)
    within = float(np.sum((values - np.repeat(means, counts)) ** 2)) / (values.size - counts.size)
    return between / within


def packing_dispersion(packs: Sequence[np.ndarray], x_min: float, permutations: int = 2000,
                       seed: int = 0) -> PackingDispersion:
    """:class:`PackingDispersion` of one ensemble: ``packs`` holds each packing's sizes (ε), the
    window starts at ``x_min``; ``permutations`` random deals of the sizes (``default_rng(seed)``).
    ValueError with fewer than two packings holding two sizes or more in the window, or
    ``permutations < 1``."""
    if not x_min > 0:
        raise ValueError(f"x_min must be > 0, got {x_min!r}")
    if permutations < 1:
        raise ValueError(f"permutations must be >= 1, got {permutations}")
    tails = [np.log(np.asarray(p, dtype=np.float64)[np.asarray(p) >= x_min] / x_min)
             for p in packs]
    counts = np.array([t.size for t in tails], dtype=np.float64)
    used = [t for t in tails if t.size >= 2]
    if len(used) < 2:
        raise ValueError(f"{len(used)} packing(s) with two sizes or more at or above "
                         f"x_min={x_min:g}: need two")
    values = np.concatenate(used)
    bounds = np.concatenate([[0], np.cumsum([t.size for t in used])])
    f = _f_ratio(values, bounds)
    rng = np.random.default_rng(seed)
    above = sum(_f_ratio(rng.permutation(values), bounds) >= f for _ in range(permutations))
    k = counts.size
    mean_c = float(counts.mean())
    ratio = float(counts.var(ddof=1) / mean_c) if k > 1 and mean_c > 0 else float("nan")
    count_p = float(stats.chi2.sf((k - 1) * ratio, k - 1)) if np.isfinite(ratio) else float("nan")
    return PackingDispersion(
        n_packings=k, packings=len(used), sizes=int(values.size), mean_log=float(values.mean()),
        f_ratio=f, f_p=(above + 1) / (permutations + 1), permutations=permutations,
        count_mean=mean_c, count_ratio=ratio, count_p=count_p)
