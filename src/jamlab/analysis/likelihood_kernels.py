"""The compiled (numba) likelihood code of the analysis fits, in one file.

numba keys a cached function on its own source file only, so a compiled function that calls one
of another file keeps stale machine code when only that file changes
(``jamlab.spheres.kernels.cache``); the functions here call each other, so they share a file.

**log Γ(a, z)** (:func:`log_upper_gamma_value`) and the normaliser of the cut-off power law
(:func:`cutoff_log_norm`): the scalar formulas of :mod:`jamlab.analysis.cutoff_powerlaw` (its
docstring gives them; it calls these through checked wrappers). scipy's special functions are
reached through their Cython exports (``scipy.special.cython_special``, linked by symbol so that
numba can cache the callers): the same C code as ``scipy.special.gammaincc``, ``gamma`` and
``exp1``, so every value equals the one the earlier pure-Python form computed, bit for bit.

**The joint finite-size likelihood** (:func:`joint_nll`, for
:func:`jamlab.analysis.finite_size.fit_joint_scaling`) **and its bounded Nelder–Mead search**
(:func:`minimize_joint_nll`). The fit searches ``(τ, log S*_ref, β)`` ~300 times per call
(several starts for the data and for each bootstrap resample); with
``scipy.optimize.minimize(method="Nelder-Mead")`` around a Python likelihood nearly all of its
time went to the interpreter (1.1–1.7 s per fit with 100 resamples; now 0.06 s,
``benchmarks/bench_joint_fit.py``). The search is scipy's
algorithm (1.17's ``_minimize_neldermead``, ``adaptive=False``: the initial simplex of 5 % steps,
the bounds' clipping and reflection of that simplex, reflection ``ρ = 1``, expansion ``χ = 2``,
contractions ``ψ = 1/2``, shrink ``σ = 1/2``, the stopping rule on ``xatol`` and ``fatol``) with
the same floating-point operations in the same order. One difference is deliberate: the simplex
is sorted by a stable sort (NaN last). numpy's ``argsort`` of four values is not stable on
machines where it dispatches to a SIMD sort, so scipy's path through exactly equal values depends
on the CPU; with a stable sort in scipy the two visit the same points and return the same
minimum, bit for bit. It is specialised to this likelihood because numba cannot cache a compiled
function that takes another as an argument.

**The truncated power law's score equation** (:func:`truncated_score`, ``h'(u)``, and its root
:func:`truncated_score_root`, for :mod:`jamlab.analysis.powerlaw`): the KS scan of ``x_min`` solves
it once per candidate and per bootstrap resample (~190,000 times in a quick report). The root is
scipy's ``brentq`` (``Zeros/brentq.c``) with the same operations in the same order: the same
root, bit for bit, with no Python call per step (a fit 1.8× faster, the rest is numpy's KS).

Tests: ``tests/analysis/test_likelihood_kernels.py``.
"""

from __future__ import annotations

import math

import llvmlite.binding as llvm
import numpy as np
from numba import njit, types
from numba.extending import get_cython_function_address
from numpy.typing import NDArray

__all__ = [
    "ASYMPTOTIC_Z",
    "SERIES_U",
    "SMALL_A",
    "cutoff_log_norm",
    "joint_nll",
    "log_upper_gamma_value",
    "minimize_joint_nll",
    "truncated_score",
    "truncated_score_root",
]

FloatArray = NDArray[np.float64]

SMALL_A = 1e-5
"""Below this ``|a|`` the recurrence cancels: ``Γ(a, z) e^z`` is linear between ``0`` and
``±SMALL_A``."""
ASYMPTOTIC_Z = 50.0
"""Above this ``z`` the asymptotic series (12 terms) is used."""


def _external(cython_name: str, n_args: int) -> types.ExternalFunction:
    """scipy's float64 function ``cython_name`` as a symbol compiled code links against (not a
    ctypes pointer: numba cannot cache a function that holds one)."""
    symbol = f"jamlab_scipy_special_{cython_name}"
    llvm.add_symbol(symbol, get_cython_function_address(_SPECIAL, cython_name))
    return types.ExternalFunction(symbol, types.float64(*([types.float64] * n_args)))


_SPECIAL = "scipy.special.cython_special"
_gammaincc = _external("gammaincc", 2)
_gamma = _external("__pyx_fuse_1gamma", 1)  # the float64 one of the fused function
_exp1 = _external("__pyx_fuse_1exp1", 1)


@njit(cache=True)
def _scaled_upper_gamma(a: float, z: float) -> float:
    """``Γ(a, z) e^z`` for ``0 < z ≤ 50``."""
    if 0.0 < abs(a) < SMALL_A:
        edge = math.copysign(SMALL_A, a)
        g0 = _scaled_upper_gamma(0.0, z)
        g1 = _scaled_upper_gamma(edge, z)
        return g0 + (g1 - g0) * (a / edge)
    if a > 0:
        return _gammaincc(a, z) * _gamma(a) * math.exp(z)
    if a == 0:
        return _exp1(z) * math.exp(z)
    return (_scaled_upper_gamma(a + 1.0, z) - z**a) / a


