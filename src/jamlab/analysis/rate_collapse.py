"""Finite-size collapse of the *rate* of avalanches: ``n_N(≥ S) = N^(−b) F(S / N^a)``.

:func:`jamlab.analysis.finite_size.collapse` collapses the density per avalanche, ``P(S)``, which
is normalised at each ``N`` and so cannot see how the *number* of avalanches changes with the box.
Here the quantity is the cumulative rate per particle and unit strain,

    ``n_N(≥ S) = #{avalanches ≥ S} / (N Σ_packings γ)``,

(``γ`` the strain each packing was sheared over: one number for all, or one per packing), and the
collapse asks for the sizes to scale as ``N^a`` and the rate at a fixed scaled size as ``N^(−b)``.
Avalanches whose number and sizes do not depend on the box give ``a = b = 0``; a release per
particle and unit strain that does not depend on N (``∫ S dn``) needs ``a = b``.

The curves: per ``N``, ``n_N(≥ S)`` on one geometric grid of ``points_per_decade`` sizes per decade
from ``s_min`` up, kept where at least ``least`` avalanches are ``≥ S``. The collapse's quality at
``(a, b)``: the RMS, in decades, of ``log10(N_i^b n_i(S)) − log10(N_j^b n_j(S (N_j/N_i)^a))`` over
every ordered pair of sizes and every grid point of ``i`` where ``j`` has ``least`` avalanches at or
above the matched size. The other size's rate is *counted* at the matched size, not interpolated
between its grid points: interpolation smooths one curve and not the other except where the grids
align, and at ``a = 0``, where they do, a first version that interpolated had a sharp dip (its fits
landed on ``a = 0`` to 1e-9 from any start). ``(a, b)`` minimise it: a grid of step 0.05 over
``[−1, 2]²``, then Nelder–Mead from the grid's best point (its first simplex one grid step wide: the
counted rates make the objective rough on scales of 1e-3 in ``a``). Errors: the standard deviations
of ``(a, b)`` over ``boot`` resamples of each size's packings with replacement (each refitted by
Nelder–Mead from the data's optimum; ``numpy.random.default_rng(seed)``), and their correlation. A
pure power law ``n ∝ S^(1−τ)`` is invariant along ``b = a (τ − 1)``: the fit is determined by where
the curves bend (their cut-offs, a lower roll-off), and the resamples' correlation says how much.
Beside the optimum: the RMS without rescaling and with the rate alone rescaled (``a = 0``, best
``b``).

Used by ``scripts/rate_collapse.py`` (docs/reproduce.md, "The rate of avalanches collapses").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize, minimize_scalar

from jamlab import validation

__all__ = ["RateCollapse", "RateCurves", "collapse_rms", "cumulative_rates", "rate_collapse"]

FloatArray = NDArray[np.float64]

_STEP = 0.05
_GRID = np.round(np.arange(-1.0, 2.0 + 1e-9, _STEP), 10)


@dataclass(frozen=True)
class RateCollapse:
    """The fit of :func:`rate_collapse`: sizes ``n`` (ascending), ``packings`` and avalanches
    ``≥ s_min`` per size (``tails``); the exponents ``a`` (sizes ``∝ N^a``) and ``b`` (rate at a
    fixed scaled size ``∝ N^(−b)``), their resampled σ and correlation (``boot_used`` resamples
    that gave a collapse); the collapse's RMS (decades) at ``(a, b)``, unrescaled (``rms_none``),
    and with ``a = 0`` at the best ``b_rate_only`` (``rms_rate_only``)."""

    n: tuple[int, ...]
    packings: tuple[int, ...]
    tails: tuple[int, ...]
    s_min: float
    a: float
    b: float
    a_sigma: float
    b_sigma: float
    correlation: float
    boot_used: int
    rms: float
    rms_none: float
    b_rate_only: float
    rms_rate_only: float


Strain = float | Mapping[int, Sequence[float]]


def _per_packing(groups: Mapping[int, Sequence[np.ndarray]], strain: Strain) -> dict:
    """``{N: strains of its packings}`` from one strain for all or one per packing; ValueError
    where a strain is not a number > 0 or a size's count differs from its packings'."""
    scalar = validation.is_real(strain)
    if not (scalar or isinstance(strain, Mapping)):
        raise ValueError(f"strain must be a number or {{N: strains}}, got {strain!r}")
    out = {}
    for n, packs in groups.items():
        if not scalar and n not in strain:
            raise ValueError(f"N = {n}: no strains given for its packings")
        g = np.full(len(packs), strain, dtype=np.float64) if scalar \
            else np.asarray(strain[n], dtype=np.float64).ravel()
        if g.size != len(packs) or not np.all(np.isfinite(g) & (g > 0)):
            got = strain if scalar else g
            raise ValueError(f"N = {n}: the strains must be numbers > 0, one per packing "
                             f"({len(packs)}), got {got}")
        out[n] = g
    return out


def cumulative_rates(groups: Mapping[int, Sequence[np.ndarray]], strain: Strain, s_min: float,
                     least: int = 20, points_per_decade: int = 20
                     ) -> dict[int, tuple[FloatArray, FloatArray]]:
    """``{N: (S, n_N(≥ S))}``: the rate per particle and unit strain of avalanches ``≥ S`` of each
    size's packings (``groups[N]``: one size array per packing, sheared over ``strain``: one
    number, or ``{N: one per packing}``; the exposure is ``N`` times the packings' strains), on
    the grid ``s_min · 10^(k / points_per_decade)``, where at least ``least`` avalanches are
    ``≥ S``."""
    c = RateCurves(groups, strain, s_min, least, points_per_decade)
    return {n: (c.points[n], c.rate(n, c.points[n])[0]) for n in c.n}


class RateCurves:
    """``RateCurves(groups, strain, s_min, least, points_per_decade)`` (as
    :func:`cumulative_rates`), the data of the collapse's objective :func:`collapse_rms`. Per
    size: the pooled sizes ascending, the exposure ``N Σ γ`` over its packings, and the points of
    the grid ``s_min · 10^(k / points_per_decade)`` where at least ``least`` avalanches are at or
    above."""

    def __init__(self, groups, strain, s_min, least, points_per_decade):
        self.least, self.s_min = least, s_min
        self.n = sorted(int(n) for n in groups)
        strains = _per_packing(groups, strain)
        self.pooled = {int(n): np.sort(np.concatenate([np.asarray(a, dtype=np.float64).ravel()
                                                       for a in packs])) if len(packs)
                       else np.empty(0) for n, packs in groups.items()}
        self.exposure = {int(n): float(n) * float(g.sum()) for n, g in strains.items()}
        top = max((float(p[-1]) for p in self.pooled.values() if p.size), default=s_min)
        k = np.arange(int(math.floor(points_per_decade * math.log10(max(top, s_min) / s_min)))
                      + 1)
        grid = s_min * 10.0 ** (k / points_per_decade)
        self.points = {n: grid[self._count(n, grid) >= least] for n in self.n}

    def _count(self, n: int, s: FloatArray) -> NDArray[np.int64]:
        return self.pooled[n].size - np.searchsorted(self.pooled[n], s, side="left")

    def rate(self, n: int, s: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Size ``n``'s rate of avalanches ``≥ s`` per particle and unit strain, and where it
        rests on ``least`` avalanches or more with ``s ≥ s_min``."""
        count = self._count(n, s)
        return count / self.exposure[n], (count >= self.least) & (s >= self.s_min)

    def log_rate(self, n: int, s: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """:meth:`rate` in decades (a count of 0 taken as 1: such points are never kept)."""
        count = self._count(n, s)
        return (np.log10(np.maximum(count, 1) / self.exposure[n]),
                (count >= self.least) & (s >= self.s_min))


def collapse_rms(c: RateCurves, a: float, b: float) -> float:
    """RMS in decades of ``log10(N_i^b n_i(S)) − log10(N_j^b n_j(S (N_j/N_i)^a))`` over every
    ordered pair of sizes and every grid point ``S`` of ``i`` where ``j`` has ``least``
    avalanches at or above ``S (N_j/N_i)^a`` (and that is ``≥ s_min``): the other size's
    empirical rate is counted there, not interpolated."""
    sq = []
    for i in c.n:
        s = c.points[i]
        yi, _ = c.log_rate(i, s)
        for j in c.n:
            if j == i:
                continue
            yj, ok = c.log_rate(j, s * (j / i) ** a)
            sq.append((yi[ok] - yj[ok] + b * math.log10(i / j)) ** 2)
    d = np.concatenate(sq)
    return float(math.sqrt(d.mean())) if d.size else math.inf


def _fit(c: RateCurves, start: tuple[float, float] | None) -> tuple[float, float, float]:
    if start is None:
        best = min((collapse_rms(c, a, b), a, b) for a in _GRID for b in _GRID)
        start = (best[1], best[2])
    x0 = np.asarray(start, dtype=np.float64)
    # the counted rates make the objective rough on scales ≪ the grid's step: a simplex of the
    # grid's size, so that no start is held by a ripple next to it
    simplex = np.array([x0, x0 + (_STEP, 0.0), x0 + (0.0, _STEP)])
    res = minimize(lambda v: collapse_rms(c, v[0], v[1]), x0, method="Nelder-Mead",
                   options={"xatol": 1e-4, "fatol": 1e-9, "initial_simplex": simplex})
    return float(res.x[0]), float(res.x[1]), float(res.fun)


def rate_collapse(groups: Mapping[int, Sequence[np.ndarray]], strain: Strain, s_min: float, *,
                  least: int = 20, boot: int = 200, seed: int = 0,
                  points_per_decade: int = 20) -> RateCollapse:
    """:class:`RateCollapse` of ``groups`` (``{N: per-packing size arrays}``, two sizes or more; the
    packings sheared over ``strain``, as in :func:`cumulative_rates`) from ``s_min`` up (module
    docstring). ValueError with fewer than two sizes, a bad ``strain``, ``s_min``, ``least`` or
    ``boot``, or a size with fewer than two grid points above ``least`` avalanches."""
    if len(groups) < 2:
        raise ValueError(f"need two sizes N or more, got {sorted(groups)}")
    if not (validation.is_real(s_min) and math.isfinite(s_min) and s_min > 0):
        raise ValueError(f"s_min must be a number > 0, got {s_min!r}")
    strains = _per_packing(groups, strain)
    if not (validation.is_integer(least) and least >= 1):
        raise ValueError(f"least must be an integer >= 1, got {least!r}")
    if not (validation.is_integer(boot) and boot >= 2):
        raise ValueError(f"boot must be an integer >= 2, got {boot!r}")
    ns = sorted(int(n) for n in groups)
    empty = [n for n in ns if not len(groups[n])]
    if empty:
        raise ValueError(f"N = {empty[0]}: no packings")
    packs = {n: [np.asarray(a, dtype=np.float64).ravel() for a in groups[n]] for n in ns}
    strains = {int(n): g for n, g in strains.items()}
    curves = RateCurves(packs, strains, s_min, least, points_per_decade)
    for n, s in curves.points.items():
        if s.size < 2:
            raise ValueError(f"N = {n}: fewer than two sizes S >= {s_min:.3g} with {least} "
                             "avalanches or more at or above them")
    a, b, rms = _fit(curves, None)
    only = minimize_scalar(lambda v: collapse_rms(curves, 0.0, v), bounds=(-1.0, 2.0),
                           method="bounded", options={"xatol": 1e-6})
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(boot):
        pick = {n: rng.integers(0, len(packs[n]), len(packs[n])) for n in ns}
        c = RateCurves({n: [packs[n][i] for i in pick[n]] for n in ns},
                       {n: strains[n][pick[n]] for n in ns}, s_min, least, points_per_decade)
        if all(s.size >= 2 for s in c.points.values()):
            fa, fb, q = _fit(c, (a, b))
            if math.isfinite(q):
                draws.append((fa, fb))
    d = np.asarray(draws, dtype=np.float64).reshape(-1, 2)
    enough = d.shape[0] >= 2
    return RateCollapse(
        n=tuple(ns), packings=tuple(len(packs[n]) for n in ns),
        tails=tuple(int(sum(np.count_nonzero(x >= s_min) for x in packs[n])) for n in ns),
        s_min=float(s_min), a=a, b=b,
        a_sigma=float(np.std(d[:, 0], ddof=1)) if enough else math.nan,
        b_sigma=float(np.std(d[:, 1], ddof=1)) if enough else math.nan,
        correlation=float(np.corrcoef(d.T)[0, 1]) if enough else math.nan,
        boot_used=int(d.shape[0]), rms=rms, rms_none=collapse_rms(curves, 0.0, 0.0),
        b_rate_only=float(only.x), rms_rate_only=float(only.fun))
