"""The mean-field static jump distribution ``P(ΔE | δγ)`` of SPEC §1, as printed in the paper.

For a Parisi function ``y(q)`` (see :mod:`jamlab.theory.parisi`) and a strain step ``δγ``::

    ρ(x)        = exp(-x²/4)/√π + (x/2) erfc(-x/2),           ρ'(x) = erfc(-x/2)/2
    x(q)        = (ΔE + δγ² Y(q)) / (√(1-q) |δγ|)
    C(ΔE, δγ)   = |δγ| ∫ dq y'(q) √(1-q) ρ(x(q)),              R = exp(-C)
    ∂C/∂ΔE      = ½ ∫ dq y'(q) erfc(-x(q)/2)
    P(ΔE | δγ)  = δ(ΔE) R(0, δγ) + θ(-ΔE) R(ΔE) ∂C/∂ΔE

The ``y'`` integrals include the atom at ``q = 0`` (and every atom of a step function) and run
over ``[0, q_max]``.

Numerics. The integrand's features sit at ``1 - q ~ (ΔE/δγ)²`` (as small as 1e-24 here) and, when
``δγ² Y(q)`` exceeds ``|ΔE|``, at the zero ``q*`` of ``ΔE + δγ² Y(q)`` where ``x`` changes sign,
possibly within a tiny range of ``q``. The ``q`` integrals are therefore done in
``s = -log(1 - q)`` (so ``dq = e^{-s} ds``) with fixed composite Gauss–Legendre panels: uniform
panels of width ``<= 0.5`` on ``[0, s_end]``, panels graded geometrically towards ``s*``, and panel
edges at the kinks of ``y'``. ``s_end`` is where ``x <= -20`` (beyond it ``ρ`` and ``erfc(-x/2)``
are below ``1e-40``) or the cut-off ``s_max = -log(1 - q_max)``. Rows of one call share those
panels in blocks, except in the far tail (``x(q=0) < -9`` or so, ``C`` below ~1e-13): there the
integrands fall as ``e^{-x(0)² s/4}`` from ``s = 0`` and each row gets panels of its own graded in
``x(0)² s/4`` (see ``PrintedJumpDistribution._steep``), so that ``C`` keeps its relative accuracy
down to ``1e-300`` whatever the other rows of the call. ``ρ`` is evaluated in a form free
of cancellation for ``x < 0`` (see :func:`rho_and_erfc`). ``1 - R`` is computed as
``-expm1(-C)`` so that the cdf keeps its relative accuracy where it is small.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import erfcx

from jamlab import validation
from jamlab.theory.parisi import ParisiFunction

FloatArray = NDArray[np.float64]

_SQRT_PI = math.sqrt(math.pi)
_INV_SQRT_PI = 1.0 / _SQRT_PI
_X_CUT = 20.0  # |x| beyond which e^{-x²/4} < 1e-43: the integrand is negligible
_PANEL_WIDTH = 0.5  # in s = -log(1-q)
_GL_ORDER = 10
_GL_T, _GL_W = np.polynomial.legendre.leggauss(_GL_ORDER)
_CHUNK = 400_000  # quadrature nodes per vectorised block (memory bound)
_S_LIMIT = 700.0  # deepest s = -log(1-q) used: 1 - q = e^-700 ~ 1e-304 is still a normal float
# Rows whose integrands fall from q = 0 at a rate k0 > _K_STEEP in s (x(0) < -9, C below ~1e-13
# for the usual y and δγ) get panels graded in τ = k0 (e^s - 1) ~ x²/4 - x(0)²/4 (the integrands
# go as e^{-τ}): Gauss–Legendre of order 10 is exact to rounding on e^{-τ} over a width 5; beyond
# τ = 80 the integrands are below e^{-80} of their value at s = 0.
_K_STEEP = 20.0
_STEEP_TAU = np.array(
    [0, 0.5, 1, 1.5, 2, 2.5, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 19, 22, 26, 30, 35, 40, 46, 52, 60]
    + [70, 80],
    dtype=np.float64,
)

# coefficients of 1 - √π z erfcx(z) = Σ_{n>=1} (-1)^{n+1} (2n-1)!! / (2z²)^n  (asymptotic, z >= 10)
_ASYM_N = 16
_ASYM_C = np.array(
    [(-1.0) ** (n + 1) * float(np.prod(np.arange(1, 2 * n, 2))) for n in range(1, _ASYM_N + 1)]
)


def rho_and_erfc(x: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Return ``(ρ(x), erfc(-x/2))`` with full relative accuracy for all real ``x``.

    With ``w = |x|/2`` and ``g(w) = e^{-w²} (1/√π - w erfcx(w)) = ρ(-|x|)``: for ``x < 0``,
    ``ρ = g`` and ``erfc(-x/2) = erfc(w)``; for ``x >= 0``, ``ρ = x + g`` (``ρ(x) - ρ(-x) = x``)
    and ``erfc(-x/2) = 2 - erfc(w)``. The bracket of ``g`` cancels for large ``w``; there
    (``w >= 10``) its asymptotic series ``Σ (-1)^{n+1} (2n-1)!!/(2w²)^n / √π`` is used.
    """
    x = np.asarray(x, dtype=np.float64)
    w = 0.5 * np.abs(x)
    e = np.exp(-w * w)
    ex = erfcx(w)
    big = w >= 10.0
    bracket = _INV_SQRT_PI - w * ex
    if np.any(big):
        inv = 1.0 / (2.0 * w[big] ** 2)
        series = np.zeros_like(inv)
        for c in _ASYM_C[::-1]:  # Horner in 1/(2w²)
            series = (series + c) * inv
        bracket[big] = series * _INV_SQRT_PI
    g = e * bracket
    erfc_w = e * ex
    neg = x < 0.0
    rho = np.where(neg, g, x + g)
    ec = np.where(neg, erfc_w, 2.0 - erfc_w)
    return rho, ec


