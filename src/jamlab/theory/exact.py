r"""Exact jump law of the ``k``-level cascade (the corrected theory).

Notation of SPEC §2, ``d = |δγ|``, ``v_i = q_{i+1} - q_i``, ``σ_i = d √v_i``,
``Δy_i = y_i - y_{i-1}`` (``y_0 = 0``), ``α_i = Δy_i / y_i``, ``r_i = y_i / y_{i+1}``.
``R(x) = P(ΔE >= x)`` for ``x <= 0``; ``R(0)`` is the no-jump probability.

Derivation (``docs/theory-vs-cascade.md`` §2 and §7). Write the ground state's path
``(u_i, s_i)_{i=1..k}`` (energy and stress increments from its level-``i`` ancestor ``n_i``). By the
Mecke formula, the path has intensity ``Π e^{y_i u_i} φ_{v_i}(s_i)`` and the other children of each
``n_i`` are an independent copy of the Poisson process, all of whose states must satisfy
``U > U_gs`` and ``U - dΣ > U_gs - dΣ_gs + x``. For a level-``i`` node at the origin,
``P(all its states satisfy U > t and U - dΣ > h) = exp(-e^{y_i t} g_i(h - t))``,
``g_i = (c_i⁰/y_i) e^{f_i}``, with the Parisi-type recursion

    f_k(z) = log E_s[e^{y_k (z + d s)⁺}]
           = log[Φ(-z/σ_k) + e^{y_k z + y_k² σ_k²/2} Φ(z/σ_k + y_k σ_k)],
    f_i(z) = log E_s[exp(r_i f_{i+1}(z + d s))],        s ~ N(0, v_i).

The energy integrals factorise and

    R(x) = E_path[ Π_i F_i(z_i) ],   F_i = e^{-α_i f_i},   z_i = x - d S_i,

``S_i`` the ground state's stress relative to ``n_i`` (a Gaussian walk, ``z_{k+1} = x``,
``z_i = z_{i+1} - d s_i``). ``F_i(z)`` is the probability, given the ground state's path, that the
level-``i`` cluster (states whose deepest common ancestor with the ground state is ``n_i``) has
no state below the threshold: the cluster is a mixed (Cox) Poisson process, ``λ ~ Gamma(α_i)``.

*The whole law.* The new ground state (the winner) lies in the level-``i`` cluster with
``ΔE ∈ dx`` with density ``p_i(x) = E_path[D_i(z_i) Π_{j≠i} F_j(z_j)]``, ``D_i = -F_i' =
α_i f_i' F_i``; ``Σ_i p_i = -R'``. Applying the Mecke formula to the pair (ground state, winner),
the winner's own path from ``n_i`` is a second Gaussian walk from ``z_i`` to its energy
``w = ΔU > 0`` (variance ``σ_j²`` per level, weight ``F_j`` at its levels ``j > i``), with end
weight ``e^{y_k w}``, and the branch point carries ``W_i = α_i y_i e^{-(1+α_i) f_i} B_i``: the
joint density of ``(x = ΔE, w = ΔU)`` is

    p(x, w) = e^{y_k w} Σ_i ∫ dz G_i(z; x) W_i(z) G_i(z; w),      x < 0 < w,

``G_k(z; x) = φ_{σ_k}(z - x)``, ``G_i = φ_{σ_i} * (F_{i+1} G_{i+1})`` (the ground state's walk
from ``x`` and the winner's walk to ``w`` obey the same recursion), ``B_1 = 1``,
``B_{i+1} = φ_{σ_i} * (F_i B_i)`` (so ``R = B_{k+1}``). ``ΔΣ = (w - x)/d > 0``. The identity
``(e^{f_i})' = y_i ∫ dw e^{y_k w} G_i(·; w)`` makes ``∫ dw p(x, w) = -R'(x)``.

Numerics: every function on one uniform grid ``z = h·ℤ`` with ``h <= σ_min/1.5`` and
``h <= σ_k/4``; Gaussian convolutions as trapezoid sums over the grid (spectrally accurate: the
aliasing error of a sampled Gaussian is ``~e^{-2π²σ²/h²}``), the log-recursion for ``f_i`` centred
on ``f_{i+1}(z)`` so that no exponential overflows, its derivative by the same sums. The last
convolution is evaluated at arbitrary points, so ``R``, the densities of ``ΔE`` and ``ΔU`` need no
interpolation; the ``ΔΣ`` law uses a Chebyshev tensor interpolant of ``p(x, w)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import integrate
from scipy.ndimage import correlate1d
from scipy.signal import fftconvolve
from scipy.special import log_ndtr, ndtr

from jamlab import validation

__all__ = [
    "CascadeRecursion",
    "exact_jump_R",
    "level_functions",
    "one_level_A",
    "one_level_R",
]

_SQRT2PI = math.sqrt(2.0 * math.pi)


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


def _check_x(x: Any) -> np.ndarray:
    """``x`` as a float64 array (at least 1-d); ValueError if any ``x`` is NaN or ``> 0``
    (``R(x) = P(ΔE >= x)`` is asked of ``x <= 0`` only, ``ΔE <= 0``)."""
    xa = np.atleast_1d(np.asarray(x, dtype=np.float64))
    if np.any(np.isnan(xa)):
        raise ValueError(f"x must not be NaN, got x = {float(xa[np.isnan(xa)][0])!r}")
    if np.any(xa > 0):
        raise ValueError(f"x must be <= 0, got max x = {float(xa.max())!r}")
    return xa


def one_level_R(x: float, y: float, dgamma: float, v: float = 1.0) -> float:
    """Exact ``R(x) = P(ΔE >= x)`` for one level (``k = 1``, stress variance ``v = 1 - q_1``).

    Given the ground state's stress ``σ0 ~ N(0, v)``, the other states are a Poisson process on
    ``u > u_0`` mixed by ``λ = e^{y u_0}/y ~ Exp(1)``, so
    ``R(x) = ∫ φ_v(σ0) / (1 + A_x(σ0)) dσ0`` (:func:`one_level_A`).

    Arguments as for :func:`exact_jump_R` with ``q = [1 - v]``, ``y = [y]``: ``x <= 0``, ``y > 0``,
    ``0 < v <= 1``, ``dgamma`` finite (``R = 1`` at ``dgamma = 0``); others are a ValueError.
    """
    _check_x(x)
    validation.positive("y", y)
    validation.number("dgamma", dgamma)
    validation.number("v = 1 - q_1", v, low=0.0, low_open=True, high=1.0)
    d = abs(float(dgamma))
    if d == 0.0:
        return 1.0
    sd = np.sqrt(v)

    def integrand(s0: float) -> float:
        return float(np.exp(-0.5 * s0 * s0 / v) / (np.sqrt(2 * np.pi) * sd)
                     / (1.0 + one_level_A(x, s0, y, d, v)))

    val, _ = integrate.quad(integrand, -12 * sd, 12 * sd, epsabs=1e-13, epsrel=1e-12, limit=200)
    return float(val)


def _kernel(sigma: float, h: float, extra: float = 0.0) -> np.ndarray:
    """``h φ_σ(t h)`` for ``|t h| <= (11 + extra) σ`` (trapezoid weights of a Gaussian)."""
    m = max(1, int(math.ceil((11.0 + extra) * sigma / h)))
    t = np.arange(-m, m + 1) * h
    return h * np.exp(-0.5 * (t / sigma) ** 2) / (_SQRT2PI * sigma)


def _conv(g: np.ndarray, kern: np.ndarray) -> np.ndarray:
    """Gaussian smoothing of bounded grid functions along the last axis; beyond the grid each
    function is continued by its edge value (all path functions tend to constants). Wide kernels
    go through the FFT (absolute error ~1e-16 of the largest value)."""
    if kern.size < 48:
        return correlate1d(g, kern, axis=-1, mode="nearest")
    m = (kern.size - 1) // 2
    g2 = np.atleast_2d(g)
    gp = np.concatenate([np.repeat(g2[:, :1], m, axis=1), g2, np.repeat(g2[:, -1:], m, axis=1)],
                        axis=1)
    out = fftconvolve(gp, kern[None, ::-1], mode="valid", axes=-1)
    return out[0] if g.ndim == 1 else out


def _smooth_log(f: np.ndarray, df: np.ndarray, r: float, sigma: float, h: float,
                tilt: float, stride: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``log E[exp(r f(z + σξ))]`` and its derivative on the grid (``f → 0`` on the left, linear
    on the right beyond the grid), centred on ``r f(z)``. ``tilt`` bounds ``r σ f'``; the sum
    uses every ``stride``-th grid point (``f`` smooth on that scale, ``σ >= 1.3 stride h``)."""
    hs = h * stride
    kern = _kernel(sigma, hs, extra=tilt)
    M = (kern.size - 1) // 2
    m = M * stride
    n = f.size
    fp = np.empty(n + 2 * m)
    dp = np.empty(n + 2 * m)
    fp[:m] = 0.0
    dp[:m] = 0.0
    fp[m:m + n] = f
    dp[m:m + n] = df
    slope = df[-1]
    fp[m + n:] = f[-1] + slope * h * np.arange(1, m + 1)
    dp[m + n:] = slope
    win = np.lib.stride_tricks.sliding_window_view(fp, 2 * m + 1)[:, ::stride]
    dwin = np.lib.stride_tricks.sliding_window_view(dp, 2 * m + 1)[:, ::stride]
    out_f = np.empty(n)
    out_d = np.empty(n)
    rows = max(1, 4_000_000 // kern.size)
    for a in range(0, n, rows):
        e = np.exp(r * (win[a:a + rows] - f[a:a + rows, None])) * kern[None, :]
        ssum = e.sum(axis=1)
        out_f[a:a + rows] = r * f[a:a + rows] + np.log(ssum)
        out_d[a:a + rows] = r * np.einsum("ij,ij->i", e, dwin[a:a + rows]) / ssum
    return out_f, out_d


class CascadeRecursion:
    """The exact recursion of the module docstring solved on a grid for levels ``(q, y)``.

    ``q``, ``y``: ``k`` levels as for :func:`jamlab.theory.sample_cascade_jumps`; ``dgamma``
    (only ``|δγ|`` enters; ``d > 0``). ``points_per_sd``: grid points per smallest level width
    ``σ_min`` (1.5 is spectrally accurate); ``points_per_scale``: grid points per ``σ_k``, the
    width of the finest structure of the ``f_i``.

    Attributes: ``z`` (grid), ``h``, ``f``, ``df`` (``f_i``, ``f_i'`` as ``(k, n)``), ``B``
    (``B_i``, ``i = 1..k``), ``x_lo`` (below it ``P(ΔE < x_lo) < 1e-14``), ``w_hi``, ``edge``
    (``z_0 + 12 σ_k <= x_lo``: below it :meth:`R` is 1, the grid's sum being short there).
    """

    def __init__(self, q: Any, y: Any, dgamma: float, *, points_per_sd: float = 1.5,
                 points_per_scale: float = 4.0, max_points: int = 400_000) -> None:
        from jamlab.theory.cascade import validate_levels

        qa, ya = validate_levels(q, y)
        d = abs(float(dgamma))
        if not d > 0.0 or not math.isfinite(d):
            raise ValueError(f"dgamma must be finite and nonzero, got {dgamma!r}")
        self.q, self.y, self.d = qa, ya, d
        self.k = qa.size
        self.v = np.diff(np.append(qa, 1.0))
        self.sigma = d * np.sqrt(self.v)
        self.alpha = np.diff(np.concatenate(([0.0], ya))) / ya
        L = d * math.sqrt(1.0 - qa[0])
        T = d * d * float(np.sum(ya * self.v))  # d² Y(q_1): the scale of the tilt
        self.x_lo = -(12.0 * L + 2.0 * T)
        self.w_hi = 12.0 * L + 2.0 * T
        h = min(float(self.sigma.min()) / points_per_sd, float(self.sigma[-1]) / points_per_scale)
        lo = int(math.floor((self.x_lo - 12.0 * L) / h))
        hi = int(math.ceil((self.w_hi + 2.0 * L) / h))
        if hi - lo + 1 > max_points:
            raise ValueError(
                f"exact recursion: a grid of {hi - lo + 1} points is needed (more than "
                f"{max_points}); use fewer levels or a larger smallest level spacing")
        self.h = h
        self.z = np.arange(lo, hi + 1) * h
        # below z_0 + 12σ_k (<= x_lo) the grid's Gaussian sum misses the mass past its first
        # point (R ≈ ½ at z_0, 0 below), while R = 1 there within the grid's accuracy
        # (P(ΔE < x_lo) < 1e-14; R(-∞) = 1 exactly)
        self.edge = float(self.z[0] + 12.0 * self.sigma[-1])
        self._kern = [_kernel(s, h) for s in self.sigma]
        self.f, self.df = self._level_functions()
        self.B = self._B_sweep()

    # ---------------------------------------------------------------- recursions
    def _level_functions(self) -> tuple[np.ndarray, np.ndarray]:
        z, k, ya = self.z, self.k, self.y
        f = np.empty((k, z.size))
        df = np.empty((k, z.size))
        sk = self.sigma[-1]
        b = ya[-1] * sk
        w = z / sk
        la = ya[-1] * z + 0.5 * b * b + log_ndtr(w + b)
        f[-1] = np.logaddexp(log_ndtr(-w), la)
        df[-1] = ya[-1] * np.exp(la - f[-1])
        for i in range(k - 2, -1, -1):
            r = ya[i] / ya[i + 1]
            # f_{i+1} is smooth on the scale d √(1 - q_{i+1}): coarse levels may skip points
            scale = min(self.sigma[i] / 1.3, self.d * math.sqrt(1.0 - self.q[i + 1]) / 6.0)
            stride = max(1, int(scale / self.h))
            f[i], df[i] = _smooth_log(f[i + 1], df[i + 1], r, self.sigma[i], self.h,
                                      tilt=ya[i] * self.sigma[i], stride=stride)
        return f, df

    def F(self, i: int) -> np.ndarray:  # noqa: N802
        """``F_i = exp(-α_i f_i)`` on the grid (``i`` is 0-based)."""
        return np.exp(-self.alpha[i] * self.f[i])

    def D(self, i: int) -> np.ndarray:  # noqa: N802
        """``D_i = -F_i' = α_i f_i' F_i`` on the grid."""
        return self.alpha[i] * self.df[i] * self.F(i)

    def W(self, i: int) -> np.ndarray:  # noqa: N802
        """Branch-point weight ``W_i = α_i y_i e^{-(1+α_i) f_i} B_i``."""
        return self.alpha[i] * self.y[i] * np.exp(-(1.0 + self.alpha[i]) * self.f[i]) * self.B[i]

    def _B_sweep(self) -> np.ndarray:
        B = np.empty((self.k, self.z.size))
        B[0] = 1.0
        for i in range(self.k - 1):
            B[i + 1] = _conv(self.F(i) * B[i], self._kern[i])
        return B

    def _last(self, g: np.ndarray, x: np.ndarray, below: float | None = None) -> np.ndarray:
        """``∫ φ_{σ_k}(x - z) g(z) dz`` at arbitrary points ``x`` (trapezoid over the grid);
        with ``below``, that value at ``x <`` :attr:`edge` (the sum taken at ``max(x, edge)``:
        every ``x`` above keeps its value)."""
        if below is not None:
            return np.where(x < self.edge, below, self._last(g, np.maximum(x, self.edge)))
        sk = self.sigma[-1]
        out = np.empty(x.size)
        z, h = self.z, self.h
        for s in range(0, x.size, 256):
            xs = x[s:s + 256]
            ker = np.exp(-0.5 * ((xs[:, None] - z[None, :]) / sk) ** 2) * (h / (_SQRT2PI * sk))
            # einsum, not ker @ g: BLAS's gemv sums a row in an order that depends on how many
            # rows the call holds, so R(x) would change in the last bit with its batch
            out[s:s + 256] = np.einsum("ij,j->i", ker, g)
        return out

    # ---------------------------------------------------------------- ΔE
    def R(self, x: Any) -> np.ndarray:  # noqa: N802
        """``R(x) = P(ΔE >= x)`` for ``x <= 0`` (``B_{k+1}(x)``; 1 below :attr:`edge`)."""
        xa = np.atleast_1d(np.asarray(x, dtype=np.float64))
        k = self.k - 1
        return self._last(self.F(k) * self.B[k], xa.ravel(), below=1.0).reshape(xa.shape)

    def _V_last(self) -> np.ndarray:  # noqa: N802
        V = np.zeros(self.z.size)
        for i in range(self.k - 1):
            V = _conv(self.F(i) * V + self.D(i) * self.B[i], self._kern[i])
        k = self.k - 1
        return self.F(k) * V + self.D(k) * self.B[k]

    def dE_pdf(self, x: Any) -> np.ndarray:  # noqa: N802
        """Density ``-R'(x)`` of ``ΔE`` at ``x < 0`` (the jumps' part of the law; 0 below
        :attr:`edge`, where :meth:`R` is 1)."""
        xa = np.atleast_1d(np.asarray(x, dtype=np.float64))
        if not hasattr(self, "_vlast"):
            self._vlast = self._V_last()
        return self._last(self._vlast, xa.ravel(), below=0.0).reshape(xa.shape)

    # ---------------------------------------------------------------- overlap and ΔU
    def _forward_all_x(self) -> None:
        """Ground-state walks started uniformly on ``x <= 0``: the masses of the clusters
        ``P_i = ∫_{-∞}^0 p_i(x) dx`` and the ``ΔU`` end function."""
        k = self.k
        Pf = ndtr(-self.z / self.sigma[-1])  # ∫_{-∞}^0 φ_{σ_k}(z - x) dx
        masses = np.empty(k)
        A = np.empty((k, self.z.size))
        for i in range(k - 1, -1, -1):
            if i < k - 1:
                Pf = _conv(self.F(i + 1) * Pf, self._kern[i])
            masses[i] = self.h * float(np.sum(Pf * self.D(i) * self.B[i]))
            A[i] = Pf * self.W(i)
        E = np.zeros(self.z.size)
        for i in range(k - 1):
            E = _conv(E * self.F(i) + A[i], self._kern[i])
        self._masses = masses
        self._uend = E * self.F(k - 1) + A[k - 1]

    def cluster_masses(self) -> np.ndarray:
        """``P(the new ground state is in the level-i cluster)``, ``i = 1..k`` (overlap ``q_i``)."""
        if not hasattr(self, "_masses"):
            self._forward_all_x()
        return self._masses.copy()

    def dU_pdf(self, w: Any) -> np.ndarray:  # noqa: N802
        """Density of ``ΔU`` at ``w > 0`` (jumps only; ``0`` for ``w <= 0``)."""
        wa = np.atleast_1d(np.asarray(w, dtype=np.float64))
        if not hasattr(self, "_uend"):
            self._forward_all_x()
        flat = wa.ravel()
        out = np.zeros(flat.size)
        pos = flat > 0
        if np.any(pos):
            # e^{y_k w} overflows (w → ∞) only where the Gaussian tail has underflowed to 0
            tail = self._last(self._uend, flat[pos])
            on = tail != 0.0
            tail[on] *= np.exp(self.y[-1] * flat[pos][on])
            out[pos] = tail
        return out.reshape(wa.shape)

    def dU_cdf_jumps(self, w: Any) -> np.ndarray:  # noqa: N802
        """``P(0 < ΔU <= w)``, exactly: ``∫_0^w e^{y_k u} φ_{σ_k}(u - z) du`` in closed form."""
        wa = np.atleast_1d(np.asarray(w, dtype=np.float64))
        if not hasattr(self, "_uend"):
            self._forward_all_x()
        yk, sk = self.y[-1], self.sigma[-1]
        z, h, g = self.z, self.h, self._uend
        flat = np.maximum(wa.ravel(), 0.0)
        out = np.empty(flat.size)
        shift = yk * sk * sk
        a = log_ndtr((-z - shift) / sk)
        base = yk * z + 0.5 * shift * yk
        for s in range(0, flat.size, 256):
            b = log_ndtr((flat[s:s + 256, None] - z[None, :] - shift) / sk)
            # e^{y z + y² σ²/2} [Φ(b) - Φ(a)], b >= a
            with np.errstate(divide="ignore"):
                lg = base[None, :] + b + np.log(-np.expm1(np.minimum(a[None, :] - b, 0.0)))
            out[s:s + 256] = h * (np.exp(lg) @ g)
        return out.reshape(wa.shape)

    # ---------------------------------------------------------------- joint (ΔE, ΔU)
    def joint_on_nodes(self, xn: np.ndarray, wn: np.ndarray) -> np.ndarray:
        """``p(x, w) e^{-y_k w}`` (module docstring) on the tensor grid ``xn × wn``."""
        nodes = np.concatenate([xn, wn])
        nx = xn.size
        sk = self.sigma[-1]
        G = np.exp(-0.5 * ((self.z[None, :] - nodes[:, None]) / sk) ** 2) / (_SQRT2PI * sk)
        out = np.zeros((nx, wn.size))
        for i in range(self.k - 1, -1, -1):
            if i < self.k - 1:
                G = _conv(G * self.F(i + 1)[None, :], self._kern[i])
            out += (G[:nx] * (self.W(i) * self.h)[None, :]) @ G[nx:].T
        return out


def level_functions(q: Any, y: Any, dgamma: float, **grid: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(z, f)``: the grid and ``f_i(z)``, ``i = 1..k`` (rows), of the recursion (module doc)."""
    rec = CascadeRecursion(q, y, dgamma, **grid)
    return rec.z, rec.f


def exact_jump_R(
    q: Any,
    y: Any,
    dgamma: float,
    x: Any = 0.0,
    *,
    decouple_path: bool = False,
    poisson_clusters: bool = False,
    **grid: Any,
) -> np.ndarray:
    """Exact ``R(x) = P(ΔE >= x)`` of the ``k``-level cascade (module docstring), ``x <= 0``;
    ``R = 1`` below the grid's range (``x <`` :attr:`CascadeRecursion.edge`, ``-∞`` included).

    ``decouple_path=True`` replaces the ground state's correlated stress path by independent
    ``S_i ~ N(0, 1 - q_i)`` per level (``R ≈ Π_i E[exp(-(Δy_i/y_i) f_i(x - d S_i))]``): the
    diagonal approximation of the paper's Hubbard–Stratonovich step; for diagnosis only.

    ``poisson_clusters=True`` replaces each cluster's Gamma mixing by its mean: the factor
    ``(1 + A_i)^{-Δy_i/y_i} = exp(-(Δy_i/y_i) f_i)``, ``A_i = e^{f_i} - 1``, becomes
    ``exp(-(Δy_i/y_i) A_i)`` (clusters seen from the ground state taken as plain Poisson
    processes); for diagnosis only. ``grid``: options of :class:`CascadeRecursion`.
    """
    xa = _check_x(x)
    if float(dgamma) == 0.0:
        from jamlab.theory.cascade import validate_levels

        validate_levels(q, y)
        return np.ones_like(xa)
    rec = CascadeRecursion(q, y, dgamma, **grid)
    if not (decouple_path or poisson_clusters):
        return rec.R(xa)
    k, d, qa = rec.k, rec.d, rec.q
    if poisson_clusters:
        F = np.exp(-rec.alpha[:, None] * np.expm1(np.minimum(rec.f, 700.0)))
    else:
        F = np.exp(-rec.alpha[:, None] * rec.f)
    if decouple_path:
        gx, gw = np.polynomial.hermite_e.hermegauss(80)
        gw = gw / gw.sum()
        out = np.ones_like(xa)
        for i in range(k):
            sd = d * math.sqrt(1.0 - qa[i])
            for j, xv in enumerate(xa):
                out[j] *= float(np.sum(gw * np.interp(xv - sd * gx, rec.z, F[i])))
        return out
    B = np.ones(rec.z.size)
    for i in range(k - 1):
        B = _conv(F[i] * B, rec._kern[i])
    return rec._last(F[k - 1] * B, xa.ravel(), below=1.0).reshape(xa.shape)

