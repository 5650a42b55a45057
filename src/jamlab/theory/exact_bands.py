r"""``R(x)`` and the density of ``ΔE`` of the exact recursion on a multi-band grid.

Same recursion and notation as :mod:`jamlab.theory.exact` (``ℓ_i = d√(1 - q_i)``): the level
function ``f_i`` has all its structure within ``|z| ≲ 12 ℓ_i + 2 d² Y(q_i)`` of 0 (beyond it, 0 on
the left and linear on the right up to ``e^{-70}``), and the ground state's backward stress walk
from ``z_{k+1} = x`` has spread ``ℓ_i`` at level ``i``. So instead of one uniform grid that must
resolve the top level's width ``σ_k`` over the whole range ``|z| ≲ d`` (``∝ 1/√(1 - q_k)``
points), every level gets its own lattice ``z = t_i h ℤ`` (``t_i`` a power of two, ``t_i h`` below
``σ_{i-1}/1.3``, ``σ_i/1.3`` and ``ℓ_{i+1}/6``; ``t_{i+1}`` divides ``t_i``) and its own window:
``f_i`` on the window around 0, and, for each ``x``, the walk's (unnormalised) density

    ρ_k(z) = φ_{σ_k}(z - x),   ρ_{i-1} = φ_{σ_{i-1}} * (F_i ρ_i),   R(x) = ∫ F_1 ρ_1 dz,

on ``x ± 12 ℓ_i`` (the ``F_i <= 1`` only shrink it); the derivative ``-R'(x)`` is carried along
(``η_{i-1} = φ * (F_i η_i - D_i ρ_i)``). The cost is ``O(k)`` windows of a few hundred points,
independent of ``1 - q_k``, so the top level can sit at ``1 - q_k = 10^{-12}``. All sums are
trapezoid sums of sampled Gaussians, spectrally accurate as in :mod:`jamlab.theory.exact`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.signal import fftconvolve
from scipy.special import log_ndtr

__all__ = ["BandedRecursion"]

_SQRT2PI = math.sqrt(2.0 * math.pi)
_WIN = 12.0  # window half-widths in units of the level's spread


class BandedRecursion:
    """``R(x)`` and ``-R'(x)`` of the ``k``-level recursion (module docstring).

    ``q``, ``y``: the levels (as :class:`jamlab.theory.exact.CascadeRecursion`); ``dgamma``:
    only ``|δγ|`` enters. ``points_per_sd``: lattice points per ``σ`` (1.3 is spectrally
    accurate to ``~1e-14``); ``points_per_scale``: per width of the ``f_i``'s structure
    (``ℓ_{i+1}``, and ``min(σ_k, 1/y_k)`` at the top); ``max_points``: largest window of one
    level (the top level's window has ``~12 (y_k σ_k)²`` points).
    """

    def __init__(self, q: Any, y: Any, dgamma: float, *, points_per_sd: float = 1.3,
                 points_per_scale: float = 6.0, max_points: int = 4_000_000) -> None:
        from jamlab.theory.cascade import validate_levels

        qa, ya = validate_levels(q, y)
        d = abs(float(dgamma))
        if not d > 0.0 or not math.isfinite(d):
            raise ValueError(f"dgamma must be finite and nonzero, got {dgamma!r}")
        self.q, self.y, self.d, self.k = qa, ya, d, qa.size
        k = self.k
        self.v = np.diff(np.append(qa, 1.0))
        self.sigma = d * np.sqrt(self.v)
        self.alpha = np.diff(np.concatenate(([0.0], ya))) / ya
        self.ell = d * np.sqrt(1.0 - qa)
        tail = np.cumsum((ya * self.v)[::-1])[::-1]  # Y of the steps above q_i
        self.tilt = d * d * tail
        bound = np.empty(k)
        for i in range(k):
            b = self.sigma[i] / points_per_sd
            if i > 0:
                b = min(b, self.sigma[i - 1] / points_per_sd)
            # f_{i+1} varies on ℓ_{i+1}; the top level's f_k' and F_k also on 1/y_k (a
            # logistic step of that width when y_k σ_k > 1)
            top = min(self.sigma[-1], 1.0 / ya[-1])
            b = min(b, (self.ell[i + 1] if i + 1 < k else top) / points_per_scale)
            bound[i] = b
        h = float(bound.min())
        t = 2 ** np.floor(np.log2(bound / h)).astype(np.int64)
        for i in range(1, k):  # non-increasing strides, each dividing the one below
            t[i] = min(t[i], t[i - 1])
        self.h, self.t = h, t
        self._levels(max_points)

    # ------------------------------------------------------------------ f_i on windows
    def _lookup(self, i: int, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``f_i``, ``f_i'`` at absolute lattice indices ``idx`` (multiples of ``t_i``)."""
        lo, f, df = self._lo[i], self._f[i], self._df[i]
        n = f.size
        pos = (idx - lo) // self.t[i]
        inside = np.clip(pos, 0, n - 1)
        fv = f[inside].copy()
        dv = df[inside].copy()
        left = pos < 0
        fv[left] = 0.0
        dv[left] = 0.0
        right = pos > n - 1
        if np.any(right):
            fv[right] = f[-1] + df[-1] * (idx[right] - (lo + (n - 1) * self.t[i])) * self.h
            dv[right] = df[-1]
        return fv, dv

    def _levels(self, max_points: int) -> None:
        k, h, ya = self.k, self.h, self.y
        self._lo = [0] * k
        self._f: list[np.ndarray] = [np.empty(0)] * k
        self._df: list[np.ndarray] = [np.empty(0)] * k
        for i in range(k - 1, -1, -1):
            ti = int(self.t[i])
            half = _WIN * self.ell[i] + 2.0 * self.tilt[i]
            m = int(math.ceil(half / (ti * h)))
            if 2 * m + 1 > max_points:
                raise ValueError(
                    f"exact recursion (bands): level {i + 1} needs {2 * m + 1} lattice points "
                    f"(more than {max_points}): y_k |δγ| √(1 - q_k) = "
                    f"{ya[-1] * self.sigma[-1]:.3g} is too large; lower the top level (a smaller "
                    "q_cut)")
            idx = np.arange(-m, m + 1, dtype=np.int64) * ti
            z = idx * h
            if i == k - 1:
                sk = self.sigma[-1]
                b = ya[-1] * sk
                w = z / sk
                la = ya[-1] * z + 0.5 * b * b + log_ndtr(w + b)
                f = np.logaddexp(log_ndtr(-w), la)
                df = ya[-1] * np.exp(la - f)
            else:
                r = ya[i] / ya[i + 1]
                sg = self.sigma[i]
                M = max(1, int(math.ceil((11.0 + ya[i] * sg) * sg / (ti * h))))
                tt = np.arange(-M, M + 1) * (ti * h)
                kern = ti * h * np.exp(-0.5 * (tt / sg) ** 2) / (_SQRT2PI * sg)
                ext = np.arange(-m - M, m + M + 1, dtype=np.int64) * ti
                fe, de = self._lookup(i + 1, ext)
                win = np.lib.stride_tricks.sliding_window_view(fe, 2 * M + 1)
                dwin = np.lib.stride_tricks.sliding_window_view(de, 2 * M + 1)
                with np.errstate(divide="ignore"):
                    logk = np.log(kern)
                f = np.empty(idx.size)
                df = np.empty(idx.size)
                rows = max(1, 4_000_000 // kern.size)
                for a in range(0, idx.size, rows):  # log-sum-exp centred on each row's maximum
                    ex = r * win[a:a + rows] + logk[None, :]
                    top = ex.max(axis=1)
                    e = np.exp(ex - top[:, None])
                    s = e.sum(axis=1)
                    f[a:a + rows] = top + np.log(s)
                    df[a:a + rows] = r * np.einsum("ij,ij->i", e, dwin[a:a + rows]) / s
            self._lo[i] = int(idx[0])
            self._f[i] = f
            self._df[i] = df

    # ------------------------------------------------------------------ the walk
    def R_and_pdf(self, x: Any) -> tuple[np.ndarray, np.ndarray]:  # noqa: N802
        """``(R(x), -R'(x))`` at the points ``x <= 0``."""
        xa = np.atleast_1d(np.asarray(x, dtype=np.float64)).ravel()
        R = np.empty(xa.size)
        P = np.empty(xa.size)
        for s in range(0, xa.size, 64):
            R[s:s + 64], P[s:s + 64] = self._walk(xa[s:s + 64])
        return R, P

    def R(self, x: Any) -> np.ndarray:  # noqa: N802
        """``R(x) = P(ΔE >= x)``."""
        xa = np.asarray(x, dtype=np.float64)
        return self.R_and_pdf(xa)[0].reshape(np.atleast_1d(xa).shape)

    def dE_pdf(self, x: Any) -> np.ndarray:  # noqa: N802
        """``-R'(x)``."""
        xa = np.asarray(x, dtype=np.float64)
        return self.R_and_pdf(xa)[1].reshape(np.atleast_1d(xa).shape)

    def _window(self, i: int, x: np.ndarray) -> np.ndarray:
        """Absolute indices (rows: the ``x``) of the walk's window at level ``i``."""
        ti, h = int(self.t[i]), self.h
        half = _WIN * self.ell[i]
        m = int(math.ceil(half / (ti * h))) + 1
        start = np.floor((x - half) / (ti * h)).astype(np.int64) * ti
        return start[:, None] + ti * np.arange(2 * m + 1, dtype=np.int64)[None, :]

    def _walk(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k, h = self.k, self.h
        idx = self._window(k - 1, x)
        sk = self.sigma[-1]
        rho = np.exp(-0.5 * ((idx * h - x[:, None]) / sk) ** 2) * (self.t[-1] * h
                                                                  / (_SQRT2PI * sk))
        eta = np.zeros_like(rho)
        for i in range(k - 1, -1, -1):
            f, df = self._lookup(i, idx.ravel())
            F = np.exp(-self.alpha[i] * f).reshape(idx.shape)
            D = (self.alpha[i] * df).reshape(idx.shape) * F
            eta = F * eta + D * rho
            rho = F * rho
            if i == 0:
                break
            # convolve with σ_{i-1} on the level-i lattice, sample on the level-(i-1) window
            ti, tn = int(self.t[i]), int(self.t[i - 1])
            sg = self.sigma[i - 1]
            M = max(1, int(math.ceil(13.0 * sg / (ti * h))))
            tt = np.arange(-M, M + 1) * (ti * h)
            kern = np.exp(-0.5 * (tt / sg) ** 2) / (_SQRT2PI * sg) * (tn * h)
            both = fftconvolve(np.concatenate([rho, eta]), kern[None, :], mode="full", axes=-1)
            new = self._window(i - 1, x)
            first = idx[:, :1] - M * ti  # absolute index of the full output's first entry
            pos = (new - first) // ti
            ok = (pos >= 0) & (pos < both.shape[1])  # beyond: Gaussian tails < e^{-84}
            pos = np.clip(pos, 0, both.shape[1] - 1)
            n = x.size
            rows = np.arange(n)[:, None]
            rho = np.where(ok, both[:n][rows, pos], 0.0)
            eta = np.where(ok, both[n:][rows, pos], 0.0)
            idx = new
        # ρ, η are masses per lattice point (density × lattice spacing)
        return rho.sum(axis=1), eta.sum(axis=1)
