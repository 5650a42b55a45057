"""Finite-size scaling of avalanche sizes: ``⟨S⟩`` and the cut-off ``S_c`` against ``N``, the
exponent ``β`` of ``S_c ~ N^β`` and the collapse ``P(S) S^τ`` against ``S/N^β``.

Pure functions on arrays (``docs/analysis.md``, ``docs/criticality.md``). Input: for each system
size ``N`` the avalanche sizes of each sample (one array per sample, possibly empty), already
restricted to the avalanches one counts (e.g. plastic steps between jammed minima).

- Cut-off: ``S_c = ⟨S²⟩/⟨S⟩`` (:func:`cutoff_size`). For ``P(S) = S^(−τ) G(S/S*)`` with
  ``1 < τ < 2`` and a lower cut-off ``s_0 ≪ S*`` it is proportional to ``S*``.
- ``β``: weighted least squares of ``log S_c`` against ``log N`` with weights ``1/σ²``, ``σ`` the
  bootstrap standard deviation of ``log S_c`` over resamples of the *samples* at that ``N``
  (samples with replacement, their avalanches kept together); the error of ``β`` is the standard
  deviation of the same fit over those resamples, multiplied by ``√(χ²/dof)`` of the fit when that
  exceeds 1 (three sizes or more; the scatter of the cut-offs about the line shows the bootstrap
  errors too small — ``⟨S²⟩`` rests on the few largest avalanches, and a sample short of them also
  has a small bootstrap spread); its 95 % interval is ``β ± 1.96 σ_β``. On the synthetic ensembles
  of ``tests/analysis/test_finite_size.py`` (four sizes, 30 samples of ~20 avalanches) the bootstrap
  error alone covered the true ``β`` in 85 % of 100 trials, with the ``χ²`` factor in 94 %. The
  slope of ``log⟨S⟩`` is fitted the same way. Two sizes give a straight line through two points
  (no ``χ²``): ``β`` is then only as good as the two cut-offs and its interval is likely too
  narrow.
- Collapse: the density per avalanche ``P(S)`` at each ``N`` (log bins on one grid), then
  ``y = P(S) S^τ`` against ``x = S/N^β``. Its quality is the root-mean-square difference, in
  decades, between ``log10 y`` of every pair of sizes where their ``x`` ranges overlap (each curve
  interpolated linearly in ``log x``); 0 is a perfect collapse.
- Joint fit (:func:`fit_joint_scaling`): every avalanche at or above a floor ``s_N`` (one per
  ``N``) enters one likelihood, ``P(S | N) = S^(−τ) e^(−S/S*(N)) / Z`` on ``[s_N, ∞)`` with
  ``S*(N) = S*_ref (N/N_ref)^β`` and one ``τ`` for all ``N``
  (:mod:`jamlab.analysis.cutoff_powerlaw` for ``Z``; ``N_ref`` the geometric mean of the sizes,
  where ``S*_ref`` and ``β`` are least correlated). ``⟨S²⟩/⟨S⟩`` rests on the largest avalanche
  or two at each ``N``; the likelihood also weighs how the bulk of the distribution bends. The
  maximum is searched in ``(τ, log S*_ref, β)`` (bounded Nelder–Mead from several starts,
  compiled: :mod:`jamlab.analysis.likelihood_kernels`); the
  errors are bootstrap standard deviations over resamples of the samples at each ``N`` (their
  avalanches kept together, so correlations within a sample are respected), the 95 % intervals
  ``± 1.96`` of them (on the synthetic ensembles of ``tests/analysis/test_finite_size_joint.py``,
  20 samples per size, they held β in 93 % and τ in 88 % of 60 trials — slightly better than the
  percentile intervals, 88 % and 87 %; read them as ≈ 90 % intervals at that sample count).
  The cut-off's shape is a choice: ``stretch = a`` fits ``e^(−(S/S*)^a)`` instead (fixed ``a``;
  ``Z`` from :func:`~jamlab.analysis.cutoff_powerlaw.cutoff_power_law_log_norm`), and the
  maximised ``loglik`` over a grid of ``a`` is its profile likelihood. Near a slow crossover
  ``τ`` and ``a`` trade off against each other (``docs/criticality.md``), while ``β`` moves less.
  Whether the data hold a cut-off at all:
  ``cutoff_lr = 2 (ℓ − ℓ_pure)``, the likelihood ratio against the pure power law with one ``τ``
  (``S* = ∞`` at every ``N``); ``resolved`` when it exceeds 5.99, the 95 % point of ``χ²`` with two
  degrees of freedom (the cut-off and ``β``; under the pure law ``β`` is not identified and
  ``S* = ∞`` lies on the boundary, so the reference distribution is only approximate). Without a
  resolved cut-off ``β`` means nothing. ``at_bound``: a parameter ended on its search bound
  (``τ ∈ [−1, 5]``, ``log S*_ref`` up to ``log`` of 1100 (``e^7``) times the largest size,
  ``β ∈ [−3, 6]``).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab import validation
from jamlab.analysis.cutoff_powerlaw import shape_free_interval, shape_set
from jamlab.analysis.histograms import log_histogram
from jamlab.analysis.jackknife import jackknife_variance
from jamlab.analysis.likelihood_kernels import joint_nll, minimize_joint_nll
from jamlab.analysis.powerlaw import finite_data, mle_tau, power_law_loglik

__all__ = [
    "Collapse",
    "CutoffScaling",
    "JointScaling",
    "JointShapeFree",
    "collapse",
    "collapse_quality",
    "cutoff_size",
    "fit_cutoff_scaling",
    "fit_joint_scaling",
    "joint_shape_free",
    "joint_shape_profile",
]

FloatArray = NDArray[np.float64]

_Z_95 = 1.959963984540054
_CHI2_2_95 = 5.991464547107979  # 95 % point of χ² with 2 degrees of freedom


def cutoff_size(sizes: ArrayLike) -> float:
    """``S_c = ⟨S²⟩/⟨S⟩`` of the (positive) ``sizes``; NaN when empty, ``ValueError`` for a
    NaN, inf, zero or negative size."""
    s = finite_data(sizes, "sizes")
    if s.size == 0:
        return math.nan
    if np.any(s <= 0):
        i = int(np.argmax(s <= 0))
        raise ValueError(f"sizes must be positive, got {float(s[i])!r} at flat index {i}")
    return float(np.sum(s * s) / np.sum(s))


@dataclass(frozen=True, eq=False)
class CutoffScaling:
    """``⟨S⟩`` and ``S_c`` per ``N`` (``n``, ascending) with their bootstrap standard deviations
    (of the value, over resamples of samples), the avalanche and sample counts, and the fitted
    exponents: ``beta`` (``S_c ~ N^β``) with ``beta_err`` and ``beta_ci95``, ``mean_exponent``
    (``⟨S⟩ ~ N^b``) with ``mean_exponent_err``; ``n_boot`` resamples; ``chi2_dof`` of the ``β``
    fit (NaN with two sizes)."""

    n: NDArray[np.int64]
    mean: FloatArray
    mean_err: FloatArray
    cutoff: FloatArray
    cutoff_err: FloatArray
    avalanches: NDArray[np.int64]
    samples: NDArray[np.int64]
    beta: float
    beta_err: float
    beta_ci95: tuple[float, float]
    mean_exponent: float
    mean_exponent_err: float
    n_boot: int
    chi2_dof: float = math.nan

    def as_dict(self) -> dict[str, object]:
        """Plain numbers (JSON)."""
        return {
            "n": self.n.tolist(), "mean": self.mean.tolist(), "mean_err": self.mean_err.tolist(),
            "cutoff": self.cutoff.tolist(), "cutoff_err": self.cutoff_err.tolist(),
            "avalanches": self.avalanches.tolist(), "samples": self.samples.tolist(),
            "beta": self.beta, "beta_err": self.beta_err, "beta_ci95": list(self.beta_ci95),
            "mean_exponent": self.mean_exponent, "mean_exponent_err": self.mean_exponent_err,
            "n_boot": self.n_boot, "chi2_dof": None if math.isnan(self.chi2_dof) else self.chi2_dof,
        }


def _wls(log_n: FloatArray, log_y: FloatArray, w: FloatArray) -> tuple[float, float]:
    """Slope of the weighted least-squares line through ``(log_n, log_y)`` and its ``χ²/dof``
    (NaN without a degree of freedom)."""
    ok = np.isfinite(log_y) & np.isfinite(w) & (w > 0)
    if ok.sum() < 2:
        return math.nan, math.nan
    x, y, w = log_n[ok], log_y[ok], w[ok]
    xm = np.sum(w * x) / np.sum(w)
    ym = np.sum(w * y) / np.sum(w)
    sxx = np.sum(w * (x - xm) ** 2)
    if not sxx > 0:
        return math.nan, math.nan
    slope = float(np.sum(w * (x - xm) * (y - ym)) / sxx)
    dof = x.size - 2
    chi2 = float(np.sum(w * (y - ym - slope * (x - xm)) ** 2)) / dof if dof > 0 else math.nan
    return slope, chi2


def fit_cutoff_scaling(
    sizes_by_n: Mapping[int, Sequence[ArrayLike]],
    n_boot: int = 200,
    seed: int = 0,
) -> CutoffScaling:
    """``⟨S⟩``, ``S_c`` against ``N`` and the exponents ``β`` of ``S_c ~ N^β`` and of ``⟨S⟩``
    (module docstring). ``sizes_by_n[N]`` holds one array of sizes per sample. Sizes with no
    avalanche are dropped; ``ValueError`` with fewer than two sizes that have avalanches, or
    ``n_boot < 2``."""
    if not (validation.is_integer(n_boot) and n_boot >= 2):
        raise ValueError(f"n_boot must be an integer >= 2, got {n_boot!r}")
    per_n = {}
    for n, samples in sizes_by_n.items():
        arrs = [np.asarray(s, dtype=np.float64).ravel() for s in samples]
        if any(np.any(~(a > 0)) for a in arrs):
            raise ValueError(f"sizes at N = {n} must be positive")
        if sum(a.size for a in arrs):
            per_n[int(n)] = arrs
    ns = np.array(sorted(per_n), dtype=np.int64)
    if ns.size < 2:
        raise ValueError(f"need avalanches at two sizes N at least, have {ns.tolist()}")
    rng = np.random.default_rng(seed)
    mean = np.empty(ns.size)
    cut = np.empty(ns.size)
    boot_mean = np.empty((n_boot, ns.size))
    boot_cut = np.empty((n_boot, ns.size))
    counts, n_samples = [], []
    for k, n in enumerate(ns):
        arrs = per_n[int(n)]
        m = len(arrs)
        s1 = np.array([a.sum() for a in arrs])
        s2 = np.array([(a * a).sum() for a in arrs])
        c = np.array([a.size for a in arrs], dtype=np.float64)
        mean[k], cut[k] = s1.sum() / c.sum(), s2.sum() / s1.sum()
        picks = rng.integers(0, m, size=(n_boot, m))
        b1, b2, bc = s1[picks].sum(axis=1), s2[picks].sum(axis=1), c[picks].sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            boot_mean[:, k] = b1 / bc
            boot_cut[:, k] = b2 / b1
        counts.append(int(c.sum()))
        n_samples.append(m)
    log_n = np.log(ns.astype(np.float64))
    out = {}
    for name, value, boot in (("cut", cut, boot_cut), ("mean", mean, boot_mean)):
        log_boot = np.log(boot)
        sd = np.array([np.nanstd(col[np.isfinite(col)], ddof=1) if np.isfinite(col).sum() > 1
                       else math.nan for col in log_boot.T])
        w = 1.0 / np.where(sd > 0, sd, np.nan) ** 2
        if not np.all(np.isfinite(w)):  # one sample at some N: no spread; weigh all alike
            w = np.ones_like(log_n)
        slope, chi2 = _wls(log_n, np.log(value), w)
        slopes = np.array([_wls(log_n, row, w)[0] for row in log_boot])
        slopes = slopes[np.isfinite(slopes)]
        err = float(np.std(slopes, ddof=1)) if slopes.size > 1 else math.nan
        if math.isfinite(chi2) and chi2 > 1.0:
            err *= math.sqrt(chi2)
        out[name] = (slope, err, value * np.where(np.isfinite(sd), sd, math.nan), chi2)
    beta, beta_err, cut_err, chi2_cut = out["cut"]
    b_mean, b_mean_err, mean_err, _ = out["mean"]
    return CutoffScaling(
        n=ns, mean=mean, mean_err=mean_err, cutoff=cut, cutoff_err=cut_err,
        avalanches=np.array(counts, dtype=np.int64), samples=np.array(n_samples, dtype=np.int64),
        beta=beta, beta_err=beta_err,
        beta_ci95=(beta - _Z_95 * beta_err, beta + _Z_95 * beta_err),
        mean_exponent=b_mean, mean_exponent_err=b_mean_err, n_boot=n_boot, chi2_dof=chi2_cut,
    )


@dataclass(frozen=True, eq=False)
class Collapse:
    """The rescaled densities: per ``N``, ``x = S/N^β`` and ``y = P(S) S^τ`` (bin centres with at
    least ``min_count`` avalanches), ``tau``, ``beta``, and the quality (:func:`collapse_quality`,
    RMS in decades; NaN without overlap)."""

    tau: float
    beta: float
    x: dict[int, FloatArray]
    y: dict[int, FloatArray]
    quality: float


def _densities(
    sizes_by_n: Mapping[int, ArrayLike], bins_per_decade: int, min_count: int
) -> dict[int, tuple[FloatArray, FloatArray]]:
    pooled = {int(n): np.asarray(s, dtype=np.float64).ravel() for n, s in sizes_by_n.items()}
    pooled = {n: s for n, s in pooled.items() if s.size}
    if not pooled:
        raise ValueError("no avalanches")
    everything = np.concatenate(list(pooled.values()))
    lo, hi = float(everything.min()), float(everything.max())
    if hi <= lo:
        hi = lo * 10.0
    rng = (10 ** math.floor(math.log10(lo)), 10 ** math.ceil(math.log10(hi) + 1e-12))
    out = {}
    for n, s in sorted(pooled.items()):
        h = log_histogram(s, bins_per_decade, range=rng)
        ok = h.counts >= min_count
        out[n] = (h.centres[ok], h.density[ok])
    return out


def _quality(curves: Mapping[int, tuple[FloatArray, FloatArray]]) -> float:
    sq = []
    for (_, (xa, ya)), (_, (xb, yb)) in itertools.permutations(curves.items(), 2):
        if xa.size < 1 or xb.size < 2:
            continue
        la, lb = np.log10(xa), np.log10(xb)
        inside = (la >= lb.min()) & (la <= lb.max())
        if inside.any():
            yb_at = np.interp(la[inside], lb, np.log10(yb))
            sq.append((np.log10(ya[inside]) - yb_at) ** 2)
    if not sq:
        return math.nan
    return float(math.sqrt(np.mean(np.concatenate(sq))))


def _rescale(dens, tau: float, beta: float) -> dict[int, tuple[FloatArray, FloatArray]]:
    return {n: (c / float(n) ** beta, d * c**tau) for n, (c, d) in dens.items()}


def collapse(
    sizes_by_n: Mapping[int, ArrayLike],
    tau: float,
    beta: float,
    bins_per_decade: int = 5,
    min_count: int = 3,
) -> Collapse:
    """``P(S) S^τ`` against ``S/N^β`` for the sizes pooled at each ``N`` (``sizes_by_n[N]``: all
    avalanches at that ``N``), on log bins of one grid, ``bins_per_decade`` per decade, keeping bins
    with ``≥ min_count`` avalanches; with its quality (module docstring)."""
    curves = _rescale(_densities(sizes_by_n, bins_per_decade, min_count), tau, beta)
    return Collapse(tau=float(tau), beta=float(beta), x={n: c[0] for n, c in curves.items()},
                    y={n: c[1] for n, c in curves.items()}, quality=_quality(curves))


def collapse_quality(
    sizes_by_n: Mapping[int, ArrayLike],
    tau: float,
    betas: ArrayLike,
    bins_per_decade: int = 5,
    min_count: int = 3,
) -> FloatArray:
    """The collapse quality (RMS in decades) at each of ``betas`` (the histograms are made once)."""
    dens = _densities(sizes_by_n, bins_per_decade, min_count)
    return np.array([_quality(_rescale(dens, tau, float(b)))
                     for b in np.asarray(betas, dtype=np.float64).ravel()])


@dataclass(frozen=True, eq=False)
class JointScaling:
    """Result of :func:`fit_joint_scaling`: per ``N`` (``n``, ascending) the floor ``floors``, the
    avalanches at or above it (``tail``) and the samples; the shared ``tau`` and ``beta`` with
    bootstrap standard deviations (``*_err``) and 95 % intervals ``± 1.96`` of them
    (``*_ci95``); ``cutoff_ref`` (``S*`` at ``n_ref``) with its interval (the same in ``log``);
    the maximised ``loglik``; the likelihood ratio ``cutoff_lr`` against the pure power law and
    ``resolved``; ``at_bound`` and ``boot_at_bound``, the fraction of resamples with a parameter
    at its bound (module docstring); ``n_boot`` resamples and their fits ``boot`` (rows
    ``τ, log S*_ref, β``). With the jackknife: ``tau_err_jack``, ``beta_err_jack`` and the
    leave-one-out fits ``leave_one_out`` (rows ``N, sample index, τ, log S*_ref, β``); else NaN
    and an empty array. ``stretch``: the exponent ``a`` of the cut-off ``e^(−(S/S*)^a)``."""

    n: NDArray[np.int64]
    floors: FloatArray
    tail: NDArray[np.int64]
    samples: NDArray[np.int64]
    tau: float
    tau_err: float
    tau_ci95: tuple[float, float]
    beta: float
    beta_err: float
    beta_ci95: tuple[float, float]
    n_ref: float
    cutoff_ref: float
    cutoff_ref_ci95: tuple[float, float]
    loglik: float
    cutoff_lr: float
    resolved: bool
    at_bound: bool
    boot_at_bound: float
    n_boot: int
    boot: FloatArray
    tau_err_jack: float = math.nan
    beta_err_jack: float = math.nan
    leave_one_out: FloatArray = field(default_factory=lambda: np.empty((0, 5)))
    stretch: float = 1.0

    def cutoff(self, n: ArrayLike) -> FloatArray:
        """The fitted ``S*(N) = S*_ref (N/N_ref)^β``."""
        return self.cutoff_ref * (np.asarray(n, dtype=np.float64) / self.n_ref) ** self.beta

    def as_dict(self) -> dict[str, object]:
        """Plain numbers (JSON)."""
        return {
            "n": self.n.tolist(), "floors": self.floors.tolist(), "tail": self.tail.tolist(),
            "samples": self.samples.tolist(), "tau": self.tau, "tau_err": self.tau_err,
            "tau_ci95": list(self.tau_ci95), "beta": self.beta, "beta_err": self.beta_err,
            "beta_ci95": list(self.beta_ci95), "n_ref": self.n_ref,
            "cutoff_ref": self.cutoff_ref, "cutoff_ref_ci95": list(self.cutoff_ref_ci95),
            "loglik": self.loglik, "cutoff_lr": self.cutoff_lr, "resolved": self.resolved,
            "at_bound": self.at_bound,
            "boot_at_bound": self.boot_at_bound, "n_boot": self.n_boot,
            "stretch": self.stretch,
            "tau_err_jack": None if math.isnan(self.tau_err_jack) else self.tau_err_jack,
            "beta_err_jack": None if math.isnan(self.beta_err_jack) else self.beta_err_jack,
        }


def _joint_mle(starts: list[NDArray], bounds: NDArray, args: tuple) -> NDArray:
    """Bounded Nelder–Mead (:func:`jamlab.analysis.likelihood_kernels.minimize_joint_nll`,
    scipy's algorithm compiled) from each start, then once more from the best point."""
    lower, upper = bounds[:, 0].copy(), bounds[:, 1].copy()
    best_x, best_f = None, math.inf
    for x0 in starts:
        x0 = np.clip(x0, bounds[:, 0] + 1e-6, bounds[:, 1] - 1e-6)
        x, fun, _ = minimize_joint_nll(x0, lower, upper, args, 1e-7, 1e-9, 4000)
        if best_x is None or fun < best_f:
            best_x, best_f = x, fun
    # a restart from the best point (Nelder–Mead can stall on a collapsed simplex)
    x, fun, _ = minimize_joint_nll(best_x, lower, upper, args, 1e-8, 1e-10, 4000)
    return x if fun <= best_f else best_x


def fit_joint_scaling(
    sizes_by_n: Mapping[int, Sequence[ArrayLike]],
    floors: float | Mapping[int, float],
    n_boot: int = 200,
    seed: int = 0,
    min_tail: int = 5,
    jackknife: bool = False,
    stretch: float = 1.0,
) -> JointScaling:
    """One maximum-likelihood fit of ``τ``, ``β`` and the cut-off to all sizes ``N`` (module
    docstring). ``sizes_by_n[N]``: one array of sizes per sample; ``floors``: one lower end for
    all ``N`` or one per ``N`` (sizes below it are dropped). Sizes ``N`` with fewer than
    ``min_tail`` avalanches at or above their floor are dropped. ``jackknife``: also refit with
    each sample left out in turn (:attr:`JointScaling.leave_one_out`, the stratified jackknife
    errors ``*_err_jack``; a second error estimate beside the bootstrap, and the influence of
    single samples). ``stretch = a``: the cut-off ``e^(−(S/S*)^a)`` instead of ``e^(−S/S*)``
    (fixed; compare ``loglik`` over a grid of ``a`` for its profile likelihood). ``ValueError``
    for non-positive sizes, floors or ``stretch``, a missing floor, ``n_boot < 2``, or fewer
    than two sizes ``N`` left."""
    if not (validation.is_integer(n_boot) and n_boot >= 2):
        raise ValueError(f"n_boot must be an integer >= 2, got {n_boot!r}")
    if not (validation.is_integer(min_tail) and min_tail >= 1):
        raise ValueError(f"min_tail must be an integer >= 1, got {min_tail!r}")
    stretch = float(stretch)
    if not (math.isfinite(stretch) and stretch > 0):
        raise ValueError(f"stretch must be finite and > 0, got {stretch!r}")
    rows = []
    for n, samples in sorted(sizes_by_n.items()):
        floor = floors.get(n) if isinstance(floors, Mapping) else floors
        if floor is None:
            raise ValueError(f"no floor for N = {n}")
        floor = float(floor)
        if not (math.isfinite(floor) and floor > 0):
            raise ValueError(f"the floor at N = {n} must be finite and > 0, got {floor!r}")
        arrs = [np.asarray(a, dtype=np.float64).ravel() for a in samples]
        if any(np.any(~(a > 0) | ~np.isfinite(a)) for a in arrs):
            raise ValueError(f"sizes at N = {n} must be positive and finite")
        tails = [a[a >= floor] for a in arrs]
        stats = np.array([[t.size, np.log(t).sum(), (t**stretch).sum()]
                          for t in tails]).reshape(-1, 3)
        if stats[:, 0].sum() >= min_tail:
            rows.append((int(n), floor, stats, np.concatenate(tails)))
    if len(rows) < 2:
        raise ValueError(f"need two sizes N with >= {min_tail} avalanches above their floors, "
                         f"have {[r[0] for r in rows]}")
    ns = np.array([r[0] for r in rows], dtype=np.int64)
    fl = np.array([r[1] for r in rows])
    n_ref = float(np.exp(np.mean(np.log(ns))))
    log_rel = np.log(ns / n_ref)
    largest = max(float(r[3].max()) for r in rows)
    hi = math.log(largest) + 7.0
    bounds = np.array([[-1.0, 5.0], [math.log(float(fl.min())) - 3.0 / stretch, hi],
                       [-3.0, 6.0]])

    def totals(stats: list[NDArray]) -> tuple[NDArray, NDArray, NDArray]:
        """Per N: the count, ``Σ log S`` and ``Σ S^a`` of the samples' statistics."""
        return tuple(np.array([s[:, c].sum() for s in stats]) for c in range(3))

    def fit(stats: list[NDArray], extra: NDArray | None) -> NDArray:
        k, sl, s1 = totals(stats)
        mean_log = float(np.sum(sl - k * np.log(fl)) / k.sum())
        tau0 = min(max(1.0 + 1.0 / mean_log if mean_log > 0 else 1.5, 0.0), 3.0)
        starts = [np.array([tau0, math.log(largest), b0]) for b0 in (0.5, 1.5)]
        starts.append(np.array([tau0, math.log(float(np.median(fl))) + 3.0, 1.0]))
        if extra is not None:
            starts = [extra, starts[0]]
        return _joint_mle(starts, bounds, (log_rel, fl, k, sl, s1, stretch))

    base = [r[2] for r in rows]
    x = fit(base, None)
    k, sl, s1 = totals(base)
    loglik = -joint_nll(x, log_rel, fl, k, sl, s1, stretch)
    rng = np.random.default_rng(seed)
    boot = np.empty((n_boot, 3))
    for b in range(n_boot):
        res = [s[rng.integers(0, s.shape[0], s.shape[0])] for s in base]
        boot[b] = fit(res, x)
    # the pure power law with one τ: the sizes in units of their floors, S/s_N ≥ 1, follow it on
    # [1, ∞) (the Jacobian Σ log s_N converts the likelihood back)
    scaled = np.concatenate([r[3] / r[1] for r in rows])
    tau_pure = mle_tau(scaled, 1.0)[0]
    loglik_pure = power_law_loglik(scaled, tau_pure, 1.0) - float(np.sum(k * np.log(fl)))
    cutoff_lr = 2.0 * (loglik - loglik_pure)

    def on_bound(p: NDArray) -> NDArray:
        p = np.atleast_2d(p)
        return np.any((p < bounds[:, 0] + 1e-3) | (p > bounds[:, 1] - 1e-3), axis=1)

    at_b = on_bound(boot)
    loo = np.empty((0, 5))
    err_jack = np.full(3, math.nan)
    if jackknife:
        # stratified delete-one jackknife: v = Σ_N (m_N − 1)/m_N Σ_i (θ_(N,i) − θ̄_N)²
        out, var = [], np.zeros(3)
        for j, st in enumerate(base):
            m = st.shape[0]
            if m < 2:
                continue
            fits = np.array([fit([np.delete(st, i, axis=0) if jj == j else s
                                  for jj, s in enumerate(base)], x) for i in range(m)])
            var += jackknife_variance(fits)
            out.extend([ns[j], i, *f] for i, f in enumerate(fits))
        loo = np.array(out, dtype=np.float64).reshape(-1, 5)
        err_jack = np.sqrt(var)
    sd = np.std(boot, axis=0, ddof=1)
    lo, up = x - _Z_95 * sd, x + _Z_95 * sd
    return JointScaling(
        n=ns, floors=fl, tail=k.astype(np.int64),
        samples=np.array([s.shape[0] for s in base], dtype=np.int64),
        tau=float(x[0]), tau_err=float(sd[0]), tau_ci95=(float(lo[0]), float(up[0])),
        beta=float(x[2]), beta_err=float(sd[2]), beta_ci95=(float(lo[2]), float(up[2])),
        n_ref=n_ref, cutoff_ref=math.exp(float(x[1])),
        cutoff_ref_ci95=(math.exp(float(lo[1])), math.exp(float(up[1]))),
        loglik=float(loglik), cutoff_lr=float(cutoff_lr), resolved=bool(cutoff_lr > _CHI2_2_95),
        at_bound=bool(on_bound(x)[0]),
        boot_at_bound=float(at_b.mean()), n_boot=n_boot, boot=boot,
        tau_err_jack=float(err_jack[0]), beta_err_jack=float(err_jack[2]), leave_one_out=loo,
        stretch=stretch,
    )


def joint_shape_profile(
    sizes_by_n: Mapping[int, Sequence[ArrayLike]],
    floors: float | Mapping[int, float],
    stretches: Sequence[float],
    n_boot: int = 200,
    seed: int = 0,
    known: Mapping[float, JointScaling] | None = None,
) -> dict[float, JointScaling]:
    """The profile of the cut-off's shape in the joint fit: :func:`fit_joint_scaling` at each
    ``a`` of ``stretches`` and at ``a = 1`` (the exponential, the reference of every
    comparison), ``{a: fit}`` in ascending ``a``, each fit with its own ``n_boot`` resamples
    from ``seed``. ``known``: fits already made, ``{a: fit}``, taken as they are instead of
    refitted (e.g. the exponential fit of a table printed before). ``ValueError`` as
    :func:`fit_joint_scaling` (a shape ``≤ 0`` among them)."""
    known = dict(known or {})
    return {x: known[x] if x in known
            else fit_joint_scaling(sizes_by_n, floors, n_boot=n_boot, seed=seed, stretch=x)
            for x in sorted(set(float(a) for a in stretches) | {1.0})}


@dataclass(frozen=True)
class JointShapeFree:
    """Result of :func:`joint_shape_free`: ``best``, the ``a`` of the largest log-likelihood on
    the grid (``at_edge`` when it is an end of the grid: the maximum may lie beyond);
    ``tau_low``, ``tau_high``, the 95 % interval of the shared ``τ`` with the shape free;
    ``inside``, the grid's shapes with ``2Δlog L / scale ≤ 3.84`` (ascending; ``a_low``,
    ``a_high`` its ends); ``lr_exponential = 2 (ℓ(best) − ℓ(a = 1))``, not divided by
    ``scale``."""

    best: float
    tau_low: float
    tau_high: float
    inside: tuple[float, ...]
    at_edge: bool
    lr_exponential: float
    scale: float

    @property
    def a_low(self) -> float:
        """The smallest shape of :attr:`inside`."""
        return self.inside[0]

    @property
    def a_high(self) -> float:
        """The largest shape of :attr:`inside`."""
        return self.inside[-1]


def joint_shape_free(fits: Mapping[float, JointScaling], scale: float = 1.0) -> JointShapeFree:
    """τ with the cut-off's shape free, from joint fits by shape ``a`` (``{a: JointScaling}``,
    one of them at ``a = 1``; :func:`joint_shape_profile`):
    :func:`jamlab.analysis.shape_free_interval` with each fit's bootstrap σ (whole samples
    resampled, so correlated avalanches and unlike packings are in it) and the log-likelihoods
    divided by ``scale`` (a design effect ``λ̂``, :mod:`jamlab.analysis.shape_test`: the profile
    read with packings as the units; ``1``: every avalanche independent). ``ValueError`` for
    ``scale ≤ 0`` or no fit at ``a = 1``."""
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be finite and > 0, got {scale!r}")
    if 1.0 not in fits:
        raise ValueError("the fits need one at a = 1 (the exponential cut-off)")
    grid = sorted(fits)
    ll = np.array([fits[x].loglik for x in grid]) / scale
    low, high = shape_free_interval([fits[x].tau for x in grid],
                                    [fits[x].tau_err for x in grid], ll)
    best = max(grid, key=lambda x: fits[x].loglik)
    return JointShapeFree(
        best=best, tau_low=low, tau_high=high, inside=tuple(grid[i] for i in shape_set(ll)),
        at_edge=best in (grid[0], grid[-1]),
        lr_exponential=2.0 * (fits[best].loglik - fits[1.0].loglik), scale=float(scale))