@njit(cache=True)
def log_upper_gamma_value(a: float, z: float) -> float:
    """``log Γ(a, z)`` for finite ``a`` and finite ``z > 0`` (``ValueError`` otherwise)."""
    if not (math.isfinite(a) and math.isfinite(z) and z > 0):
        raise ValueError("log_upper_gamma needs finite a and z > 0")
    if z > ASYMPTOTIC_Z:
        term = 1.0
        total = 1.0
        for k in range(1, 13):
            term *= (a - k) / z
            total += term
        return (a - 1.0) * math.log(z) - z + math.log(total)
    return math.log(_scaled_upper_gamma(a, z)) - z


@njit(cache=True)
def cutoff_log_norm(tau: float, x_c: float, x_min: float, stretch: float) -> float:
    """``log Z`` of ``x^(−τ) e^(−(x/x_c)^a)`` on ``[x_min, ∞)`` (``a = stretch``; parameters not
    checked): ``(1−τ) log x_c + log Γ(1−τ, x_min/x_c)`` at ``a = 1``, else
    ``(1−τ) log x_c − log a + log Γ((1−τ)/a, (x_min/x_c)^a)``."""
    if stretch == 1.0:
        return (1.0 - tau) * math.log(x_c) + log_upper_gamma_value(1.0 - tau, x_min / x_c)
    return ((1.0 - tau) * math.log(x_c) - math.log(stretch)
            + log_upper_gamma_value((1.0 - tau) / stretch, (x_min / x_c) ** stretch))


@njit(cache=True)
def joint_nll(params: NDArray, log_rel_n: FloatArray, floors: FloatArray, k: FloatArray,
              sum_log: FloatArray, sum_s: FloatArray, stretch: float) -> float:
    """``−log L`` of ``p(S | N) ∝ S^(−τ) e^(−(S/S*_N)^a)`` on ``[s_N, ∞)`` with
    ``log S*_N = log S*_ref + β log(N/N_ref)`` (``params = (τ, log S*_ref, β)``, ``log_rel_n =
    log(N/N_ref)``, ``floors = s_N``, ``a = stretch``), from the sufficient statistics per ``N``:
    the count ``k``, ``Σ log S`` and ``Σ S^a`` at or above the floors."""
    tau, log_ref, beta = params[0], params[1], params[2]
    total = 0.0
    for i in range(k.size):
        if k[i] == 0:
            continue
        log_star = log_ref + beta * log_rel_n[i]
        s_star = math.exp(log_star)
        scaled = sum_s[i] / s_star if stretch == 1.0 else sum_s[i] * math.exp(-stretch * log_star)
        total += (tau * sum_log[i] + scaled
                  + k[i] * cutoff_log_norm(tau, s_star, floors[i], stretch))
    return total


_RHO, _CHI, _PSI, _SIGMA = 1.0, 2.0, 0.5, 0.5  # Nelder–Mead's coefficients (scipy's, not adaptive)
_NONZDELT, _ZDELT = 0.05, 0.00025  # its initial simplex: relative step, step from zero


