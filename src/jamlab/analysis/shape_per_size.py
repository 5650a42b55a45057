"""One τ for several system sizes whose cut-off moves with N in scale *and* shape, at one window.

The joint fits of ``scripts/tau_window.py`` give every size one τ and one cut-off shape ``a``
(``p(S) ∝ S^(−τ) e^(−(S/S*_N)^a)``, ``S*_N ∝ N^β``); ``scripts/size_dependence.py`` fits each
size alone with one ``a`` held for all. At p = 1e-4 the shape each size prefers moves with N
(docs/reproduce.md, "p = 1e-4 with four sizes"), so both can read a moving shape as a moving τ.
Here each size ``k`` has its own ``S*_k`` and its own ``a_k`` (on a grid of shapes), and:

- **separately** (τ_k free too): the profile of :func:`cutoff_shape_profile` per size — ``τ_k`` at
  the size's best shape, its shape-free 95 % interval, and the least-squares slope ``dτ/d ln N``
  through the ``τ_k`` with its σ from resamples of each size's packings (whole packings the
  independent units);
- **jointly** (one τ): ``L(τ) = Σ_k max_(a_k, S*_k) ℓ_k(τ, a_k, S*_k)``, maximised over τ, with
  its 95 % profile interval ``2 (L_max − L(τ)) ≤ 3.84``;
- the likelihood ratio ``2 (Σ_k ℓ_k,max − L_max)`` of the separate fits against the joint one,
  ``χ²`` with ``K − 1`` degrees of freedom when the avalanches are independent (they are not
  quite: the slope's packing-resampled z is the test with packings as units).

``ℓ`` is the log-likelihood of the sizes ``x ≥ x_min`` (normaliser
:func:`cutoff_power_law_log_norm`), the same number :func:`cutoff_shape_profile` reports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from jamlab.analysis.cutoff_powerlaw import (
    CHI2_1_95,
    DEFAULT_STRETCHES,
    cutoff_shape_profile,
    log_yc_bounds,
    tail_objective,
)
from jamlab.analysis.size_difference import least_squares_slope, resampled_taus

__all__ = ["SharedTau", "fixed_tau_loglik", "shared_tau"]

_MIN_TAIL = 10
_SCAN = 40  # points of the coarse scan of log S* before the bounded refinement
_TAU_STEP = 0.02  # the joint profile's coarse grid in τ


def fixed_tau_loglik(x: np.ndarray, x_min: float, tau: float, stretch: float
                     ) -> tuple[float, float]:
    """``(max over x_c of ℓ(τ, x_c, a), the x_c there)`` for the sizes ``x ≥ x_min`` at fixed
    ``τ`` and cut-off shape ``a = stretch``: a scan of ``log x_c`` over the bounds of
    :func:`fit_cutoff_power_law` (``x_min e^(−3/a)`` to ``max x · e^(7/a)``), refined by a bounded
    scalar search around the scan's best point. ValueError with fewer than 10 sizes in the
    window."""
    x = np.asarray(x, dtype=np.float64)
    y = x[x >= x_min] / x_min
    if y.size < _MIN_TAIL:
        raise ValueError(f"need at least {_MIN_TAIL} sizes at or above x_min={x_min:g}, "
                         f"got {y.size}")
    n = y.size
    fun, args = tail_objective(y, np.log(y), stretch)

    def nll(v: float) -> float:  # −ℓ_y at log y_c = v
        return fun(np.array([tau, v]), *args)

    lo, hi = log_yc_bounds(y, stretch)
    grid = np.linspace(lo, hi, _SCAN)
    vals = [nll(float(v)) for v in grid]
    k = int(np.argmin(vals))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, _SCAN - 1)]
    r = optimize.minimize_scalar(nll, bounds=(a, b), method="bounded",
                                 options={"xatol": 1e-10})
    v, f = (float(r.x), float(r.fun)) if r.fun <= vals[k] else (float(grid[k]), vals[k])
    return -f - n * math.log(x_min), x_min * math.exp(v)


@dataclass(frozen=True)
class SharedTau:
    """Result of :func:`shared_tau` (sizes ascending; module docstring). Separate fits: ``tau_each``
    at each size's best shape ``a_each``, its shape-free interval ``low_each``/``high_each``,
    ``loglik_each`` (max over τ, S* and the grid's a); the slope of ``tau_each`` on ``ln N`` with
    ``slope_sigma`` from ``boot`` packing resamples (``boot_used`` kept). Joint fit: ``tau``, its
    interval ``tau_low``/``tau_high``, ``loglik`` and the shape ``a_joint`` each size takes there;
    ``lr`` against the separate fits on ``dof = K − 1`` degrees of freedom, ``p_value``."""

    x_min: float
    n: tuple[int, ...]
    packings: tuple[int, ...]
    tails: tuple[int, ...]
    stretches: tuple[float, ...]
    tau_each: tuple[float, ...]
    a_each: tuple[float, ...]
    low_each: tuple[float, ...]
    high_each: tuple[float, ...]
    loglik_each: tuple[float, ...]
    slope: float
    slope_sigma: float
    boot_used: int
    tau: float
    tau_low: float
    tau_high: float
    loglik: float
    a_joint: tuple[float, ...]
    lr: float
    dof: int
    p_value: float

    @property
    def z_slope(self) -> float:
        return self.slope / self.slope_sigma


def _joint(tails: list[np.ndarray], x_min: float, grid: tuple[float, ...], tau: float
           ) -> tuple[float, tuple[float, ...]]:
    """``(L(τ), the shape each size takes at τ)``."""
    total, shapes = 0.0, []
    for x in tails:
        ll = [fixed_tau_loglik(x, x_min, tau, a)[0] for a in grid]
        k = int(np.argmax(ll))
        total += ll[k]
        shapes.append(grid[k])
    return total, tuple(shapes)


def shared_tau(groups: dict[int, list[np.ndarray]], x_min: float,
               stretches: tuple[float, ...] = DEFAULT_STRETCHES, boot: int = 200,
               seed: int = 0) -> SharedTau:
    """:class:`SharedTau` of ``groups`` (``{N: per-packing size arrays}``, two sizes or more) at
    the fixed lower end ``x_min``, the shapes on the grid ``stretches``; ``boot`` resamples of
    each size's packings (``numpy.random.default_rng(seed)``, sizes in ascending N; a resample
    where a size has fewer than 10 sizes in the window is dropped), for the σ of the slope of
    the separate τ against ``ln N``; ``boot = 0`` draws none (``slope_sigma`` NaN, the joint fit
    unchanged). ValueError with fewer than two sizes, ``boot`` 1 or negative, or a size with
    fewer than 10 sizes in the window."""
    if len(groups) < 2:
        raise ValueError(f"need two sizes N or more, got {sorted(groups)}")
    if boot < 0 or boot == 1:
        raise ValueError(f"boot must be 0 or >= 2, got {boot}")
    ns = sorted(groups)
    grid = tuple(sorted(float(a) for a in stretches))
    tails = [np.concatenate(groups[n]) for n in ns]
    tails = [t[t >= x_min] for t in tails]
    for n, t in zip(ns, tails, strict=True):
        if t.size < _MIN_TAIL:
            raise ValueError(f"N = {n}: {t.size} sizes at or above x_min={x_min:g}, need "
                             f"{_MIN_TAIL}")
    prof = [cutoff_shape_profile(t, x_min, grid) for t in tails]
    tau_each = np.array([p.tau_best for p in prof])
    log_n = np.log(np.array(ns, dtype=np.float64))
    boots = resampled_taus([groups[n] for n in ns], x_min, boot, seed,
                           lambda t, xm: cutoff_shape_profile(t, xm, grid).tau_best
                           ) if boot else []
    slopes = [least_squares_slope(log_n, t) for t in boots if np.all(np.isfinite(t))]
    # the joint fit: a coarse grid in τ around the separate fits, then a bounded refinement
    lo, hi = float(tau_each.min()) - 0.4, float(tau_each.max()) + 0.4
    taus = np.arange(lo, hi + _TAU_STEP / 2, _TAU_STEP)
    vals = np.array([_joint(tails, x_min, grid, float(t))[0] for t in taus])
    k = int(np.argmax(vals))
    r = optimize.minimize_scalar(
        lambda t: -_joint(tails, x_min, grid, t)[0],
        bounds=(taus[max(k - 1, 0)], taus[min(k + 1, taus.size - 1)]), method="bounded",
        options={"xatol": 1e-6})
    tau, best = (float(r.x), -float(r.fun)) if -r.fun >= vals[k] else (float(taus[k]), vals[k])
    a_joint = _joint(tails, x_min, grid, tau)[1]

    def edge(side: np.ndarray) -> float:  # where 2 (L_max − L) crosses 3.84 on that side
        out = side[2.0 * (best - vals[side]) > CHI2_1_95]  # grid indices, nearest τ first
        if out.size == 0:
            return math.nan  # the grid does not reach the edge
        return optimize.brentq(
            lambda t: 2.0 * (best - _joint(tails, x_min, grid, t)[0]) - CHI2_1_95,
            float(taus[out[0]]), tau, xtol=1e-6)

    tau_low = edge(np.flatnonzero(taus < tau)[::-1])
    tau_high = edge(np.flatnonzero(taus > tau))
    ll_each = tuple(max(p.logliks) for p in prof)
    lr = max(2.0 * (sum(ll_each) - best), 0.0)
    dof = len(ns) - 1
    return SharedTau(
        x_min=float(x_min), n=tuple(ns), packings=tuple(len(groups[n]) for n in ns),
        tails=tuple(int(t.size) for t in tails), stretches=grid,
        tau_each=tuple(float(v) for v in tau_each), a_each=tuple(p.best for p in prof),
        low_each=tuple(p.tau_low for p in prof), high_each=tuple(p.tau_high for p in prof),
        loglik_each=ll_each, slope=least_squares_slope(log_n, tau_each),
        slope_sigma=float(np.std(slopes, ddof=1)) if len(slopes) > 1 else math.nan,
        boot_used=len(slopes), tau=tau, tau_low=tau_low, tau_high=tau_high, loglik=best,
        a_joint=a_joint, lr=lr, dof=dof, p_value=float(stats.chi2.sf(lr, dof)))
