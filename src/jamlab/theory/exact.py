r"""Exact jump distribution of the ``k``-level cascade (the corrected theory).

Notation of SPEC §2, ``d = |δγ|``, ``v_i = q_{i+1} - q_i``, ``Δy_i = y_i - y_{i-1}`` (``y_0 = 0``),
``r_i = y_i / y_{i+1}``. ``R(x) = P(ΔE >= x)`` for ``x <= 0``; ``R(0)`` is the no-jump probability.

Derivation (see ``docs/theory-vs-cascade.md``). Write the ground state's path
``(u_i, s_i)_{i=1..k}`` (energy and stress increments from its level-``i`` ancestor ``n_i``). By the
Mecke formula, the path has intensity ``Π e^{y_i u_i} φ_{v_i}(s_i)`` and the other children of each
``n_i`` are an independent copy of the Poisson process, all of whose states must satisfy
``U > U_gs`` and ``U - dΣ > U_gs - dΣ_gs + x``. For a level-``i`` node at the origin,
``P(all its states satisfy U > t and U - dΣ > h) = exp(-e^{y_i t} g_i(h - t))`` (shift invariance),
with the one-variable functions

    g_k(z) = (1/y_k) E_s[e^{y_k (z + d s)⁺}],                         s ~ N(0, v_k)
    g_i(z) = (Γ(1 - r_i)/y_i) E_s[g_{i+1}(z + d s)^{r_i}],            s ~ N(0, v_i).

With ``t_i = Σ_{j>=i} u_j`` the path integral over energies factorises,
``∫ e^{Δy_i t} exp(-e^{y_i t} g) dt = Γ(Δy_i/y_i) g^{-Δy_i/y_i} / y_i``, and

    R(x) = E_path[ Π_i exp(-(Δy_i/y_i) f_i(x - d S_i)) ],   S_i = Σ_{j>=i} s_j,

where ``f_i = log(y_i g_i / c_i⁰)`` (``c_i⁰`` the ``δγ = 0`` constants) obeys the Parisi-like
recursion

    f_k(z) = log E_s[e^{y_k (z + d s)⁺}]
           = log[Φ(-z/(d√v_k)) + e^{y_k z + y_k² d² v_k/2} Φ(z/(d√v_k) + y_k d √v_k)],
    f_i(z) = log E_s[exp(r_i f_{i+1}(z + d s))].

``S_i`` is the ground state's stress relative to its level-``i`` ancestor: a backward Gaussian
random walk, ``Var S_i = 1 - q_i``. For ``k = 1`` this is
``R(x) = E_{σ0}[1/(1 + A_x(σ0))]`` (:func:`one_level_R`).

Numerics: ``f_i`` on a uniform ``z`` grid with Gauss–Hermite quadrature and linear interpolation;
the path average by the forward recursion ``M_k(z) = F_k(z) φ_{d² v_k}(z - x)``,
``M_i = F_i · (M_{i+1} * φ_{d² v_i})``, ``R(x) = ∫ M_1``, ``F_i = exp(-(Δy_i/y_i) f_i)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import integrate
from scipy.special import log_ndtr, ndtr

__all__ = ["exact_jump_R", "one_level_R", "one_level_A", "level_functions"]


def one_level_A(x: float, sigma0: np.ndarray, y: float, d: float, v: float = 1.0) -> np.ndarray:
    """``A_x(σ0) = ∫_{σ > σ*} φ_v(σ)(e^{y x + b(σ - σ0)} - 1) dσ`` for one level.

    Explicitly, with ``sd = √v``, ``b = y d``, ``σ* = σ0 - x/d``:
    ``A = e^{y x - b σ0 + b² v/2} Φ̄((σ* - b v)/sd) - Φ̄(σ*/sd)``.
    """
    sd = np.sqrt(v)
    b = y * d
    s_star = sigma0 - x / d
    log1 = y * x - b * sigma0 + 0.5 * b * b * v + log_ndtr(-(s_star - b * v) / sd)
    return np.exp(log1) - ndtr(-s_star / sd)


def one_level_R(x: float, y: float, dgamma: float, v: float = 1.0) -> float:
    """Exact ``R(x) = P(ΔE >= x)`` for one level (``k = 1``, stress variance ``v = 1 - q_1``).

    Given the ground state's stress ``σ0 ~ N(0, v)``, the other states are a Poisson process on
    ``u > u_0`` mixed by ``λ = e^{y u_0}/y ~ Exp(1)``, so
    ``R(x) = ∫ φ_v(σ0) / (1 + A_x(σ0)) dσ0`` (:func:`one_level_A`).
    """
    d = abs(float(dgamma))
    if d == 0.0:
        return 1.0
    sd = np.sqrt(v)

    def integrand(s0: float) -> float:
        return float(np.exp(-0.5 * s0 * s0 / v) / (np.sqrt(2 * np.pi) * sd)
                     / (1.0 + one_level_A(x, s0, y, d, v)))

    val, _ = integrate.quad(integrand, -12 * sd, 12 * sd, epsabs=1e-13, epsrel=1e-12, limit=200)
    return float(val)


_GH_X, _GH_W = np.polynomial.hermite_e.hermegauss(48)
_GH_W = _GH_W / _GH_W.sum()


def _gauss_smooth_log(z: np.ndarray, fz: np.ndarray, r: float, width: float) -> np.ndarray:
    """``log E[exp(r f(z + width ξ))]``, ``ξ ~ N(0,1)``, ``f`` tabulated on the uniform grid ``z``
    (linear interpolation; linear extrapolation beyond the grid)."""
    pts = z[:, None] + width * _GH_X[None, :]
    h = z[1] - z[0]
    fi = np.interp(pts, z, fz)
    lo = pts < z[0]
    hi = pts > z[-1]
    if lo.any():
        slope = (fz[1] - fz[0]) / h
        fi[lo] = fz[0] + slope * (pts[lo] - z[0])
    if hi.any():
        slope = (fz[-1] - fz[-2]) / h
        fi[hi] = fz[-1] + slope * (pts[hi] - z[-1])
    a = r * fi
    amax = a.max(axis=1, keepdims=True)
    return (amax[:, 0] + np.log(np.sum(_GH_W[None, :] * np.exp(a - amax), axis=1)))


def _grid(x: np.ndarray, d: float, v: np.ndarray, points_per_sd: float) -> np.ndarray:
    lo = float(np.min(x)) - 12.0 * d
    hi = max(float(np.max(x)), 0.0) + 12.0 * d
    h = d * float(np.sqrt(np.min(v))) / points_per_sd
    npts = int(np.ceil((hi - lo) / h)) + 1
    if npts > 400_000:
        raise ValueError(f"exact R: grid of {npts} points is too fine; use fewer/coarser levels")
    return np.linspace(lo, hi, npts)


def level_functions(q: Any, y: Any, dgamma: float, z: np.ndarray) -> np.ndarray:
    """``f_i(z)`` for ``i = 1..k`` on the grid ``z`` (rows), by the recursion in the module doc."""
    from jamlab.theory.cascade import validate_levels

    qa, ya = validate_levels(q, y)
    d = abs(float(dgamma))
    v = np.diff(np.append(qa, 1.0))
    k = qa.size
    f = np.empty((k, z.size))
    sdk = d * np.sqrt(v[-1])
    b = ya[-1] * sdk
    w = z / sdk
    f[-1] = np.logaddexp(log_ndtr(-w), ya[-1] * z + 0.5 * b * b + log_ndtr(w + b))
    for i in range(k - 2, -1, -1):
        f[i] = _gauss_smooth_log(z, f[i + 1], ya[i] / ya[i + 1], d * np.sqrt(v[i]))
    return f


def exact_jump_R(
    q: Any,
    y: Any,
    dgamma: float,
    x: Any = 0.0,
    *,
    points_per_sd: float = 8.0,
    decouple_path: bool = False,
    poisson_clusters: bool = False,
) -> np.ndarray:
    """Exact ``R(x) = P(ΔE >= x)`` of the ``k``-level cascade (module docstring), ``x <= 0``.

    ``decouple_path=True`` replaces the ground state's correlated stress path by independent
    ``S_i ~ N(0, 1 - q_i)`` per level (``R ≈ Π_i E[exp(-(Δy_i/y_i) f_i(x - d S_i))]``): the
    diagonal approximation of the paper's Hubbard–Stratonovich step; for diagnosis only.

    ``poisson_clusters=True`` replaces each cluster's Gamma mixing by its mean: the factor
    ``(1 + A_i)^{-Δy_i/y_i} = exp(-(Δy_i/y_i) f_i)``, ``A_i = e^{f_i} - 1``, becomes
    ``exp(-(Δy_i/y_i) A_i)`` (clusters seen from the ground state taken as plain Poisson
    processes); for diagnosis only.
    """
    from jamlab.theory.cascade import validate_levels

    qa, ya = validate_levels(q, y)
    d = abs(float(dgamma))
    xa = np.atleast_1d(np.asarray(x, dtype=np.float64))
    if np.any(xa > 0):
        raise ValueError(f"x must be <= 0, got max x = {xa.max()!r}")
    if d == 0.0:
        return np.ones_like(xa)
    v = np.diff(np.append(qa, 1.0))
    dy = np.diff(np.concatenate(([0.0], ya)))
    z = _grid(xa, d, v, points_per_sd)
    h = z[1] - z[0]
    f = level_functions(qa, ya, d, z)
    if poisson_clusters:
        F = np.exp(-(dy / ya)[:, None] * np.expm1(np.minimum(f, 700.0)))
    else:
        F = np.exp(-(dy / ya)[:, None] * f)  # (k, nz)
    k = qa.size
    if decouple_path:
        out = np.ones_like(xa)
        for i in range(k):
            var = 1.0 - qa[i]
            for j, xv in enumerate(xa):
                fi = np.interp(xv - d * np.sqrt(var) * _GH_X, z, F[i])
                out[j] *= float(np.sum(_GH_W * fi))
        return out
    from scipy.ndimage import gaussian_filter1d

    sd_k = d * np.sqrt(v[-1])
    M = np.exp(-0.5 * ((z[None, :] - xa[:, None]) / sd_k) ** 2) / (np.sqrt(2 * np.pi) * sd_k)
    M *= F[-1][None, :]
    for i in range(k - 2, -1, -1):
        M = gaussian_filter1d(M, d * np.sqrt(v[i]) / h, axis=1, mode="constant", truncate=10.0)
        M *= F[i][None, :]
    return np.sum(M, axis=1) * h