@njit(cache=True)
def _clip(x: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``np.clip`` (NaN stays NaN)."""
    out = np.empty_like(x)
    for i in range(x.size):
        v = x[i]
        if v < lower[i]:
            v = lower[i]
        if v > upper[i]:
            v = upper[i]
        out[i] = v
    return out


@njit(cache=True)
def _before(a: float, b: float) -> bool:
    """``a`` sorts strictly before ``b`` (numpy's order: NaN last)."""
    if np.isnan(a):
        return False
    if np.isnan(b):
        return True
    return a < b


@njit(cache=True)
def _sort(sim: np.ndarray, fsim: np.ndarray) -> None:
    """Sort the simplex by its values in place (stable)."""
    m = fsim.size
    for i in range(1, m):
        f = fsim[i]
        row = sim[i].copy()
        j = i - 1
        while j >= 0 and _before(f, fsim[j]):
            fsim[j + 1] = fsim[j]
            sim[j + 1] = sim[j]
            j -= 1
        fsim[j + 1] = f
        sim[j + 1] = row


@njit(cache=True)
def minimize_joint_nll(x0, lower, upper, args, xatol=1e-4, fatol=1e-4, maxiter=0):
    """``(x, joint_nll(x, *args), iterations)`` at the minimum that Nelder–Mead finds in
    ``[lower, upper]`` (``maxiter = 0``: scipy's default ``200 n``)."""
    n = x0.size
    if maxiter <= 0:
        maxiter = 200 * n
    x0 = _clip(x0.astype(np.float64), lower, upper)
    sim = np.empty((n + 1, n))
    sim[0] = x0
    for k in range(n):
        y = x0.copy()
        if y[k] != 0:
            y[k] = (1 + _NONZDELT) * y[k]
        else:
            y[k] = _ZDELT
        sim[k + 1] = y
    for j in range(n + 1):  # reflect a simplex past the upper bounds into the interior
        for i in range(n):
            if sim[j, i] > upper[i]:
                sim[j, i] = 2 * upper[i] - sim[j, i]
        sim[j] = _clip(sim[j], lower, upper)
    fsim = np.empty(n + 1)
    for k in range(n + 1):
        fsim[k] = joint_nll(sim[k], *args)
    _sort(sim, fsim)
    iterations = 1
    while iterations < maxiter:
        small = True
        for j in range(1, n + 1):
            for i in range(n):
                if not (abs(sim[j, i] - sim[0, i]) <= xatol):
                    small = False
        if small:
            for j in range(1, n + 1):
                if not (abs(fsim[0] - fsim[j]) <= fatol):
                    small = False
            if small:
                break
        xbar = sim[0].copy()
        for j in range(1, n):
            xbar = xbar + sim[j]
        xbar = xbar / n
        worst = sim[n].copy()
        xr = _clip((1 + _RHO) * xbar - _RHO * worst, lower, upper)
        fxr = joint_nll(xr, *args)
        shrink = False
        if fxr < fsim[0]:
            xe = _clip((1 + _RHO * _CHI) * xbar - _RHO * _CHI * worst, lower, upper)
            fxe = joint_nll(xe, *args)
            if fxe < fxr:
                sim[n] = xe
                fsim[n] = fxe
            else:
                sim[n] = xr
                fsim[n] = fxr
        elif fxr < fsim[n - 1]:
            sim[n] = xr
            fsim[n] = fxr
        elif fxr < fsim[n]:
            xc = _clip((1 + _PSI * _RHO) * xbar - _PSI * _RHO * worst, lower, upper)
            fxc = joint_nll(xc, *args)
            if fxc <= fxr:
                sim[n] = xc
                fsim[n] = fxc
            else:
                shrink = True
        else:
            xcc = _clip((1 - _PSI) * xbar + _PSI * worst, lower, upper)
            fxcc = joint_nll(xcc, *args)
            if fxcc < fsim[n]:
                sim[n] = xcc
                fsim[n] = fxcc
            else:
                shrink = True
        if shrink:
            for j in range(1, n + 1):
                sim[j] = _clip(sim[0] + _SIGMA * (sim[j] - sim[0]), lower, upper)
                fsim[j] = joint_nll(sim[j], *args)
        iterations += 1
        _sort(sim, fsim)
    best = fsim[0]
    for j in range(1, n + 1):  # np.min(fsim): NaN if any is NaN
        if np.isnan(fsim[j]) or fsim[j] < best:
            best = fsim[j]
    return sim[0].copy(), best, iterations


SERIES_U = 1e-2
"""Below this ``|u|`` the closed forms of ``h(u) = log(expm1(u)/u)`` and its derivatives lose
digits to cancellation; their Taylor series to the kept order are accurate to ~1e-16 there
(:mod:`jamlab.analysis.powerlaw`)."""


@njit(cache=True)
def truncated_score(u: float) -> float:
    """``h'(u) = 1/(1 − e^−u) − 1/u``, the mean of ``log(x/x_min)/L`` under the truncated power
    law with ``u = (1 − τ) L`` (:mod:`jamlab.analysis.powerlaw`)."""
    if abs(u) < SERIES_U:
        return 0.5 + u / 12 - u**3.0 / 720
    if u > 0:
        return -1.0 / math.expm1(-u) - 1.0 / u
    return 1.0 + 1.0 / math.expm1(u) - 1.0 / u


@njit(cache=True)
def truncated_score_root(target: float, xtol: float, rtol: float, maxiter: int) -> float:
    """The ``u`` with ``h'(u) = target`` (``0 < target < 1``): a bracket widened from
    ``[−8, 8]``, then Brent's method as ``scipy.optimize.brentq`` runs it (scipy's
    ``Zeros/brentq.c``, the same operations in the same order, so the same root bit for bit;
    ``ValueError`` on a NaN value, ``RuntimeError`` without convergence in ``maxiter``)."""
    lo, hi = -8.0, 8.0
    while truncated_score(lo) > target:
        lo *= 2
    while truncated_score(hi) < target:
        hi *= 2
    xpre, xcur = lo, hi
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    fpre = truncated_score(xpre) - target
    fcur = truncated_score(xcur) - target
    if np.isnan(fpre) or np.isnan(fcur):
        raise ValueError("the score is NaN; the root cannot be found")
    if fpre * fcur > 0:
        raise ValueError("f(a) and f(b) must have different signs")
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    for _ in range(maxiter):
        if fpre * fcur < 0:
            xblk = xpre
            fblk = fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # good short step
                spre = scur
                scur = stry
            else:  # bisect
                spre = sbis
                scur = sbis
        else:  # bisect
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = truncated_score(xcur) - target
        if np.isnan(fcur):
            raise ValueError("the score is NaN; the root cannot be found")
    raise RuntimeError("the root of the truncated power law's score did not converge")

