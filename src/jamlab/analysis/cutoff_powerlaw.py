"""A power law with an exponential cut-off, fitted by maximum likelihood at a fixed lower end.

Model on ``[x_min, ∞)``: ``p(x) = x^(−τ) e^(−x/x_c) / Z`` with
``Z = x_c^(1−τ) Γ(1−τ, x_min/x_c)`` (``Γ(a, z)`` the upper incomplete gamma function, for every
real ``a``: normalisable for every real ``τ`` and ``x_c > 0``). It is the form of a finite-size
avalanche distribution (``P(S) ∝ S^(−τ) f(S/S_c)``) with the simplest cut-off function, and
Clauset, Shalizi & Newman (SIAM Rev. 51, 661, 2009, Table 1) list it as the alternative to the
pure power law. Where the pure or truncated fit of :mod:`jamlab.analysis.powerlaw` lets the
cut-off bend the tail — the local exponent then rises with ``x_min`` — this model fits the bend.

Log-likelihood of ``n`` data in the tail, in ``y = x/x_min`` and ``y_c = x_c/x_min``:
``ℓ(τ, y_c) = −τ Σ log y_i − Σ y_i / y_c − n [(1−τ) log y_c + log Γ(1−τ, 1/y_c)] − n log x_min``.
The MLE is found in ``(τ, log y_c)`` (bounded search from several starts); the standard errors
are those of the inverse observed information (the Hessian of ``−ℓ`` by central differences).
``log Γ(a, z)`` (:func:`log_upper_gamma`): scipy's regularised function for ``a > 0``, ``E_1``
for ``a = 0``, the upward recurrence ``Γ(a, z) = (Γ(a+1, z) − z^a e^(−z))/a`` for ``a < 0``
(linear in ``a`` for ``|a| < 1e-5``, where the recurrence cancels), the asymptotic series for
``z > 50``; checked against ``mpmath`` in ``tests/analysis/test_cutoff_powerlaw.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, special

from jamlab import validation
from jamlab.analysis.likelihood_kernels import (
    ASYMPTOTIC_Z,
    SMALL_A,
    cutoff_log_norm,
    log_upper_gamma_value,
)
from jamlab.analysis.powerlaw import finite_data
from jamlab.threads import one_blas_thread

__all__ = [
    "CHI2_1_95",
    "DEFAULT_STRETCHES",
    "CutoffPowerLawFit",
    "CutoffShapeProfile",
    "cutoff_power_law_cdf",
    "cutoff_power_law_ks",
    "cutoff_power_law_log_norm",
    "cutoff_power_law_logpdf",
    "cutoff_shape_profile",
    "fit_cutoff_power_law",
    "log_upper_gamma",
    "log_upper_gamma_array",
    "sample_cutoff_power_law",
    "shape_free_interval",
    "shape_set",
]

FloatArray = NDArray[np.float64]

_MIN_TAIL = 10

TAU_BOUNDS = (-1.0, 5.0)
"""The search interval of ``τ`` in the cut-off fits; a fit on either end has no interior
maximum (``CutoffPowerLawFit.tau_at_bound``)."""


def log_upper_gamma(a: float, z: float) -> float:
    """``log Γ(a, z)`` for real ``a`` and ``z > 0`` (module docstring; compiled:
    :func:`jamlab.analysis.likelihood_kernels.log_upper_gamma_value`)."""
    if not (math.isfinite(a) and math.isfinite(z) and z > 0):
        raise ValueError(f"log_upper_gamma needs finite a and z > 0, got a={a!r}, z={z!r}")
    return log_upper_gamma_value(float(a), float(z))


def _scaled_upper_gamma_vec(a: float, z: FloatArray) -> FloatArray:
    """``Γ(a, z) e^z`` for an array ``0 < z ≤ 50`` (the branches of the scalar version)."""
    if 0.0 < abs(a) < SMALL_A:
        edge = math.copysign(SMALL_A, a)
        g0, g1 = _scaled_upper_gamma_vec(0.0, z), _scaled_upper_gamma_vec(edge, z)
        return g0 + (g1 - g0) * (a / edge)
    if a > 0:
        return special.gammaincc(a, z) * special.gamma(a) * np.exp(z)
    if a == 0:
        return special.exp1(z) * np.exp(z)
    return (_scaled_upper_gamma_vec(a + 1.0, z) - z**a) / a


def log_upper_gamma_array(a: float, z: ArrayLike) -> FloatArray:
    """:func:`log_upper_gamma` for an array of ``z > 0``."""
    z = np.asarray(z, dtype=np.float64)
    if not (math.isfinite(a) and np.all(np.isfinite(z)) and np.all(z > 0)):
        raise ValueError("log_upper_gamma_array needs finite a and z > 0")
    out = np.empty_like(z)
    big = z > ASYMPTOTIC_Z
    if big.any():
        zb = z[big]
        term = np.ones_like(zb)
        total = np.ones_like(zb)
        for k in range(1, 13):
            term = term * (a - k) / zb
            total += term
        out[big] = (a - 1.0) * np.log(zb) - zb + np.log(total)
    if (~big).any():
        zs = z[~big]
        out[~big] = np.log(_scaled_upper_gamma_vec(a, zs)) - zs
    return out


def cutoff_power_law_cdf(x: ArrayLike, tau: float, x_c: float, x_min: float, *,
                         stretch: float = 1.0) -> FloatArray:
    """``P(X ≤ x) = 1 − Γ(1−τ, x/x_c) / Γ(1−τ, x_min/x_c)`` (0 below ``x_min``); with a stretched
    cut-off ``e^(−(x/x_c)^a)`` (``stretch = a``) ``1 − Γ(k, (x/x_c)^a) / Γ(k, (x_min/x_c)^a)``,
    ``k = (1−τ)/a``; 1 at ``x = inf``, NaN at NaN."""
    _check_model(tau, x_c, x_min)
    _check_stretch(stretch)
    x = np.asarray(x, dtype=np.float64)
    finite = np.isfinite(x)
    above = np.where(finite, np.maximum(x, x_min), x_min)
    if stretch == 1.0:
        a = 1.0 - tau
        tail = np.exp(log_upper_gamma_array(a, above / x_c) - log_upper_gamma(a, x_min / x_c))
    else:
        k = (1.0 - tau) / stretch
        tail = np.exp(log_upper_gamma_array(k, (above / x_c) ** stretch)
                      - log_upper_gamma(k, (x_min / x_c) ** stretch))
    cdf = np.where(x >= x_min, 1.0 - tail, 0.0)
    return np.where(finite, cdf, np.where(np.isnan(x), np.nan, (x > 0) * 1.0))


def _check_model(tau: float, x_c: float, x_min: float) -> None:
    if not (math.isfinite(tau) and math.isfinite(x_c) and x_c > 0
            and math.isfinite(x_min) and x_min > 0):
        raise ValueError(f"need finite tau, x_c > 0 and x_min > 0, got tau={tau!r}, "
                         f"x_c={x_c!r}, x_min={x_min!r}")


def _check_stretch(stretch: float) -> None:
    if not (math.isfinite(stretch) and stretch > 0):
        raise ValueError(f"stretch must be finite and > 0, got {stretch!r}")


def _check_x_min(x_min: float) -> float:
    """A given ``x_min`` as a float: any real number (not a bool), finite and > 0."""
    if not (validation.is_real(x_min) and math.isfinite(x_min) and x_min > 0):
        raise ValueError(f"x_min must be finite and > 0, got {x_min!r}")
    return float(x_min)


def cutoff_power_law_log_norm(tau: float, x_c: float, x_min: float, stretch: float = 1.0
                              ) -> float:
    """``log Z = (1−τ) log x_c + log Γ(1−τ, x_min/x_c)``: ``log p(x) = −τ log x − x/x_c − log Z``
    (parameters not checked; :func:`cutoff_power_law_logpdf` checks them). With a stretched
    cut-off ``e^(−(x/x_c)^a)`` (``stretch = a > 0``; ``u = (x/x_c)^a``):
    ``log Z = (1−τ) log x_c − log a + log Γ((1−τ)/a, (x_min/x_c)^a)``, the same for ``a = 1``."""
    return cutoff_log_norm(float(tau), float(x_c), float(x_min), float(stretch))


def cutoff_power_law_logpdf(x: ArrayLike, tau: float, x_c: float, x_min: float,
                            stretch: float = 1.0) -> FloatArray:
    """``log p(x)`` of the model (``−inf`` below ``x_min``); ``stretch = a``: the cut-off
    ``e^(−(x/x_c)^a)``, ``log p = −τ log x − (x/x_c)^a − log Z``; ``−inf`` at ``x = inf``, NaN
    at NaN."""
    _check_model(tau, x_c, x_min)
    _check_stretch(stretch)
    x = np.asarray(x, dtype=np.float64)
    log_z = cutoff_power_law_log_norm(tau, x_c, x_min, stretch)
    with np.errstate(divide="ignore", invalid="ignore"):
        cut = x / x_c if stretch == 1.0 else (x / x_c) ** stretch
        out = -tau * np.log(x) - cut - log_z
    inside = np.isfinite(x) & (x >= x_min)  # −inf at x = inf, where −τ log x − x/x_c can be NaN
    return np.where(inside, out, np.where(np.isnan(x), np.nan, -np.inf))


def sample_cutoff_power_law(
    n: int, tau: float, x_c: float, x_min: float, rng: np.random.Generator, *,
    stretch: float = 1.0,
) -> FloatArray:
    """``n`` draws from the model (``τ ≥ 0``), by rejection: from the pure power law accepted
    with ``e^(−(x − x_min)/x_c)`` when ``τ > 1``, else from ``x_min`` + an exponential of mean
    ``x_c`` accepted with ``(x/x_min)^(−τ)``. ``stretch = a ≠ 1``: the cut-off
    ``e^(−(x/x_c)^a)`` (``τ > 1`` only; the pure power law accepted with
    ``e^(−(x/x_c)^a + (x_min/x_c)^a)``)."""
    _check_model(tau, x_c, x_min)
    if tau < 0:
        raise ValueError(f"sample_cutoff_power_law needs tau >= 0, got {tau!r}")
    stretch = float(stretch)
    _check_stretch(stretch)
    if stretch != 1.0 and tau <= 1:
        raise ValueError(f"a stretched cut-off is sampled for tau > 1 only, got tau={tau!r}")
    out: list[FloatArray] = []
    have = 0
    while have < n:
        m = max(2 * (n - have), 64)
        if stretch != 1.0:
            y = rng.random(m) ** (-1.0 / (tau - 1.0))
            u_min = (x_min / x_c) ** stretch
            keep = rng.random(m) < np.exp(u_min - u_min * y**stretch)
        elif tau > 1:
            y = rng.random(m) ** (-1.0 / (tau - 1.0))
            keep = rng.random(m) < np.exp(-(y - 1.0) * (x_min / x_c))
        else:
            y = 1.0 + rng.exponential(x_c / x_min, m)
            keep = rng.random(m) < y ** (-tau)
        got = x_min * y[keep]
        out.append(got)
        have += got.size
    return np.concatenate(out)[:n]


@dataclass(frozen=True)
class CutoffPowerLawFit:
    """Result of :func:`fit_cutoff_power_law`: ``tau`` and ``x_c`` with their asymptotic
    standard errors (``x_c_stderr`` of ``x_c`` itself, from that of ``log x_c``), the fixed
    ``x_min``, ``n_tail`` data at or above it, the maximised ``loglik``; the bootstrap percentile
    interval ``ci_low``/``ci_high`` of ``tau`` at ``ci_level`` over ``n_boot`` resamples (NaN
    without). ``at_bound`` is True when ``x_c`` ended on its search bound (``x_c`` beyond
    ``e^7`` times the largest datum: no cut-off resolved, and its error is meaningless).
    ``ks_distance``: Kolmogorov–Smirnov distance between the tail and the fitted model;
    ``x_min_fixed``: whether ``x_min`` was given (else chosen by the KS rule);
    ``tau_at_bound``: ``τ`` ended on an end of its search interval :data:`TAU_BOUNDS` (no
    interior maximum: the data do not fix ``τ``, and its value is the bound's)."""

    tau: float
    tau_stderr: float
    x_c: float
    x_c_stderr: float
    x_min: float
    n_tail: int
    loglik: float
    at_bound: bool
    ks_distance: float = math.nan
    x_min_fixed: bool = True
    ci_low: float = math.nan
    ci_high: float = math.nan
    ci_level: float = math.nan
    n_boot: int = 0
    tau_at_bound: bool = False


def _nll(params: NDArray, log_y: FloatArray, y: FloatArray) -> float:
    tau, log_yc = float(params[0]), float(params[1])
    yc = math.exp(log_yc)
    n = y.size
    log_z = (1.0 - tau) * log_yc + log_upper_gamma(1.0 - tau, 1.0 / yc)
    return tau * float(log_y.sum()) + float(y.sum()) / yc + n * log_z


def _nll_stretched(params: NDArray, log_y: FloatArray, y: FloatArray, stretch: float,
                   sum_ya: float) -> float:
    """``−ℓ`` (without ``n log x_min``) with the cut-off ``e^(−(y/y_c)^a)``, ``a = stretch``,
    ``sum_ya = Σ y^a``; normaliser :func:`cutoff_power_law_log_norm` at ``x_min = 1``."""
    tau, log_yc = float(params[0]), float(params[1])
    log_z = cutoff_power_law_log_norm(tau, math.exp(log_yc), 1.0, stretch)
    return (tau * float(log_y.sum()) + sum_ya * math.exp(-stretch * log_yc)
            + y.size * log_z)


def tail_objective(y: FloatArray, log_y: FloatArray, stretch: float) -> tuple:
    """``(−ℓ, its extra arguments after the parameters)`` for the cut-off's shape ``stretch``
    (``_nll`` itself for the exponential one): ``fun(np.array([τ, log y_c]), *args)`` is
    ``−ℓ`` of the tail data ``y = x / x_min ≥ 1`` without ``n log x_min``."""
    if stretch == 1.0:
        return _nll, (log_y, y)
    return _nll_stretched, (log_y, y, stretch, float(np.sum(y**stretch)))


def log_yc_bounds(y: FloatArray, stretch: float = 1.0) -> tuple[float, float]:
    """The search bounds of ``log y_c`` for tail data ``y ≥ 1``: ``−3/a`` to
    ``log max y + 7/a`` (those of the exponential cut-off in ``(y/y_c)^a``)."""
    return -3.0 / stretch, math.log(float(y.max())) + 7.0 / stretch


def _mle(y: FloatArray, stretch: float = 1.0) -> tuple[float, float, float, bool, NDArray]:
    """``(τ, log y_c, −ℓ (without n log x_min), at_bound, bounds)`` for tail data ``y ≥ 1``;
    ``stretch = a``: the cut-off ``e^(−(y/y_c)^a)`` (the bounds of ``log y_c`` are those of the
    exponential one in ``(y/y_c)^a``, the same numbers at ``a = 1``)."""
    log_y = np.log(y)
    lo, hi = log_yc_bounds(y, stretch)
    bounds = np.array([TAU_BOUNDS, [lo, hi]])
    mean_log = float(log_y.mean())
    tau0 = 1.0 + 1.0 / mean_log if mean_log > 0 else 1.5
    fun, args = tail_objective(y, log_y, stretch)
    best = None
    for log_yc0 in (math.log(float(y.max())), math.log(float(np.median(y))) + 2.0,
                    hi - 1.0 / stretch):
        start = np.clip([min(max(tau0, 0.0), 3.0), log_yc0], bounds[:, 0] + 1e-6,
                        bounds[:, 1] - 1e-6)
        with one_blas_thread():  # jamlab.threads: ~11x faster on busy cores, same numbers
            r = optimize.minimize(fun, start, args=args, method="L-BFGS-B", bounds=bounds,
                                  options={"ftol": 1e-15, "gtol": 1e-10, "maxiter": 2000})
        if best is None or r.fun < best.fun:
            best = r
    at_bound = bool(best.x[1] > hi - 1e-3)
    return float(best.x[0]), float(best.x[1]), float(best.fun), at_bound, bounds


def _stderr(tau: float, log_yc: float, y: FloatArray, stretch: float = 1.0
            ) -> tuple[float, float]:
    """Standard errors of ``τ`` and ``log y_c`` from the observed information."""
    log_y = np.log(y)
    fun, args = tail_objective(y, log_y, stretch)
    p0 = np.array([tau, log_yc])
    h = np.array([1e-4, 1e-3])
    hess = np.empty((2, 2))
    for i in range(2):
        for j in range(2):
            ei, ej = np.eye(2)[i] * h[i], np.eye(2)[j] * h[j]
            hess[i, j] = (fun(p0 + ei + ej, *args) - fun(p0 + ei - ej, *args)
                          - fun(p0 - ei + ej, *args) + fun(p0 - ei - ej, *args)) / (
                4 * h[i] * h[j])
    try:
        cov = np.linalg.inv(hess)
    except np.linalg.LinAlgError:
        return math.nan, math.nan
    var = np.diag(cov)
    if not np.all(var > 0):
        return math.nan, math.nan
    return float(math.sqrt(var[0])), float(math.sqrt(var[1]))


def cutoff_power_law_ks(x: ArrayLike, tau: float, x_c: float, x_min: float) -> float:
    """Kolmogorov–Smirnov distance between the data ``x`` (all at or above ``x_min``) and the
    model: ``max_i max(i/n − F(x_(i)), F(x_(i)) − (i−1)/n)`` over the sorted data.
    ``ValueError`` for no data, NaN/inf data or data below ``x_min``."""
    _check_model(tau, x_c, x_min)
    x = finite_data(x)
    if x.size == 0:
        raise ValueError("the data are empty: a KS distance needs at least one datum")
    if x.min() < x_min:
        raise ValueError(f"the data hold {float(x.min())!r}, below x_min={x_min!r}: all must "
                         "be at or above it")
    return _ks(np.sort(x), tau, x_c, x_min)


def _ks(tail: FloatArray, tau: float, x_c: float, x_min: float) -> float:
    """:func:`cutoff_power_law_ks` of data already sorted."""
    cdf = cutoff_power_law_cdf(tail, tau, x_c, x_min)
    n = tail.size
    return float(max(np.max(np.arange(1, n + 1) / n - cdf), np.max(cdf - np.arange(n) / n)))


def _fit_at(tail_sorted: FloatArray, x_min: float) -> tuple[float, float, float, bool, float]:
    """``(τ, x_c, −ℓ, at_bound, KS distance)`` on the sorted data at or above ``x_min``."""
    t = tail_sorted[tail_sorted >= x_min]
    y = t / x_min
    tau, log_yc, nll, at_bound, _ = _mle(y)
    x_c = x_min * math.exp(log_yc)
    return tau, x_c, nll + t.size * math.log(x_min), at_bound, _ks(t, tau, x_c, x_min)


def _choose(xs: FloatArray, min_tail: int, max_candidates: int) -> tuple[float, tuple]:
    """The KS rule on sorted data: the candidate ``x_min`` (data values leaving at least
    ``min_tail`` in the tail, at most ``max_candidates`` spread geometrically in tail size)
    whose fit is closest to its tail."""
    k_max = xs.size - min_tail  # candidate index k leaves xs.size - k data
    ks_idx = np.unique(np.geomspace(1, k_max + 1, max_candidates).astype(np.intp) - 1)
    best = None
    for k in ks_idx:
        fit = _fit_at(xs, float(xs[k]))
        if best is None or fit[4] < best[1][4]:
            best = (float(xs[k]), fit)
    return best


def _check_spread(tail: FloatArray, x_min: float) -> None:
    """``ValueError`` when the tail holds a single value: no exponent can be fitted to it."""
    if tail.size and float(tail.min()) == float(tail.max()):
        raise ValueError(f"every datum at or above x_min={x_min:g} equals {float(tail[0]):g}: "
                         "a single value fixes no exponent")


def fit_cutoff_power_law(
    x: ArrayLike, x_min: float | None = None, *, min_tail: int = 50,
    max_candidates: int = 40, n_boot: int = 0, ci_level: float = 0.95, seed: int = 0,
) -> CutoffPowerLawFit:
    """Fit ``p(x) ∝ x^(−τ) e^(−x/x_c)`` to the data ``x ≥ x_min`` by maximum likelihood (module
    docstring). ``x_min`` None: chosen by the KS rule of Clauset et al. with this model (the
    candidate — a data value leaving at least ``min_tail`` data, at most ``max_candidates`` of
    them spread geometrically in tail size — whose fit has the smallest KS distance to its tail).
    ``n_boot > 0``: percentile bootstrap interval of ``τ`` (all the data resampled with
    replacement and the whole fit redone, the choice of ``x_min`` included when it was free;
    ``numpy.random.default_rng(seed)``). Raises ValueError for non-finite data, a bad ``x_min``
    or too few data at or above it (10 when given, ``min_tail`` when chosen)."""
    x = np.asarray(x, dtype=np.float64).ravel()
    if not np.all(np.isfinite(x)):
        raise ValueError("the data hold NaN or inf")
    fixed = x_min is not None
    if fixed:
        x_min = _check_x_min(x_min)
    n_boot = validation.integer("n_boot", n_boot, minimum=0)
    min_tail = validation.integer("min_tail", min_tail, minimum=_MIN_TAIL)
    max_candidates = validation.integer("max_candidates", max_candidates, minimum=1)
    seed = validation.seed("seed", seed)
    if not 0 < ci_level < 1:
        raise ValueError(f"ci_level must lie in (0, 1), got {ci_level!r}")
    xs = np.sort(x[x > 0])
    if fixed:
        need = _MIN_TAIL
        n_tail = int(np.count_nonzero(xs >= x_min))
        if n_tail < need:
            raise ValueError(f"need at least {need} data at or above x_min={x_min:g}, "
                             f"got {n_tail}")
        _check_spread(xs[xs >= x_min], x_min)
        fit = _fit_at(xs, float(x_min))
    else:
        if xs.size < min_tail + 1:
            raise ValueError(f"need more than min_tail={min_tail} positive data to choose "
                             f"x_min, got {xs.size}")
        x_min, fit = _choose(xs, min_tail, max_candidates)
    tau, x_c, nll, at_bound, ks = fit
    tail = xs[xs >= x_min]
    se_tau, se_log = _stderr(tau, math.log(x_c / x_min), tail / x_min)
    lo = hi = math.nan
    if n_boot:
        rng = np.random.default_rng(seed)
        taus = []
        for _ in range(n_boot):
            b = np.sort(rng.choice(xs, xs.size))
            if fixed:
                yb = b[b >= x_min] / x_min
                taus.append(_mle(yb)[0] if yb.size >= _MIN_TAIL else math.nan)
            else:
                taus.append(_choose(b, min_tail, max_candidates)[1][0])
        q = (1.0 - ci_level) / 2.0
        lo, hi = (float(v) for v in np.nanquantile(np.array(taus), [q, 1.0 - q]))
    return CutoffPowerLawFit(
        tau=tau,
        tau_stderr=se_tau,
        x_c=x_c,
        x_c_stderr=x_c * se_log,
        x_min=float(x_min),
        n_tail=int(tail.size),
        loglik=-nll,
        at_bound=at_bound,
        ks_distance=ks,
        x_min_fixed=fixed,
        ci_low=lo,
        ci_high=hi,
        tau_at_bound=not TAU_BOUNDS[0] + 1e-6 < tau < TAU_BOUNDS[1] - 1e-6,
        ci_level=float(ci_level) if n_boot else math.nan,
        n_boot=int(n_boot),
    )


#: The default grid of cut-off shapes ``a`` of :func:`cutoff_shape_profile`.
DEFAULT_STRETCHES = (0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7, 0.85, 1.0, 1.25, 1.5, 2.0)

#: ``χ²₁`` 95 % point: the profile set of ``a`` (and the ``τ`` it allows) is
#: ``2 (ℓ_max − ℓ(a)) ≤ 3.84``.
CHI2_1_95 = 3.841458820694124


def shape_free_interval(taus: ArrayLike, tau_stderrs: ArrayLike, logliks: ArrayLike
                        ) -> tuple[float, float]:
    """The 95 % profile-likelihood interval of ``τ`` with the cut-off's shape free, from fits at
    fixed shapes ``a`` (one entry per ``a``: the MLE ``τ_a``, its standard error ``σ_a`` and the
    maximised log-likelihood ``ℓ(a)``): with ``ℓ`` quadratic in ``τ`` at each ``a``, the union
    over the ``a`` with ``2 (ℓ_max − ℓ(a)) ≤ 3.84`` of ``τ_a ± σ_a √(3.84 − 2 (ℓ_max − ℓ(a)))``
    (a non-finite ``σ_a`` reaches no further than ``τ_a``) — the statistical error and the
    spread the shape leaves open, together. ``ValueError`` for arrays of unequal or zero length
    or a non-finite ``ℓ``."""
    t = np.asarray(taus, dtype=np.float64).ravel()
    se = np.asarray(tau_stderrs, dtype=np.float64).ravel()
    ll = np.asarray(logliks, dtype=np.float64).ravel()
    if not (t.size == se.size == ll.size and t.size > 0):
        raise ValueError(f"need equal non-empty arrays, got sizes {t.size}, {se.size}, {ll.size}")
    if not np.all(np.isfinite(ll)):
        raise ValueError("the log-likelihoods must be finite")
    best = float(ll.max())
    lows, highs = [], []
    for i in shape_set(ll):
        reach = se[i] * math.sqrt(CHI2_1_95 - 2.0 * (best - ll[i])) if math.isfinite(se[i]) else 0.0
        lows.append(float(t[i] - reach))
        highs.append(float(t[i] + reach))
    return min(lows), max(highs)


def shape_set(logliks: ArrayLike) -> list[int]:
    """The indices of the shapes in the 95 % profile set, ``2 (ℓ_max − ℓ(a)) ≤ 3.84``, of fits
    at fixed shapes ``a`` with maximised log-likelihoods ``logliks``."""
    ll = np.asarray(logliks, dtype=np.float64).ravel()
    best = float(ll.max())
    return [i for i, v in enumerate(ll.tolist()) if 2.0 * (best - v) <= CHI2_1_95]


@dataclass(frozen=True)
class CutoffShapeProfile:
    """Result of :func:`cutoff_shape_profile` at the fixed ``x_min`` (``n_tail`` data at or
    above it). Per cut-off shape ``a`` of ``stretches``: the MLE ``taus``, ``x_cs``, the
    maximised ``logliks``, ``tau_stderrs`` (observed information at fixed ``a``) and
    ``at_bound`` (``x_c`` on its upper search bound: no cut-off resolved). ``best``: the ``a`` of
    the largest log-likelihood ``ℓ_max`` on the grid (``at_edge`` when it is an end of the grid:
    the maximum may lie beyond), ``tau_best`` ± ``tau_best_stderr`` the fit there.
    ``lr_exponential = 2 (ℓ_max − ℓ(a = 1))``: the likelihood-ratio statistic against the
    exponential cut-off (``χ²₁`` under it; NaN when 1 is not on the grid). ``a_low``, ``a_high``:
    the grid points with ``2 (ℓ_max − ℓ(a)) ≤ 3.84``, the profile-likelihood 95 % set of the
    shape. ``tau_low``, ``tau_high``: the 95 % profile-likelihood interval of ``τ`` with the
    shape and ``x_c`` free, ``{τ : 2 (ℓ_max − max_(a, x_c) ℓ(τ, a, x_c)) ≤ 3.84}``, with
    ``ℓ`` quadratic in ``τ`` at each ``a`` of the grid: the union over ``a`` of
    ``τ_a ± σ_a √(3.84 − 2 (ℓ_max − ℓ(a)))`` — the statistical error and the spread the
    cut-off's shape leaves open, together."""

    x_min: float
    n_tail: int
    stretches: tuple[float, ...]
    taus: tuple[float, ...]
    x_cs: tuple[float, ...]
    logliks: tuple[float, ...]
    tau_stderrs: tuple[float, ...]
    at_bound: tuple[bool, ...]
    best: float
    at_edge: bool
    tau_best: float
    tau_best_stderr: float
    lr_exponential: float
    a_low: float
    a_high: float
    tau_low: float
    tau_high: float


def cutoff_shape_profile(x: ArrayLike, x_min: float,
                         stretches: tuple[float, ...] = DEFAULT_STRETCHES
                         ) -> CutoffShapeProfile:
    """Profile likelihood of the cut-off's shape at a fixed ``x_min``: for each ``a`` of
    ``stretches`` the maximum-likelihood ``τ`` and ``x_c`` of
    ``p(x) ∝ x^(−τ) e^(−(x/x_c)^a)`` on ``[x_min, ∞)`` (normaliser
    :func:`cutoff_power_law_log_norm`; ``a = 1`` is exactly :func:`fit_cutoff_power_law`'s fit),
    and what the data say about ``a`` and, through it, about ``τ`` (:class:`CutoffShapeProfile`).
    ``τ`` and ``a`` trade off — a smaller ``a`` bends the tail over more decades, a smaller ``τ``
    compensates — so an exponent fitted with one assumed shape carries this spread as a
    systematic error. ``ValueError`` for non-finite data, a bad ``x_min``, fewer than 10 data at
    or above it, or a grid with a non-positive, non-finite or repeated ``a``."""
    x = np.asarray(x, dtype=np.float64).ravel()
    if not np.all(np.isfinite(x)):
        raise ValueError("the data hold NaN or inf")
    x_min = _check_x_min(x_min)
    grid = tuple(float(a) for a in stretches)
    if not grid or not all(math.isfinite(a) and a > 0 for a in grid) or len(set(grid)) < len(grid):
        raise ValueError(f"stretches must be distinct finite numbers > 0, got {stretches!r}")
    grid = tuple(sorted(grid))
    tail = np.sort(x[x >= x_min])
    if tail.size < _MIN_TAIL:
        raise ValueError(f"need at least {_MIN_TAIL} data at or above x_min={x_min:g}, "
                         f"got {tail.size}")
    _check_spread(tail, x_min)
    y = tail / x_min
    log_x_min = math.log(x_min)
    fits = [_mle(y, a) for a in grid]
    taus = tuple(f[0] for f in fits)
    x_cs = tuple(x_min * math.exp(f[1]) for f in fits)
    ll = tuple(-f[2] - tail.size * log_x_min for f in fits)
    ses = tuple(_stderr(f[0], f[1], y, a)[0] for f, a in zip(fits, grid, strict=True))
    k = int(np.argmax(ll))
    inside = shape_set(ll)
    lr = 2.0 * (ll[k] - ll[grid.index(1.0)]) if 1.0 in grid else math.nan
    tau_low, tau_high = shape_free_interval(taus, ses, ll)
    return CutoffShapeProfile(
        x_min=float(x_min), n_tail=int(tail.size), stretches=grid, taus=taus, x_cs=x_cs,
        logliks=ll, tau_stderrs=ses, at_bound=tuple(f[3] for f in fits), best=grid[k],
        at_edge=k in (0, len(grid) - 1), tau_best=taus[k], tau_best_stderr=ses[k],
        lr_exponential=lr, a_low=grid[min(inside)], a_high=grid[max(inside)],
        tau_low=tau_low, tau_high=tau_high)
