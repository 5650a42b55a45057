"""Power-law fits by maximum likelihood with a Kolmogorov–Smirnov lower cut-off.

Reference: A. Clauset, C. R. Shalizi and M. E. J. Newman, "Power-law distributions in empirical
data", SIAM Rev. 51, 661 (2009), sections 3 (MLE), 3.3 (choice of x_min) and 4.1 (goodness of fit).

Two continuous models, both with density ``p(x) ∝ x^(−τ)``:

- **pure** on ``[x_min, ∞)``: ``p(x) = (τ−1)/x_min · (x/x_min)^(−τ)`` (needs ``τ > 1``).
  MLE ``τ̂ = 1 + n / Σ log(x_i/x_min)``, standard error ``(τ̂−1)/√n``.
- **truncated** on ``[x_min, x_max]``: ``p(x) = x^(−τ)/Z``,
  ``Z = (x_max^(1−τ) − x_min^(1−τ))/(1−τ)`` (``= log(x_max/x_min)`` at ``τ = 1``), normalisable
  for every real ``τ``. With ``L = log(x_max/x_min)``, ``t_i = log(x_i/x_min)``, ``u = (1−τ)L``
  and ``h(u) = log((e^u − 1)/u)`` the log-likelihood is
  ``ℓ(τ) = −τ Σ t_i − n log x_min − n log L − n h(u)``; the MLE solves the score equation
  ``h'(u) = mean(t)/L`` (``h'`` increases from 0 to 1, so the root is unique), found by bracketed
  root finding in ``u`` (compiled: ``h'`` is
  :func:`jamlab.analysis.likelihood_kernels.truncated_score`); the standard error is
  ``1/(L √(n h''(u)))`` (inverse Fisher information).

Conventions are those of ``docs/analysis.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab import validation
from jamlab.analysis.likelihood_kernels import SERIES_U, truncated_score_root

__all__ = [
    "PowerLawFit",
    "finite_data",
    "fit_power_law",
    "mle_tau",
    "power_law_cdf",
    "power_law_gof",
    "power_law_loglik",
    "power_law_pdf",
    "sample_power_law",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PowerLawFit:
    """Result of a power-law fit.

    ``tau`` is the MLE of the exponent on ``[x_min, x_max]`` (``x_max = inf`` for the pure model),
    ``tau_stderr`` its asymptotic standard error (inverse Fisher information at the cut-offs),
    ``n_tail`` the number of data in ``[x_min, x_max]``, ``ks_distance`` the Kolmogorov–Smirnov
    distance between those data and the fitted model, ``loglik`` the total log-likelihood of those
    data. ``ci_low``/``ci_high`` are the bootstrap percentile interval of ``tau`` (NaN when no
    bootstrap was run), ``ci_level`` its level and ``n_boot`` the number of resamples.
    ``p_value`` is the Clauset semi-parametric goodness-of-fit p-value (NaN when not computed).
    ``method`` is ``"pure"`` or ``"truncated"``; ``x_min_fixed`` says whether ``x_min`` was given.
    """

    tau: float
    tau_stderr: float
    x_min: float
    x_max: float
    n_tail: int
    ks_distance: float
    loglik: float
    ci_low: float
    ci_high: float
    method: str
    ci_level: float = math.nan
    n_boot: int = 0
    p_value: float = math.nan
    n_gof: int = 0
    n_data: int = 0
    x_min_fixed: bool = False

    def pdf(self, x: ArrayLike) -> FloatArray:
        """Fitted density on ``[x_min, x_max]`` (zero outside), normalised to 1 over the tail."""
        return power_law_pdf(x, self.tau, self.x_min, _none_if_inf(self.x_max))

    def cdf(self, x: ArrayLike) -> FloatArray:
        """Fitted distribution function ``P(X ≤ x | x_min ≤ X ≤ x_max)``."""
        return power_law_cdf(x, self.tau, self.x_min, _none_if_inf(self.x_max))


def _none_if_inf(x_max: float) -> float | None:
    return None if math.isinf(x_max) else x_max


# ---------------------------------------------------------------------------------------------
# h(u) = log(expm1(u)/u) and its derivatives, stable for all real u


def _h(u: float) -> float:
    if abs(u) < SERIES_U:
        return u / 2 + u * u / 24 - u**4 / 2880
    if u > 0:
        # log((e^u − 1)/u) = u + log1p(−e^−u) − log u, no overflow for large u
        return u + math.log1p(-math.exp(-u)) - math.log(u)
    return math.log(-math.expm1(u)) - math.log(-u)


def _h2(u: float) -> float:
    """h''(u) = 1/u² − 1/(4 sinh²(u/2)), the variance of t/L under the model."""
    if abs(u) < SERIES_U:
        return 1 / 12 - u * u / 240 + u**4 / 6048
    if abs(u) > 700:
        return 1.0 / (u * u)
    return 1.0 / (u * u) - 0.25 / math.sinh(u / 2) ** 2


# ---------------------------------------------------------------------------------------------
# model functions


def _check_cutoffs(tau: float, x_min: float, x_max: float | None) -> None:
    if not math.isfinite(tau):
        raise ValueError(f"tau={tau!r} must be finite")
    if not (x_min > 0 and math.isfinite(x_min)):
        raise ValueError(f"x_min={x_min!r} must be positive and finite")
    if x_max is None:
        if not tau > 1:
            raise ValueError(f"tau={tau!r} must be > 1 for the pure power law (give x_max)")
    elif not (x_max > x_min and math.isfinite(x_max)):
        raise ValueError(f"x_max={x_max!r} must be finite and > x_min={x_min!r}")


def power_law_pdf(x: ArrayLike, tau: float, x_min: float, x_max: float | None = None) -> FloatArray:
    """Density of the pure (``x_max=None``) or truncated power law; zero outside the support
    (NaN at NaN points).

    Pure: ``p(x) = (τ−1)/x_min (x/x_min)^(−τ)`` on ``[x_min, ∞)``.
    Truncated: ``p(x) = x^(−τ) / Z`` on ``[x_min, x_max]``, ``Z = ∫ x^(−τ) dx`` over the support.
    """
    _check_cutoffs(tau, x_min, x_max)
    x = np.asarray(x, dtype=np.float64)
    t = np.log(np.where(x > 0, x, 1.0) / x_min)
    if x_max is None:
        logp = math.log((tau - 1) / x_min) - tau * t
        inside = x >= x_min
    else:
        big_l = math.log(x_max / x_min)
        logp = -tau * t - math.log(x_min) - math.log(big_l) - _h((1 - tau) * big_l)
        inside = (x >= x_min) & (x <= x_max)
    return np.where(np.isnan(x), np.nan, np.where(inside, np.exp(logp), 0.0))


def power_law_cdf(x: ArrayLike, tau: float, x_min: float, x_max: float | None = None) -> FloatArray:
    """Distribution function ``P(X ≤ x)`` of the pure or truncated power law.

    Pure: ``1 − (x/x_min)^(1−τ)``. Truncated, with ``s = log(x/x_min)/L`` and ``u = (1−τ)L``:
    ``(e^(us) − 1)/(e^u − 1)`` (``= s`` at ``τ = 1``), evaluated without overflow.
    """
    _check_cutoffs(tau, x_min, x_max)
    x = np.asarray(x, dtype=np.float64)
    t = np.log(np.clip(x, x_min, None) / x_min)
    if x_max is None:
        return -np.expm1((1 - tau) * t)
    big_l = math.log(x_max / x_min)
    s = np.clip(t / big_l, 0.0, 1.0)
    return _truncated_cdf_s(s, (1 - tau) * big_l)


def _truncated_cdf_s(s: FloatArray, u: float) -> FloatArray:
    if abs(u) < 1e-12:
        return s
    if u > 0:
        return (np.exp(u * (s - 1)) - math.exp(-u)) / -math.expm1(-u)
    return np.expm1(u * s) / math.expm1(u)


def power_law_loglik(x: ArrayLike, tau: float, x_min: float, x_max: float | None = None) -> float:
    """Total log-likelihood ``Σ log p(x_i)`` of the data inside ``[x_min, x_max]``.

    Data outside the support are ignored (they are not part of the fitted tail); NaN/inf data
    raise ``ValueError``.
    """
    _check_cutoffs(tau, x_min, x_max)
    x = finite_data(x)
    inside = x >= x_min if x_max is None else (x >= x_min) & (x <= x_max)
    return _loglik_tail(x[inside], tau, x_min, x_max)


def _loglik_tail(tail: FloatArray, tau: float, x_min: float, x_max: float | None) -> float:
    n = tail.size
    sum_t = float(np.sum(np.log(tail / x_min)))
    if x_max is None:
        return n * math.log((tau - 1) / x_min) - tau * sum_t
    big_l = math.log(x_max / x_min)
    return -tau * sum_t - n * (math.log(x_min) + math.log(big_l) + _h((1 - tau) * big_l))


def sample_power_law(
    tau: float,
    x_min: float,
    x_max: float | None = None,
    size: int | tuple[int, ...] = 1,
    seed: int | np.random.Generator = 0,
) -> FloatArray:
    """Draw from the pure or truncated power law by exact inversion of its distribution function.

    Pure: ``x = x_min (1−U)^(−1/(τ−1))``. Truncated: ``x = x_min e^(sL)`` with
    ``s = log(1 + U(e^u − 1))/u`` (``s = U`` at ``τ = 1``), ``U ~ Uniform[0, 1)``.
    ``seed`` is an int (a fresh ``numpy.random.default_rng(seed)``) or a Generator.
    """
    _check_cutoffs(tau, x_min, x_max)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    uniform = rng.random(size)
    if x_max is None:
        return x_min * (1.0 - uniform) ** (-1.0 / (tau - 1.0))
    big_l = math.log(x_max / x_min)
    u = (1 - tau) * big_l
    if abs(u) < 1e-12:
        s = uniform
    elif u > 0:
        s = 1 + np.log(uniform + (1 - uniform) * math.exp(-u)) / u
    else:
        s = np.log1p(uniform * math.expm1(u)) / u
    return np.clip(x_min * np.exp(s * big_l), x_min, x_max)


# ---------------------------------------------------------------------------------------------
# MLE at fixed cut-offs


def _mle_tail(tail: FloatArray, x_min: float, x_max: float | None) -> tuple[float, float]:
    """MLE of tau and its standard error for sorted data already restricted to the support."""
    n = tail.size
    sum_t = float(np.sum(np.log(tail / x_min)))
    if n == 0 or sum_t <= 0:
        return math.nan, math.nan
    if x_max is None:
        tau = 1.0 + n / sum_t
        return tau, (tau - 1.0) / math.sqrt(n)
    big_l = math.log(x_max / x_min)
    target = sum_t / (n * big_l)
    if not 0 < target < 1:
        return math.nan, math.nan
    # h' runs from 0 (u → −∞) to 1 (u → ∞): a bracket widened from [−8, 8], then Brent's method
    # (scipy's brentq, compiled: jamlab.analysis.likelihood_kernels.truncated_score_root)
    u = truncated_score_root(target, 1e-14, 4 * np.finfo(float).eps, 100)
    tau = 1.0 - u / big_l
    return tau, 1.0 / (big_l * math.sqrt(n * _h2(u)))


def mle_tau(x: ArrayLike, x_min: float, x_max: float | None = None) -> tuple[float, float]:
    """Maximum-likelihood exponent and its standard error at fixed cut-offs.

    Uses the data in ``[x_min, x_max]`` (``[x_min, ∞)`` when ``x_max`` is None). Pure model:
    ``τ̂ = 1 + n/Σ log(x_i/x_min)``, ``σ = (τ̂−1)/√n``. Truncated model: root of the score
    equation ``h'((1−τ)L) = mean(log(x/x_min))/L``, ``σ = 1/(L √(n h''))`` (module docstring).
    Returns ``(tau, stderr)``: ``(nan, nan)`` when there is no estimate (no data in the support,
    or all at ``x_min``). NaN/inf data raise ``ValueError``.
    """
    _check_cutoffs(2.0, x_min, x_max)
    x = finite_data(x)
    inside = x >= x_min if x_max is None else (x >= x_min) & (x <= x_max)
    return _mle_tail(np.sort(x[inside]), x_min, x_max)


def _ks_tail(tail: FloatArray, tau: float, x_min: float, x_max: float | None) -> float:
    """Two-sided KS distance between sorted ``tail`` and the model, ``max |F_n − P|``."""
    n = tail.size
    if x_max is None:
        cdf = -np.expm1((1 - tau) * np.log(tail / x_min))
    else:
        big_l = math.log(x_max / x_min)
        cdf = _truncated_cdf_s(np.log(tail / x_min) / big_l, (1 - tau) * big_l)
    # sup over x of |F_n − P| is reached just before or at a data point
    above = np.arange(1, n + 1) / n - cdf
    below = cdf - np.arange(n) / n
    return float(max(above.max(), below.max()))


# ---------------------------------------------------------------------------------------------
# x_min by minimum KS distance


def _candidates(xs: FloatArray, min_tail: int, max_candidates: int) -> NDArray[np.intp]:
    """Indices k (first occurrences of distinct values) of candidate x_min = xs[k].

    Candidates are spread geometrically in the tail size n − k, from n down to ``min_tail``, so
    both the body and the far tail are scanned with the same relative resolution.
    """
    n = xs.size
    if n < min_tail:
        return np.empty(0, dtype=np.intp)
    tail_sizes = np.unique(np.round(np.geomspace(n, min_tail, max_candidates)).astype(np.intp))
    ks = np.searchsorted(xs, xs[n - tail_sizes], side="left")
    ks = np.unique(ks)
    return ks[(n - ks) >= min_tail]


def _scan(
    xs: FloatArray,
    x_max: float | None,
    min_tail: int,
    max_candidates: int,
) -> tuple[float, float, float, int, float]:
    """Return (x_min, tau, stderr, n_tail, ks) minimising the KS distance over candidates."""
    best = (math.nan, math.nan, math.nan, 0, math.inf)
    for k in _candidates(xs, min_tail, max_candidates):
        x_min = float(xs[k])
        if x_max is not None and x_min >= x_max:
            continue
        tail = xs[k:]
        tau, err = _mle_tail(tail, x_min, x_max)
        if not math.isfinite(tau) or (x_max is None and tau <= 1):
            continue
        d = _ks_tail(tail, tau, x_min, x_max)
        if d < best[4]:
            best = (x_min, tau, err, tail.size, d)
    return best


def finite_data(x: ArrayLike, name: str = "data") -> FloatArray:
    """``x`` as a flat float64 array; ``ValueError`` naming ``name`` and the first NaN or inf
    (with its index in the flattened array) if it holds one."""
    x = np.asarray(x, dtype=np.float64).ravel()
    bad = ~np.isfinite(x)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"{name} holds NaN or inf: {float(x[i])!r} at flat index {i}")
    return x


def _prepare(x: ArrayLike, x_max: float | None) -> FloatArray:
    x = finite_data(x)
    x = x[x > 0]
    if x_max is not None:
        x = x[x <= x_max]
    return np.sort(x)


def _fit_sorted(
    xs: FloatArray,
    x_min: float | None,
    x_max: float | None,
    min_tail: int,
    max_candidates: int,
) -> tuple[float, float, float, int, float]:
    if x_min is None:
        return _scan(xs, x_max, min_tail, max_candidates)
    tail = xs[np.searchsorted(xs, x_min, side="left") :]
    tau, err = _mle_tail(tail, x_min, x_max)
    d = _ks_tail(tail, tau, x_min, x_max) if math.isfinite(tau) else math.nan
    return x_min, tau, err, tail.size, d


def fit_power_law(
    x: ArrayLike,
    *,
    x_min: float | None = None,
    x_max: float | None = None,
    min_tail: int = 50,
    max_candidates: int = 200,
    n_boot: int = 0,
    ci_level: float = 0.95,
    n_gof: int = 0,
    seed: int = 0,
) -> PowerLawFit:
    """Fit ``p(x) ∝ x^(−τ)`` by maximum likelihood (Clauset, Shalizi & Newman 2009).

    Model: pure on ``[x_min, ∞)`` when ``x_max`` is None, truncated to ``[x_min, x_max]``
    otherwise (use it when τ may be ≤ 1). Non-positive data and data above ``x_max`` are
    dropped; NaN/inf raise.

    ``x_min`` None: chosen by minimising the KS distance ``D = max_x |F_n(x) − P(x)|`` between the
    data in ``[x_min, x_max]`` and the model fitted to them, over candidate ``x_min`` among the
    distinct data values whose tail holds at least ``min_tail`` points (at most
    ``max_candidates`` of them, spread geometrically in tail size).

    ``n_boot > 0``: percentile bootstrap interval at level ``ci_level``: resample all the data
    with replacement ``n_boot`` times and redo the whole fit, including the choice of ``x_min``
    when it was free. ``n_gof > 0``: Clauset's semi-parametric goodness-of-fit p-value with
    ``n_gof`` synthetic data sets (:func:`power_law_gof`). Randomness comes from
    ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    x : array_like
        The data (e.g. avalanche sizes ``S = −ΔE``); any shape, flattened.
    x_min : float, optional
        Lower cut-off; None (default) chooses it by the KS rule above.
    x_max : float, optional
        Upper cut-off of the truncated model; None (default) fits the pure model (``τ > 1``).
    min_tail : int, default 50
        Fewest data in ``[x_min, x_max]`` a candidate ``x_min`` may leave (at least 2).
    max_candidates : int, default 200
        Most candidate values of ``x_min`` tried.
    n_boot : int, default 0
        Bootstrap resamples for the interval ``ci_low``, ``ci_high`` (0: none, NaN interval).
    ci_level : float, default 0.95
        Level of the bootstrap interval, in (0, 1).
    n_gof : int, default 0
        Synthetic data sets for the goodness-of-fit p-value (0: not computed, NaN).
    seed : int, default 0
        Seed of the bootstrap and goodness-of-fit resampling.

    Returns
    -------
    PowerLawFit
        ``tau`` and its asymptotic ``tau_stderr``, the cut-offs ``x_min``/``x_max``, ``n_tail``,
        the KS distance, the log-likelihood, the bootstrap interval and the p-value.

    Raises
    ------
    ValueError
        For NaN/inf data, bad cut-offs or options, or too few data in the tail: fewer than
        ``min_tail`` when ``x_min`` is chosen, fewer than 2 when it is given (``min_tail``
        bounds the candidates of the choice only).

    Examples
    --------
    With ``x_min`` given, the pure model's estimate is the closed form
    ``τ̂ = 1 + n / Σ log(x_i/x_min)``:

    >>> import numpy as np
    >>> from jamlab.analysis import fit_power_law, sample_power_law
    >>> x = sample_power_law(1.5, x_min=1.0, size=2000, seed=1)
    >>> fit = fit_power_law(x, x_min=1.0)
    >>> round(fit.tau, 3), fit.n_tail, fit.method
    (1.499, 2000, 'pure')
    >>> bool(np.isclose(fit.tau, 1 + x.size / np.log(x).sum(), rtol=1e-12))
    True

    Truncated at the largest value, ``x_min`` chosen by the KS rule, with a bootstrap interval:

    >>> fit = fit_power_law(x, x_max=float(x.max()), min_tail=100, n_boot=20, seed=0)
    >>> fit.method, bool(fit.ci_low < 1.5 < fit.ci_high)
    ('truncated', True)
    """
    min_tail = validation.integer("min_tail", min_tail, minimum=2)
    max_candidates = validation.integer("max_candidates", max_candidates, minimum=1)
    n_boot = validation.integer("n_boot", n_boot, minimum=0)
    n_gof = validation.integer("n_gof", n_gof, minimum=0)
    seed = validation.seed("seed", seed)
    if not 0 < ci_level < 1:
        raise ValueError(f"ci_level={ci_level} must be in (0, 1)")
    if x_min is not None:
        _check_cutoffs(2.0, x_min, x_max)
    elif x_max is not None and not (x_max > 0 and math.isfinite(x_max)):
        raise ValueError(f"x_max={x_max!r} must be positive and finite")
    xs = _prepare(x, x_max)
    found_min, tau, err, n_tail, d = _fit_sorted(xs, x_min, x_max, min_tail, max_candidates)
    if x_min is not None and n_tail < 2:
        where = f"[{x_min:g}, {x_max:g}]" if x_max is not None else f"x >= {x_min:g}"
        raise ValueError(f"{n_tail} datum in {where}: an exponent needs at least 2")
    if not math.isfinite(tau):
        raise ValueError(
            f"no valid fit: {xs.size} positive data, need a tail of at least min_tail={min_tail}"
        )
    tail = xs[np.searchsorted(xs, found_min, side="left") :]
    fit = PowerLawFit(
        tau=tau,
        tau_stderr=err,
        x_min=found_min,
        x_max=math.inf if x_max is None else float(x_max),
        n_tail=n_tail,
        ks_distance=d,
        loglik=_loglik_tail(tail, tau, found_min, x_max),
        ci_low=math.nan,
        ci_high=math.nan,
        method="pure" if x_max is None else "truncated",
        n_data=int(np.asarray(x).size),
        x_min_fixed=x_min is not None,
    )
    rng = np.random.default_rng(seed)
    if n_boot > 0:
        # Resample the full data set (not only the tail) so the spread includes the x_min choice
        taus = np.empty(n_boot)
        for i in range(n_boot):
            res = np.sort(rng.choice(xs, size=xs.size, replace=True))
            taus[i] = _fit_sorted(res, x_min, x_max, min_tail, max_candidates)[1]
        taus = taus[np.isfinite(taus)]
        alpha = (1 - ci_level) / 2
        lo, hi = np.quantile(taus, [alpha, 1 - alpha])
        fit = replace(fit, ci_low=float(lo), ci_high=float(hi), ci_level=ci_level, n_boot=n_boot)
    if n_gof > 0:
        p = power_law_gof(
            xs, fit, n_sims=n_gof, min_tail=min_tail, max_candidates=max_candidates, seed=rng
        )
        fit = replace(fit, p_value=p, n_gof=n_gof)
    return fit


def power_law_gof(
    x: ArrayLike,
    fit: PowerLawFit,
    *,
    n_sims: int = 200,
    min_tail: int = 50,
    max_candidates: int = 200,
    seed: int | np.random.Generator = 0,
) -> float:
    """Clauset et al. (2009, §4.1) semi-parametric bootstrap p-value of a power-law fit.

    Each synthetic set has the size of the data (positive values, at most ``x_max``): each point
    is, with probability ``n_tail/n``, drawn from the fitted model, otherwise drawn uniformly from
    the observed data outside ``[x_min, x_max]``. Each set is refitted exactly as the data were
    (free or fixed ``x_min``); ``p`` is the fraction of synthetic KS distances ≥ the observed one.
    Small ``p`` (Clauset: ``p ≤ 0.1``) rules the power law out.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    x_max = _none_if_inf(fit.x_max)
    _check_cutoffs(fit.tau, fit.x_min, x_max)
    xs = _prepare(x, x_max)
    body = xs[xs < fit.x_min]
    n = xs.size
    fixed_min = fit.x_min if fit.x_min_fixed else None
    d_obs = _fit_sorted(xs, fixed_min, x_max, min_tail, max_candidates)[4]
    exceed = 0
    done = 0
    for _ in range(n_sims):
        n_model = rng.binomial(n, fit.n_tail / n) if body.size else n
        synth = np.concatenate(
            [
                sample_power_law(fit.tau, fit.x_min, x_max, n_model, rng),
                rng.choice(body, size=n - n_model, replace=True) if body.size else [],
            ]
        )
        d = _fit_sorted(np.sort(synth), fixed_min, x_max, min_tail, max_candidates)[4]
        if math.isfinite(d):
            done += 1
            exceed += d >= d_obs
    return exceed / done if done else math.nan