def s_of_q(q: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore"):  # q = 1 maps to s = inf on purpose
        return -np.log1p(-q)


def panel_nodes(edges: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Gauss–Legendre nodes and weights for sorted panel edges of shape (rows, P+1)."""
    a = edges[:, :-1, None]
    b = edges[:, 1:, None]
    half = 0.5 * (b - a)
    s = (0.5 * (a + b) + half * _GL_T).reshape(edges.shape[0], -1)
    w = (half * _GL_W).reshape(edges.shape[0], -1)
    return s, w


def panel_edges(pf: ParisiFunction, s_end: FloatArray,
                extra: FloatArray | None = None) -> FloatArray:
    """Sorted panel edges per row: uniform in ``[0, s_end]``, plus ``extra`` and ``y'`` kinks."""
    n_uni = max(1, int(math.ceil(float(np.max(s_end)) / _PANEL_WIDTH)))
    parts = [s_end[:, None] * np.linspace(0.0, 1.0, n_uni + 1)[None, :]]
    if extra is not None:
        parts.append(extra)
    return _with_kinks(pf, parts, s_end)


def _with_kinks(pf: ParisiFunction, parts: list[FloatArray], s_end: FloatArray) -> FloatArray:
    """The edge columns ``parts`` and the ``y'`` kinks, clipped to ``[0, s_end]`` and sorted per
    row."""
    kinks = s_of_q(pf.breakpoints_q())
    if kinks.size:
        parts = [*parts, np.broadcast_to(kinks, (s_end.size, kinks.size))]
    edges = np.concatenate(parts, axis=1)
    edges = np.minimum(np.maximum(edges, 0.0), s_end[:, None])
    return np.sort(edges, axis=1)


def _grading(s_star: FloatArray, width: FloatArray) -> FloatArray:
    """Panel edges graded geometrically (ratio 1/2) towards ``s*`` from both sides, down to the
    width of the sign change of ``x`` there (at most 2^-50: below that the change is a step)."""
    finite = np.isfinite(width)
    w_min = float(np.min(width[finite])) if np.any(finite) else np.inf
    depth = 0
    if w_min < _PANEL_WIDTH:
        depth = min(50, int(math.ceil(math.log2(_PANEL_WIDTH / max(w_min, 1e-300)))) + 2)
    offsets = _PANEL_WIDTH * 0.5 ** np.arange(depth + 1)
    return np.concatenate(
        [s_star[:, None] - offsets, s_star[:, None], s_star[:, None] + offsets], axis=1
    )


def _steep_edges(pf: ParisiFunction, k0: FloatArray, s_end: FloatArray) -> FloatArray:
    """Panel edges of the steep rows (:meth:`PrintedJumpDistribution._steep`): ``s`` with
    ``k0 (e^s - 1) = τ`` for ``τ`` in :data:`_STEEP_TAU` (``x²/4`` grows by about ``τ`` from
    ``s = 0``; the integrands fall as ``e^{-τ}``), the ``y'`` kinks and ``s_end``; clipped to
    ``[0, s_end]``. The same number of edges for every row: a row's panels do not depend on the
    other rows of the call."""
    return _with_kinks(pf, [np.log1p(_STEEP_TAU[None, :] / k0[:, None]), s_end[:, None]], s_end)


class PrintedJumpDistribution:
    """``P(ΔE | δγ)`` exactly as printed in Franz & Spigler (2017), eqs. (final)–(functionr).

    Behaves like a ``scipy.stats`` distribution of the energy jump ``ΔE <= 0``: ``pdf`` (continuous
    part), ``cdf`` (with the atom ``R(0)`` at 0), ``sf``, ``rvs``; plus ``C``, ``R``, ``dC`` and
    ``p_no_jump``. See the module docstring for the formulas. Symmetric under ``δγ → -δγ``.

    SPEC §1 records that this continuum formula is not exact at finite ``δγ``; it stays available
    under this name beside any corrected version.
    """

    def __init__(self, parisi: ParisiFunction, dgamma: float) -> None:
        if not isinstance(parisi, ParisiFunction):
            raise TypeError(f"parisi must be a ParisiFunction, got {type(parisi).__name__}")
        dgamma = float(dgamma)
        if not math.isfinite(dgamma) or dgamma == 0.0:
            raise ValueError(f"dgamma must be finite and nonzero, got {dgamma}")
        self.parisi = parisi
        self.dgamma = dgamma
        self._a = abs(dgamma)
        self._s_max = float(s_of_q(np.float64(parisi.q_max)))
        self._atoms_q, self._atoms_m = parisi.atoms()
        self._has_density = parisi.has_density()
        self._c0: float | None = None  # C(0, δγ), computed once (:meth:`_C0`)

    # ------------------------------------------------------------------ core integrals
    def _x(self, dE: FloatArray, s: FloatArray) -> FloatArray:
        u = np.exp(-s)
        B = dE + self.dgamma**2 * self.parisi.Y_u(u)
        return B * np.exp(0.5 * s) / self._a

    def _crossing(self, dE: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``s*`` where ``ΔE + δγ² Y = 0`` (0 if no crossing) and the width of the sign change
        of ``x`` there, ``1/(|δγ| y(q*) √(1-q*))``."""
        d2 = self.dgamma**2
        Y0 = float(self.parisi.Y_u(np.float64(1.0)))
        has = d2 * Y0 + dE > 0.0
        s_star = np.zeros_like(dE)
        width = np.full_like(dE, np.inf)
        if not np.any(has):
            return s_star, width
        de = dE[has]
        lo = np.zeros_like(de)
        hi = np.minimum(np.full_like(de, 2.0), self._s_max)
        # B(s) = ΔE + δγ² Y(e^{-s}) decreases to ΔE < 0 (or to B(s_max)); bracket the zero
        for _ in range(2000):
            bad = (de + d2 * self.parisi.Y_u(np.exp(-hi)) > 0.0) & (hi < self._s_max)
            if not np.any(bad):
                break
            hi[bad] = np.minimum(2.0 * hi[bad], self._s_max)
        inside = de + d2 * self.parisi.Y_u(np.exp(-hi)) <= 0.0
        for _ in range(64):
            mid = 0.5 * (lo + hi)
            pos = de + d2 * self.parisi.Y_u(np.exp(-mid)) > 0.0
            lo = np.where(pos, mid, lo)
            hi = np.where(pos, hi, mid)
        ss = np.where(inside, 0.5 * (lo + hi), self._s_max)
        u = np.exp(-np.minimum(ss, _S_LIMIT))
        yq = self.parisi.y_u(u)
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            wd = 1.0 / (self._a * yq * np.sqrt(u))
        s_star[has] = np.where(inside, ss, 0.0)
        width[has] = np.where(inside, wd, np.inf)
        return s_star, width

    def _s_end(self, dE: FloatArray, s_star: FloatArray) -> FloatArray:
        with np.errstate(divide="ignore"):
            s_end = np.maximum(2.0 * np.log(_X_CUT * self._a / np.abs(dE)), s_star + 1.0)
        s_end = np.minimum(np.maximum(s_end, 1.0), self._s_max)
        for _ in range(400):
            bad = (self._x(dE, s_end) > -_X_CUT) & (s_end < self._s_max)
            if not np.any(bad):
                break
            s_end[bad] = np.minimum(s_end[bad] + 0.5, self._s_max)
        return s_end

    def _integrals(self, dE: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(C, ∂C/∂ΔE)`` for ``ΔE < 0`` (1-d array)."""
        C = np.zeros_like(dE)
        dC = np.zeros_like(dE)
        a = self._a
        # atoms of y' (the one at q = 0 included)
        for qa, m in zip(self._atoms_q, self._atoms_m, strict=True):
            ua = 1.0 - qa
            x = (dE + self.dgamma**2 * float(self.parisi.Y_u(np.float64(ua)))) / (
                math.sqrt(ua) * a
            )
            rho, ec = rho_and_erfc(x)
            C += a * m * math.sqrt(ua) * rho
            dC += 0.5 * m * ec
        if not self._has_density:
            return C, dC
        s_star, width = self._crossing(dE)
        # Far below the power-law window (|ΔE| << |δγ|^(1+1/(2μ-1))) the zero s* of
        # ΔE + δγ² Y lies so deep that C is astronomically large. There ρ(x) >= 1/√π for s < s*,
        # so C >= (|δγ|/√π) ∫_{s*-30}^{s*} y' √(1-q) dq; when even half of that exceeds 800,
        # R = e^{-C} underflows and (C, ∂C/∂ΔE) are reported as (inf, inf).
        huge = np.zeros(dE.size, dtype=bool)
        deep = s_star > 30.0
        if np.any(deep):
            hi = np.minimum(s_star[deep], _S_LIMIT)
            edges = hi[:, None] - np.linspace(30.0, 0.0, 16)[None, :]
            sb, wb = panel_nodes(edges)
            ub = np.exp(-sb)
            bound = a * _INV_SQRT_PI * np.sum(self.parisi.dy_u(ub) * ub * np.sqrt(ub) * wb, axis=1)
            huge[deep] = 0.5 * bound > 800.0
        C[huge] = np.inf
        dC[huge] = np.inf
        rows = np.flatnonzero(~huge)
        if rows.size == 0:
            return C, dC
        dE, s_star, width = dE[rows], s_star[rows], width[rows]
        s_end = self._s_end(dE, s_star)
        unresolved = s_end > _S_LIMIT
        s_end = np.minimum(s_end, _S_LIMIT)
        steep, k0 = self._steep(dE)
        order = np.argsort(s_end)  # rows of similar length share a block
        n_guess = int(math.ceil(float(np.max(s_end)) / _PANEL_WIDTH)) + 110
        rows_per_block = max(16, _CHUNK // (n_guess * _GL_ORDER))
        for start in range(0, dE.size, rows_per_block):
            idx = order[start : start + rows_per_block]
            edges = panel_edges(self.parisi, s_end[idx], _grading(s_star[idx], width[idx]))
            # steep rows take part in the block's layout (so that the other rows keep their
            # panels whatever the call) but get their own panels below
            keep = ~steep[idx]
            if not np.any(keep):
                continue
            if not np.all(keep):
                idx, edges = idx[keep], edges[keep]
            # (inline, not by _panel_sums: the arrays of one block alive while the next is
            # allocated keep the allocator from returning and re-faulting their pages)
            s, w = panel_nodes(edges)
            u = np.exp(-s)
            dens = self.parisi.dy_u(u) * u * w  # y'(q) dq
            x = (dE[idx, None] + self.dgamma**2 * self.parisi.Y_u(u)) / (np.sqrt(u) * a)
            rho, ec = rho_and_erfc(x)
            C[rows[idx]] += a * np.sum(dens * np.sqrt(u) * rho, axis=1)
            dC[rows[idx]] += 0.5 * np.sum(dens * ec, axis=1)
        if np.any(steep):
            sub = np.flatnonzero(steep)
            n_kinks = s_of_q(self.parisi.breakpoints_q()).size
            per_block = max(16, _CHUNK // ((_STEEP_TAU.size + n_kinks + 1) * _GL_ORDER))
            for start in range(0, sub.size, per_block):
                idx = sub[start : start + per_block]
                edges = _steep_edges(self.parisi, k0[idx], s_end[idx])
                c_add, dc_add = self._panel_sums(dE[idx], edges)
                C[rows[idx]] += c_add
                dC[rows[idx]] += dc_add
        if np.any(unresolved):
            # features beyond 1 - q = e^-700 cannot be resolved in float64
            C[rows[unresolved]] = np.nan
            dC[rows[unresolved]] = np.nan
        return C, dC

    def _panel_sums(self, dE: FloatArray, edges: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The density parts of ``(C, ∂C/∂ΔE)`` by Gauss–Legendre on the panels ``edges`` (one
        row of edges per ``ΔE``; each row's sums depend on that row only). The same arithmetic as
        the shared-panel loop of :meth:`_integrals`."""
        a = self._a
        s, w = panel_nodes(edges)
        u = np.exp(-s)
        dens = self.parisi.dy_u(u) * u * w  # y'(q) dq
        x = (dE[:, None] + self.dgamma**2 * self.parisi.Y_u(u)) / (np.sqrt(u) * a)
        rho, ec = rho_and_erfc(x)
        return a * np.sum(dens * np.sqrt(u) * rho, axis=1), 0.5 * np.sum(dens * ec, axis=1)

    def _steep(self, dE: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Rows whose integrands fall steeply from ``q = 0`` (the far tail, where ``C`` is tiny),
        and the rate ``k0`` of that fall.

        With ``x0 = x(q = 0) < 0`` (no crossing) ``ρ(x)`` and ``erfc(-x/2)`` behave as
        ``e^{-x²/4}`` and ``x²/4`` grows at the rate ``k0 = x0²/4 + |δγ| y(0) |x0|/2`` in ``s``
        at ``s = 0``: the integrals' mass lies within ``s ~ 1/k0`` of 0. The shared panels (width
        up to 1/2 in ``s``) resolve that for ``k0 <= _K_STEEP`` only (their error grows from
        1e-12 at ``k0 = 35`` to 80 % at ``k0 = 700``, i.e. ``C ~ 1e-300``, and depends on the
        other rows of the block); the steeper rows get panels of their own, graded in ``k0 s``.
        """
        x0 = (dE + self.dgamma**2 * float(self.parisi.Y_u(np.float64(1.0)))) / self._a
        y0 = float(self.parisi.y_u(np.float64(1.0)))
        k0 = 0.25 * x0 * x0 + 0.5 * self._a * y0 * np.abs(x0)
        return (x0 < 0.0) & (k0 > _K_STEEP), k0

    def _C_zero(self) -> float:
        """``C(0, δγ)``; ``inf`` if ``∫ y' √(1-q)`` diverges (``μ >= 1/2`` without cut-off)."""
        a = self._a
        C = 0.0
        for qa, m in zip(self._atoms_q, self._atoms_m, strict=True):
            ua = 1.0 - qa
            x = self.dgamma**2 * float(self.parisi.Y_u(np.float64(ua))) / (math.sqrt(ua) * a)
            C += a * m * math.sqrt(ua) * float(rho_and_erfc(np.float64(x))[0])
        if not self._has_density:
            return C
        s_end = min(self._s_max, self.parisi.density_tail_s(1e-18))
        if not math.isfinite(s_end):
            return math.inf
        edges = panel_edges(self.parisi, np.array([s_end]))
        s, w = panel_nodes(edges)
        u = np.exp(-s)
        dens = self.parisi.dy_u(u) * u * w
        x = self.dgamma**2 * self.parisi.Y_u(u) / (np.sqrt(u) * a)
        C += a * float(np.sum(dens * np.sqrt(u) * rho_and_erfc(x)[0]))
        return C

    def _check_nonpositive(self, dE: FloatArray) -> None:
        _check_not_nan(dE)
        if np.any(dE > 0.0):
            raise ValueError(f"C and R are defined for dE <= 0 only, got {dE[dE > 0][0]}")

    def _C_dC(self, dE: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        dE = np.asarray(dE, dtype=np.float64)
        flat = dE.ravel()
        C = np.zeros_like(flat)
        dC = np.zeros_like(flat)
        neg = (flat < 0.0) & np.isfinite(flat)
        if np.any(neg):
            C[neg], dC[neg] = self._integrals(flat[neg])
        zero = flat == 0.0
        if np.any(zero):
            C[zero] = self._C0()
            dC[zero] = np.nan  # not needed: the pdf is zero there
        return dE, C.reshape(dE.shape), dC.reshape(dE.shape)

    # ------------------------------------------------------------------ public API
    def C(self, dE: ArrayLike) -> FloatArray | float:  # noqa: N802 - the paper's name
        """``C(ΔE, δγ) = -log R = |δγ| ∫ dq y'(q) √(1-q) ρ(x(q))`` for ``ΔE <= 0``."""
        arr = np.asarray(dE, dtype=np.float64)
        self._check_nonpositive(arr)
        return scalar_or_array(self._C_dC(arr)[1])

    def dC(self, dE: ArrayLike) -> FloatArray | float:  # noqa: N802
        """``∂C/∂ΔE = ½ ∫ dq y'(q) erfc(-x(q)/2)`` for ``ΔE < 0``."""
        arr = np.asarray(dE, dtype=np.float64)
        self._check_nonpositive(arr)
        return scalar_or_array(self._C_dC(arr)[2])

    def R(self, dE: ArrayLike) -> FloatArray | float:  # noqa: N802
        """``R(ΔE, δγ) = exp(-C)``: probability that the new ground state lies above ``ΔE``."""
        return scalar_or_array(np.exp(-np.asarray(self.C(dE))))

    @property
    def p_no_jump(self) -> float:
        """``R(0, δγ)``: the probability of no jump (the atom of ``P`` at ``ΔE = 0``)."""
        return math.exp(-self._C0())

    def logpdf(self, dE: ArrayLike) -> FloatArray | float:
        """``log P(ΔE|δγ) = log ∂C/∂ΔE - C`` for ``ΔE < 0`` (``-inf`` for ``ΔE >= 0``)."""
        arr = np.asarray(dE, dtype=np.float64)
        _check_not_nan(arr)
        out = np.full(arr.shape, -np.inf)
        neg = arr < 0.0
        if np.any(neg):
            _, C, dC = self._C_dC(arr[neg])
            with np.errstate(divide="ignore", invalid="ignore"):
                out[neg] = np.where(np.isinf(C), -np.inf, np.log(dC) - C)
        return scalar_or_array(out)

    def pdf(self, dE: ArrayLike) -> FloatArray | float:
        """Continuous part of ``P``: ``R(ΔE) ∂C/∂ΔE`` for ``ΔE < 0``, 0 for ``ΔE >= 0``."""
        arr = np.asarray(dE, dtype=np.float64)
        _check_not_nan(arr)
        out = np.zeros(arr.shape)
        neg = arr < 0.0
        if np.any(neg):
            _, C, dC = self._C_dC(arr[neg])
            with np.errstate(invalid="ignore"):
                out[neg] = np.where(np.isinf(C), 0.0, np.exp(-C) * dC)
        return scalar_or_array(out)

    def cdf(self, dE: ArrayLike) -> FloatArray | float:
        """``P(ΔE' <= ΔE)``: ``1 - R(ΔE) = -expm1(-C)`` for ``ΔE < 0``, 1 for ``ΔE >= 0``."""
        arr = np.asarray(dE, dtype=np.float64)
        _check_not_nan(arr)
        out = np.ones(arr.shape)
        neg = arr < 0.0
        if np.any(neg):
            _, C, _ = self._C_dC(arr[neg])
            out[neg] = -np.expm1(-C)
        return scalar_or_array(out)

    def sf(self, dE: ArrayLike) -> FloatArray | float:
        """``P(ΔE' > ΔE)``: ``R(ΔE)`` for ``ΔE < 0``, 0 for ``ΔE >= 0``."""
        arr = np.asarray(dE, dtype=np.float64)
        _check_not_nan(arr)
        out = np.zeros(arr.shape)
        neg = arr < 0.0
        if np.any(neg):
            _, C, _ = self._C_dC(arr[neg])
            out[neg] = np.exp(-C)
        return scalar_or_array(out)

    def ppf_log(self, c: ArrayLike) -> FloatArray:
        """``ΔE < 0`` with ``C(ΔE) = c``, solved in ``log|ΔE|``; see :meth:`rvs`.

        ``C`` falls from ``C(0) = -log R(0)`` (``inf`` for ``μ >= 1/2``
        without cut-off) to 0 as ``ΔE → -∞``, so a root exists for ``0 < c <= C(0)`` only
        (``c = C(0)`` gives ``ΔE → 0⁻``); any other ``c`` (NaN included) is a ValueError.
        """
        c = np.asarray(c, dtype=np.float64).ravel()
        bad = ~((c > 0.0) & (c <= self._C0()) & np.isfinite(c))
        if np.any(bad):
            raise ValueError(
                f"c must lie in (0, C(0)] = (0, {self._C0()!r}] (C(ΔE) = c has no root ΔE < 0 "
                f"elsewhere), got {float(c[bad][0])!r}"
            )
        return self._ppf_log(c)

    def _C0(self) -> float:  # noqa: N802
        """``C(0, δγ)``, computed once."""
        if self._c0 is None:
            self._c0 = self._C_zero()
        return self._c0

    def _ppf_log(self, c: FloatArray) -> FloatArray:
        """:meth:`ppf_log` without the range check (for :meth:`rvs`, whose ``c < -log R(0)``
        may exceed ``C(0)`` by a rounding error; the root is then ``ΔE → 0⁻``)."""
        a = self._a
        # monotone table of C over log|ΔE|, then Newton steps on the exact C
        t_grid = np.linspace(math.log(a) - 700.0, math.log(a) + math.log(200.0), 1200)
        t_grid = t_grid[t_grid > -740.0]
        C_grid = np.asarray(self.C(-np.exp(t_grid)))
        # C decreases with |ΔE|; keep finite positive values for interpolation in log C
        ok = np.isfinite(C_grid) & (C_grid > 0.0)
        tg, lCg = t_grid[ok][::-1], np.log(C_grid[ok][::-1])
        t = np.interp(np.log(c), lCg, tg)
        for _ in range(4):
            dE = -np.exp(t)
            _, Cv, dCv = self._C_dC(dE)
            # dC/dt = dC/dΔE · dΔE/dt = -|ΔE| ∂C/∂ΔE
            step = (Cv - c) / (-np.exp(t) * dCv)
            step = np.where(np.isfinite(step), np.clip(step, -2.0, 2.0), 0.0)
            t = t - step
        # far in the tail (small c: C falls faster than exponentially there) the four steps
        # on C stop short; those roots only are finished by Newton on log C (the others keep
        # their bits)
        _, Cv, _ = self._C_dC(-np.exp(t))
        short = ~(np.abs(Cv / c - 1.0) <= 1e-12)
        if np.any(short):
            t[short] = self._newton_log_c(t[short], c[short])
        return -np.exp(t)

    def _newton_log_c(self, t: FloatArray, c: FloatArray) -> FloatArray:
        """Roots ``t = log|ΔE|`` of ``log C(−e^t) = log c``, from ``t``: Newton on ``log C``
        kept inside a bracket (``C`` decreases with ``t``; a step that leaves the bracket, or
        an underflow of ``C`` to 0, is replaced by bisection) until ``log C`` is within
        ``1e-14·max(1, |log c|)`` or the bracket is at the resolution of ``t``."""
        log_c = np.log(c)
        tol = 1e-14 * np.maximum(1.0, np.abs(log_c))

        def log_C(u: FloatArray) -> tuple[FloatArray, FloatArray]:
            _, Cv, dCv = self._C_dC(-np.exp(u))
            with np.errstate(divide="ignore", invalid="ignore"):
                # d log C / dt = −|ΔE| ∂C/∂ΔE / C  (< 0)
                return np.log(Cv) - log_c, -np.exp(u) * dCv / Cv

        lo, hi = t.copy(), t.copy()  # C(lo) > c > C(hi)
        for _ in range(400):
            up = log_C(lo)[0] <= 0.0
            if not np.any(up):
                break
            lo[up] -= 1.0
        for _ in range(400):
            down = log_C(hi)[0] > 0.0
            if not np.any(down):
                break
            hi[down] += 1.0
        t = 0.5 * (lo + hi)
        for _ in range(200):
            miss, slope = log_C(t)
            lo = np.where(miss > 0.0, t, lo)
            hi = np.where(miss > 0.0, hi, t)
            # done: log C within tol, or the bracket at the resolution of t (C's own rounding)
            done = (np.abs(miss) <= tol) | (hi - lo <= 4e-16 * np.maximum(1.0, np.abs(t)))
            if np.all(done):
                return t
            with np.errstate(divide="ignore", invalid="ignore"):
                newton = t - miss / slope
            inside = np.isfinite(newton) & (newton > lo) & (newton < hi)
            t = np.where(done, t, np.where(inside, newton, 0.5 * (lo + hi)))
        raise ValueError(f"ppf_log: no root for c in [{c.min():.3g}, {c.max():.3g}]")

    def rvs(
        self, size: int | tuple[int, ...] = 1, seed: int | np.random.Generator | None = None
    ) -> FloatArray:
        """Draw ``ΔE`` by exact inversion of the cdf.

        With ``V ~ U(0,1)``: ``ΔE = 0`` if ``V >= 1 - R(0)`` (probability ``R(0)``), else the root
        of ``C(ΔE) = -log(1 - V)``. Roots below the float64 range (``|ΔE| < 1e-308``, common for
        ``μ = 1/2`` without cut-off, where most of the mass sits at unresolvably small ``|ΔE|``)
        come out as ``-0.0``.
        """
        size = validation.shape("size", size)
        if not (seed is None or isinstance(seed, np.random.Generator)):
            seed = validation.seed("seed", seed)
        rng = np.random.default_rng(seed)
        v = rng.random(size)
        flat = np.ravel(v)
        out = np.zeros_like(flat)
        p0 = self.p_no_jump
        jump = flat < 1.0 - p0
        if np.any(jump):
            c = -np.log1p(-flat[jump])
            out[jump] = self._ppf_log(c)
        return out.reshape(np.shape(v))


def _check_not_nan(dE: FloatArray) -> None:
    """ValueError if any ``ΔE`` is NaN (the one check of every method taking ``dE``)."""
    if np.any(np.isnan(dE)):
        raise ValueError(f"dE must not be NaN, got {float(dE[np.isnan(dE)].ravel()[0])!r}")


def scalar_or_array(x: FloatArray) -> FloatArray | float:
    x = np.asarray(x)
    return float(x) if x.ndim == 0 else x


def jump_distribution(y: ParisiFunction, dgamma: float) -> PrintedJumpDistribution:
    """The paper's printed ``P(ΔE | δγ)`` for the Parisi function ``y`` (module docstring).

    ``P(ΔE|δγ) = δ(ΔE) R(0) − θ(−ΔE) ∂R/∂ΔE`` with ``R = exp(−C)`` and
    ``C = |δγ| ∫ dq y'(q) √(1−q) ρ((ΔE + δγ² Y(q))/(√(1−q)|δγ|))`` (``SPEC.md`` §1). Exact at
    first order in ``δγ`` only: :func:`jamlab.theory.exact_jump_law` is the exact law.

    Parameters
    ----------
    y : ParisiFunction
        The Parisi function (``ParisiFunction.power_law``, ``.linear``, discretised, …).
    dgamma : float
        The strain step ``δγ`` (either sign; the law is even in it).

    Returns
    -------
    PrintedJumpDistribution
        A scipy-like law of ``ΔE ≤ 0``: ``R``, ``pdf``, ``cdf``, ``sf``, ``rvs``; ``R(0)`` is
        the probability of no jump.

    Examples
    --------
    >>> from jamlab.theory import ParisiFunction, jump_distribution
    >>> y = ParisiFunction.linear(2.5, 0.0, 0.9)   # y = 2.5 q cut at q_max = 0.9
    >>> P = jump_distribution(y, 0.1)
    >>> round(float(P.R(0.0)), 4)                    # printed P(no jump)
    0.9034
    """
    return PrintedJumpDistribution(y, dgamma)
