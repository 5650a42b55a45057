"""Is the cut-off's shape significant when the avalanches of one packing are not independent?

The fits of :mod:`jamlab.analysis.cutoff_powerlaw` and :func:`jamlab.analysis.fit_joint_scaling`
compare cut-off shapes ``e^(−(S/S*)^a)`` by their likelihoods, and a likelihood that multiplies
the densities of all avalanches treats them as independent. Avalanches of one packing share its
history, so the log-likelihood ratio ``W = 2 (ℓ(â) − ℓ(a = 1))`` need not follow ``χ²₁`` under
the exponential cut-off. This module gives the test that treats each sample (packing) as the
independent unit: the independence likelihood is then a *composite* likelihood, and under the
null ``W → λ χ²₁`` (Rotnitzky & Jewell, Biometrika 77, 485, 1990; Varin, Reid & Firth, Stat.
Sinica 21, 5, 2011, §2.3), ``λ`` the factor by which the correlation within samples inflates the
variance of the score for ``a`` once the other parameters are projected out. It is estimated at
the fit with ``a = 1`` (the null's estimates, as in a score test) as the *design effect*

    λ̂ = (J₁⁻¹ J_K J₁⁻¹)_aa / (J₁⁻¹)_aa,

``J₁ = n/(n − 1) Σ_i (s_i − s̄)(s_i − s̄)ᵀ`` the covariance of the scores ``s_i`` of the ``n``
avalanches and ``J_K = K/(K − 1) Σ_k (U_k − Ū)(U_k − Ū)ᵀ`` that of their sums ``U_k`` over each
of the ``K`` samples: ``λ̂`` is the variance over samples of the efficient score for ``a``
(``s_a − J₁,aν J₁,νν⁻¹ s_ν``) against its variance over independent avalanches, 1 when the
avalanches of one sample are independent, and the same in any parametrisation of ``a``. The
adjusted statistic ``W / max(λ̂, 1)`` is referred to ``F(1, K − 1)`` rather than ``χ²₁``, since
``λ̂`` rests on ``K`` sums (the small-sample reference of cluster-robust tests); ``λ̂ < 1``
(avalanches of one sample less alike than independent ones) is not let to sharpen it.

Why this ``λ̂``. The textbook form uses the observed information ``H = −∇²ℓ`` in place of
``J₁``: ``(H⁻¹ J_K H⁻¹)_aa / (H⁻¹)_aa``. Both agree under the null (``H ≈ J₁``), but under an
alternative the score at ``a = 1`` is not centred, ``H`` and ``J₁`` part, and ``H`` need not be
positive definite there. Four variants were compared while this was written (the copula of
``scripts/shape_test_size.py``, 20 samples × 40 sizes, rejections at 5 % over 80–300 trials,
binomial errors 1.5–6 %; ranges over two seeds; true exponential cut-off with ρ = 0.2 and 0.5
for the size, independent sizes with a = 0.3 for the power):

| ``λ̂`` | size, ρ = 0.2 | size, ρ = 0.5 | power, a = 0.3 | undefined |
|---|---|---|---|---|
| none (``χ²₁``) | 11 – 13 % | 32 – 37 % | 59 – 69 % | — |
| ``H``-form at ``a = 1`` | 4.1 % | 2.7 % | 18 % | rarely |
| ``H``-form at ``â`` | 9.1 % | 13.7 % | 66 % | at the bound |
| ``H``-form over itself with ``J₁`` | 3.5 – 5.6 % | 2.0 – 6.2 % | 51 – 53 % | 19 – 36 % * |
| **``J₁``-form at ``a = 1`` (this module)** | 6.0 – 7.3 % | 5.3 – 7.5 % | 50 – 64 % | never |

(* of the stretched sets, where ``H`` is not positive definite at ``a = 1``.) With 20 samples
the chosen form is still slightly liberal (≈ 7 % at a nominal 5 %: its p-values are somewhat
small), the naive test two to seven times more so. This version's rates from the script itself,
also with 80 samples: ``docs/analysis.md``.

Model: sizes at or above ``floor`` (one for all groups) of one group (``x_c`` free) or of
several system sizes ``N`` (the joint model of :func:`jamlab.analysis.fit_joint_scaling`:
``x_c(N) = x_c,ref (N/N_ref)^β``, ``N_ref`` the geometric mean of the ``N``), density
:func:`~jamlab.analysis.cutoff_powerlaw.cutoff_power_law_logpdf` with its ``stretch = a``.
Parameters ``θ = (τ, log x_c,ref[, β], log a)``; the maximum with ``a`` free and at ``a = 1``
by bounded L-BFGS-B from several starts; derivatives by central differences (scores of each
avalanche with steps 1e-6, ``H`` from the total with steps 1e-4).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, stats

from jamlab import validation
from jamlab.analysis.cutoff_powerlaw import cutoff_power_law_logpdf
from jamlab.threads import one_blas_thread

__all__ = ["ClusteredShapeTest", "clustered_shape_test"]

FloatArray = NDArray[np.float64]

_LOG_A = (math.log(0.05), math.log(5.0))
_STARTS_A = (0.3, 0.6, 1.0, 1.6)
_H_SCORE = 1e-6
_H_HESS = 1e-4


@dataclass(frozen=True)
class ClusteredShapeTest:
    """Result of :func:`clustered_shape_test` (module docstring). ``n``: the groups' sizes (one
    entry, 0, for a single group); ``samples``, ``n_tail``: samples (clusters) and avalanches at
    or above ``floor``. ``stretch``: the MLE ``â`` (``at_bound`` when it lies on the search
    bound 0.05 or 5), ``tau`` there and ``tau_null`` at ``a = 1``; ``lr = W``. ``scale = λ̂``,
    the design effect (NaN, as is ``p_adjusted``, when the avalanches' score covariance is
    singular). ``p_naive``:
    ``χ²₁`` tail of ``W``; ``p_adjusted``: ``F(1, K − 1)`` tail of ``W / max(λ̂, 1)``.
    ``log_stretch_se``, ``log_stretch_se_robust``, ``tau_se``, ``tau_se_robust``: standard
    errors of ``log â`` and of ``τ`` at ``â`` from ``H⁻¹`` and from ``H⁻¹ J H⁻¹`` (NaN when
    ``H`` is not positive definite at ``â``)."""

    n: tuple[int, ...]
    floor: float
    samples: int
    n_tail: int
    stretch: float
    at_bound: bool
    tau: float
    tau_null: float
    lr: float
    scale: float
    p_naive: float
    p_adjusted: float
    log_stretch_se: float
    log_stretch_se_robust: float
    tau_se: float
    tau_se_robust: float


class _Model:
    """The data of the test and the log-density of every avalanche at ``θ``."""

    def __init__(self, groups: list[tuple[int, list[FloatArray]]], floor: float) -> None:
        self.floor = floor
        self.joint = len(groups) > 1
        ns = np.array([g[0] for g in groups], dtype=np.float64)
        self.log_rel = np.log(ns / math.exp(float(np.mean(np.log(ns))))) if self.joint \
            else np.zeros(1)
        self.x = [np.concatenate(g[1]) for g in groups]
        counts = [a.size for g in groups for a in g[1]]  # the samples of all groups, in order
        self.k = len(counts)
        self.labels = np.repeat(np.arange(self.k), counts)
        top = max(float(x.max()) for x in self.x)
        rows = [(-1.0, 5.0), (math.log(floor) - 40.0, math.log(top) + 12.0)]
        if self.joint:
            rows.append((-3.0, 6.0))
        rows.append(_LOG_A)
        self.bounds = np.array(rows)
        self.top = top

    def terms(self, theta: FloatArray) -> FloatArray:
        tau, log_ref = float(theta[0]), float(theta[1])
        beta = float(theta[2]) if self.joint else 0.0
        a = math.exp(float(theta[-1]))
        return np.concatenate([
            cutoff_power_law_logpdf(x, tau, math.exp(log_ref + beta * lr), self.floor, a)
            for x, lr in zip(self.x, self.log_rel, strict=True)])

    def nll(self, theta: FloatArray) -> float:
        try:
            v = -float(np.sum(self.terms(theta)))
        except (ValueError, OverflowError, ZeroDivisionError):
            return 1e300
        return v if math.isfinite(v) else 1e300

    def fit(self, log_a: float | None) -> FloatArray:
        """The MLE with ``log a`` free (``None``) or fixed."""
        free = log_a is None
        best = None
        for a0 in (_STARTS_A if free else (math.exp(log_a),)):
            for lx in (math.log(self.top), math.log(self.floor) + 3.0):
                x0 = [1.3, lx] + ([0.5] if self.joint else []) + [math.log(a0)]
                b = self.bounds.copy()
                if not free:
                    b[-1] = (log_a, log_a)
                x0 = np.clip(x0, b[:, 0], b[:, 1])
                with one_blas_thread():  # jamlab.threads
                    r = optimize.minimize(self.nll, x0, method="L-BFGS-B", bounds=b,
                                          options={"ftol": 1e-15, "gtol": 1e-9,
                                                   "maxiter": 5000})
                if best is None or r.fun < best.fun:
                    best = r
        return np.asarray(best.x, dtype=np.float64)

    def information(self, theta: FloatArray, hessian: bool = True
                    ) -> tuple[FloatArray | None, FloatArray, FloatArray]:
        """``(H⁻¹, J over samples, J over avalanches)`` at ``θ``, the score sums centred on
        their mean; ``H⁻¹`` is None when ``H`` is not positive definite or not asked for
        (``hessian=False``: the scores alone)."""
        p = theta.size
        scores = np.empty((self.labels.size, p))
        for j in range(p):
            e = np.zeros(p)
            e[j] = _H_SCORE
            scores[:, j] = (self.terms(theta + e) - self.terms(theta - e)) / (2 * _H_SCORE)
        inv = self._inverse_hessian(theta) if hessian else None
        sums = np.zeros((self.k, p))
        np.add.at(sums, self.labels, scores)
        sums -= sums.mean(axis=0)
        scores = scores - scores.mean(axis=0)
        n = scores.shape[0]
        return (inv, self.k / (self.k - 1) * sums.T @ sums, n / (n - 1) * scores.T @ scores)

    def _inverse_hessian(self, theta: FloatArray) -> FloatArray | None:
        """``H⁻¹``, ``H = −∇²ℓ`` at ``θ`` by central differences; None when ``H`` is not
        positive definite."""
        p = theta.size
        hess = np.empty((p, p))
        for i in range(p):
            for j in range(p):
                ei, ej = np.eye(p)[i] * _H_HESS, np.eye(p)[j] * _H_HESS
                hess[i, j] = (self.nll(theta + ei + ej) - self.nll(theta + ei - ej)
                              - self.nll(theta - ei + ej) + self.nll(theta - ei - ej)) / (
                    4 * _H_HESS**2)
        hess = 0.5 * (hess + hess.T)
        return np.linalg.inv(hess) if np.all(np.linalg.eigvalsh(hess) > 0) else None


def _groups(sizes_by_group, floor: float) -> list[tuple[int, list[FloatArray]]]:
    if isinstance(sizes_by_group, Mapping):
        items = sorted(sizes_by_group.items())
    else:
        items = [(0, sizes_by_group)]
    out = []
    for n, samples in items:
        arrs = [np.asarray(a, dtype=np.float64).ravel() for a in samples]
        if any(np.any(~np.isfinite(a) | ~(a > 0)) for a in arrs):
            raise ValueError(f"the sizes of group {n} must be positive and finite")
        out.append((int(n), [a[a >= floor] for a in arrs]))
    return out


def clustered_shape_test(sizes_by_group: Mapping[int, Sequence[ArrayLike]] | Sequence[ArrayLike],
                         floor: float) -> ClusteredShapeTest:
    """Test the exponential cut-off ``a = 1`` against ``e^(−(S/S*)^a)`` with whole samples as
    the independent units (module docstring). ``sizes_by_group``: one array of sizes per sample,
    either a list (one group) or ``{N: list}`` (the joint model over the sizes ``N``); sizes
    below ``floor`` are dropped. ``ValueError`` for a bad floor, non-positive or non-finite
    sizes, fewer than 3 samples or 20 avalanches at or above the floor, or ``{N: list}`` with one
    ``N``."""
    if not (validation.is_real(floor) and math.isfinite(floor) and floor > 0):
        raise ValueError(f"floor must be finite and > 0, got {floor!r}")
    if isinstance(sizes_by_group, Mapping) and len(sizes_by_group) < 2:
        raise ValueError("the joint model needs two sizes N or more (pass a list for one)")
    groups = _groups(sizes_by_group, float(floor))
    m = _Model(groups, float(floor))
    n_tail = int(sum(x.size for x in m.x))
    if m.k < 3 or n_tail < 20:
        raise ValueError(f"need >= 3 samples and >= 20 sizes at or above the floor, got {m.k} "
                         f"and {n_tail}")
    null = m.fit(0.0)
    full = m.fit(None)
    if m.nll(null) < m.nll(full):
        full = null  # the null lies in the free model: the search missed it
    w = max(2.0 * (m.nll(null) - m.nll(full)), 0.0)
    lo, hi = m.bounds[-1]
    at_bound = bool(full[-1] < lo + 1e-6 or full[-1] > hi - 1e-6)
    inv_f, j_f, _ = m.information(full)
    se = [math.nan] * 4
    if inv_f is not None:
        sand_f = inv_f @ j_f @ inv_f
        se = [math.sqrt(inv_f[-1, -1]), math.sqrt(sand_f[-1, -1]), math.sqrt(inv_f[0, 0]),
              math.sqrt(sand_f[0, 0])]
    _, j_samples, j_each = m.information(null, hessian=False)
    scale = math.nan
    if np.all(np.linalg.eigvalsh(j_each) > 0):
        inv = np.linalg.inv(j_each)
        scale = float((inv @ j_samples @ inv)[-1, -1] / inv[-1, -1])
    return ClusteredShapeTest(
        n=tuple(g[0] for g in groups), floor=float(floor), samples=m.k, n_tail=n_tail,
        stretch=math.exp(float(full[-1])), at_bound=at_bound,
        tau=float(full[0]), tau_null=float(null[0]), lr=float(w), scale=scale,
        p_naive=float(stats.chi2.sf(w, 1)),
        p_adjusted=(float(stats.f.sf(w / max(scale, 1.0), 1, m.k - 1))
                    if math.isfinite(scale) else math.nan),
        log_stretch_se=float(se[0]), log_stretch_se_robust=float(se[1]), tau_se=float(se[2]),
        tau_se_robust=float(se[3]))
