r"""The whole exact jump law of a cascade: ``ΔE``, the overlap ``q``, ``ΔU`` and ``ΔΣ``.

:func:`exact_jump_law` returns an :class:`ExactJumpLaw` built on the grid solution of the exact
recursion (:class:`jamlab.theory.exact.CascadeRecursion`, derivation in its module docstring and
``docs/theory-vs-cascade.md`` §7). Conventions as for the printed law
(:class:`jamlab.theory.PrintedJumpDistribution`): ``ΔE <= 0`` with an atom ``p_no_jump`` at 0,
``cdf(x) = 1 - R(x)`` for ``x < 0``; ``ΔU >= 0`` and ``δγ ΔΣ >= 0`` with their atoms at 0 (no
jump); the overlap law has its atom at ``q = 1``. ``pdf`` always means the density of the jumps'
part (atoms excluded), ``cdf`` includes the atoms.

For a step function (``ParisiFunction.steps`` or arrays ``(q, y)``) the law is exact for that
``k``-level cascade. For any other ``ParisiFunction`` the continuum limit (``k → ∞``) is computed:
:func:`continuum_levels` discretises ``y`` on ``K`` graded levels, the law is evaluated at ``K``
and ``2K`` and Richardson-extrapolated (the recursion converges as ``K^{-2}``, measured); the
difference of the two is the reported error estimate ``R_error``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.polynomial import chebyshev as C

from jamlab import validation
from jamlab.theory.exact import CascadeRecursion
from jamlab.theory.exact_bands import BandedRecursion
from jamlab.theory.jumps import scalar_or_array
from jamlab.theory.marginal_laws import JumpOverlapLaw, ScalarJumpLaw, checked_floats, one_sided

__all__ = [
    "MIN_ONE_MINUS_Q_CUT",
    "ExactEnergyJumpLaw",
    "ExactJumpLaw",
    "JumpOverlapLaw",
    "ScalarJumpLaw",
    "continuum_levels",
    "exact_energy_jump_law",
    "exact_jump_law",
    "geometric_levels",
]

#: smallest ``1 - q_cut`` accepted: ``1 - q`` of a float64 ``q`` near 1 has absolute error 1e-16
MIN_ONE_MINUS_Q_CUT = 1e-13
#: default merging cut-off of :func:`exact_energy_jump_law` when ``q_max = 1``
Q_CUT_ENERGY = 1.0 - 1e-12
#: largest ``y_k |δγ| √(1 - q_k)`` of the merged top level the default cut-off allows
TOP_COUPLING_MAX = 100.0


def _lobatto(a: float, b: float, n: int) -> np.ndarray:
    return 0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * np.arange(n) / (n - 1))[::-1]


def _bary_matrix(nodes: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Barycentric interpolation matrix of Chebyshev–Lobatto ``nodes`` at the points ``t``."""
    n = nodes.size
    w = (-1.0) ** np.arange(n)
    w[0] *= 0.5
    w[-1] *= 0.5
    diff = t[:, None] - nodes[None, :]
    hit = diff == 0.0
    diff[hit] = 1.0
    m = w[None, :] / diff
    m /= m.sum(axis=1, keepdims=True)
    rows = np.flatnonzero(hit.any(axis=1))
    if rows.size:
        m[rows] = hit[rows].astype(float)
    return m


class _DiscreteLaw:
    """All laws for one ``k``-level cascade (one grid solution)."""

    def __init__(self, q: np.ndarray, y: np.ndarray, dgamma: float, grid: dict) -> None:
        self.rec = rec = CascadeRecursion(q, y, dgamma, **grid)
        self.p_no_jump = float(rec.R(0.0)[0])
        self._sig_cheb: C.Chebyshev | None = None

    # ΔΣ (|ΔΣ| = (w - x)/d), from the joint density of (ΔE, ΔU) on Chebyshev nodes
    def _dsigma_series(self) -> C.Chebyshev:
        if self._sig_cheb is not None:
            return self._sig_cheb
        rec = self.rec
        d, yk = rec.d, float(rec.y[-1])
        span = rec.w_hi - rec.x_lo
        n = int(np.clip(3.0 * (-rec.x_lo) / rec.sigma[-1] + 40, 60, 400))
        xn = _lobatto(rec.x_lo, 0.0, n)
        wn = _lobatto(0.0, rec.w_hi, n)
        Q = rec.joint_on_nodes(xn, wn)  # p e^{-y_k w}
        gx, gw = np.polynomial.legendre.leggauss(48)
        s_hi = span / d

        def p_sigma(s: np.ndarray) -> np.ndarray:
            s = np.atleast_1d(s)
            if s.size > 64:  # bounded memory: the interpolation matrices are (64·48) × n
                return np.concatenate([p_sigma(s[j:j + 64]) for j in range(0, s.size, 64)])
            a = np.maximum(-d * s, rec.x_lo)
            b = np.minimum(0.0, rec.w_hi - d * s)
            ok = b > a
            out = np.zeros(s.size)
            if not np.any(ok):
                return out
            a, b, so = a[ok], b[ok], s[ok]
            xs = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * gx[None, :]
            ws = xs + d * so[:, None]
            Lx = _bary_matrix(xn, xs.ravel())
            Lw = _bary_matrix(wn, ws.ravel())
            vals = np.sum((Lx @ Q) * Lw, axis=1).reshape(xs.shape)
            vals *= np.exp(yk * ws)
            out[ok] = d * 0.5 * (b - a) * (vals @ gw)
            return out

        deg = int(np.clip(3.0 * span / rec.sigma[-1] + 60, 100, 700))
        self._sig_cheb = C.Chebyshev.interpolate(p_sigma, deg, domain=[0.0, s_hi])
        return self._sig_cheb

    def dsigma_pdf(self, s: np.ndarray) -> np.ndarray:
        ch = self._dsigma_series()
        return np.where(s < ch.domain[1], ch(np.minimum(s, ch.domain[1])), 0.0)

    def dsigma_cdf(self, s: np.ndarray) -> np.ndarray:
        ch = self._dsigma_series()
        it = ch.integ(lbnd=0.0)
        return it(np.clip(s, 0.0, ch.domain[1]))


def continuum_levels(y: Any, K: int, q_cut: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``K`` graded levels ``(q, y)`` approximating a continuous ``ParisiFunction``.

    The top level sits at ``q_top = min(q_max, q_cut)`` (or lower, where ``y`` stops rising) with
    ``y = Y(q_top)/(1 - q_top)`` (the mean of ``y`` above it; ``y(q_max)`` when ``q_top =
    q_max``): a cut-off ``q_cut`` merges every cluster above it into one level, which changes the
    law only at ``|ΔE|`` of order ``|δγ|√(1 - q_cut)`` and ``δγ² Y(q_cut)`` or below. Without a
    cut-off (``q_max = 1``) ``q_cut`` is required. Level edges equidistribute ``s(q) = ½ q/q_top
    + ½ log(1 + (y(q) - y(0+))/y_s) / log(1 + (y(q_top) - y(0+))/y_s)``, ``y_s = (y(q_top) -
    y(0+))/10`` (half the levels uniform in ``q``, half where ``y`` rises, geometrically where it
    diverges; uniform when ``y`` is constant); ``y_i`` is the mean of ``y`` over ``[q_i,
    q_{i+1}]`` (as :meth:`ParisiFunction.discretise`).
    """
    qm = _rise_end(y, _top_level(y, q_cut))
    y0 = float(y.y(0.0))
    ym = float(y.y(qm))
    rise = ym - y0
    if not rise > 0:  # y constant on [0, q_top]: uniform edges, one level after merging
        return _step_values(y, np.linspace(0.0, qm, K), qm)
    ys = rise / 10.0
    norm = math.log1p(rise / ys)

    def s_of(q: np.ndarray) -> np.ndarray:
        yy = np.asarray(y.y(np.minimum(q, qm)), dtype=np.float64)
        return 0.5 * q / qm + 0.5 * np.log1p((yy - y0) / ys) / norm

    t = np.arange(K, dtype=np.float64) / (K - 1)
    lo = np.zeros(K)
    hi = np.full(K, qm)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        big = s_of(mid) > t
        hi = np.where(big, mid, hi)
        lo = np.where(big, lo, mid)
    q = 0.5 * (lo + hi)
    q[0] = 0.0
    q[-1] = qm
    return _step_values(y, q, qm)


def _rise_end(y: Any, qm: float) -> float:
    """Where ``y`` stops rising below ``qm``: ``qm`` itself unless ``y`` is flat on
    ``[q_f, qm]`` with ``qm - q_f > 1e-9``. Above ``q_f`` no clusters branch: the top level sits
    there (its ``y`` the mean above it, exact), for ``K`` and ``2K`` levels alike."""
    ym = float(y.y(qm))
    if not float(y.y(0.0)) < ym:  # constant: one level, whatever its top
        return qm
    lo, hi = 0.0, qm
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if float(y.y(mid)) < ym:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15:
            break
    return qm if qm - hi <= 1e-9 else hi


def _step_values(y: Any, q: np.ndarray, qm: float) -> tuple[np.ndarray, np.ndarray]:
    """Levels ``q`` (``q_1 = 0``, ``q_K = qm``) and ``y_i`` = the mean of ``y`` over
    ``[q_i, q_{i+1}]``, the top one over ``[qm, 1]``; levels with no rise of ``y`` merged."""
    K = q.size
    Yq = np.asarray(y.Y(q), dtype=np.float64)
    yv = np.empty(K)
    yv[:-1] = (Yq[:-1] - Yq[1:]) / np.diff(q)
    yv[-1] = float(y.Y(qm)) / (1.0 - qm)
    if not yv[0] > 0:
        raise ValueError("y vanishes on the first level; a cascade needs y_1 > 0")
    keep = np.concatenate(([True], np.diff(yv) > 1e-12 * yv[1:]))
    return q[keep], yv[keep]


def _top_level(y: Any, q_cut: float | None, q_cut_default: float | None = None) -> float:
    qm = float(y.q_max)
    if q_cut is None and qm >= 1.0:
        q_cut = q_cut_default
    if q_cut is not None:
        qc = float(q_cut)
        if not 0.0 < qc < 1.0 or not 1.0 - qc >= MIN_ONE_MINUS_Q_CUT:
            raise ValueError(f"q_cut must lie in (0, 1 - {MIN_ONE_MINUS_Q_CUT:g}], got {q_cut!r}")
        qm = min(qm, qc)
    if qm >= 1.0:
        raise ValueError("continuum levels need a cut-off: q_max < 1 or q_cut < 1")
    return qm


def geometric_levels(y: Any, K: int, q_cut: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``K`` levels ``(q, y)`` approximating a continuous ``ParisiFunction``, geometric in
    ``1 - q`` (for :func:`exact_energy_jump_law`).

    Level edges equidistribute ``s(q) = ¼ q/q_top + ¾ log(1 - q)/log(1 - q_top)``: a quarter of
    the levels uniform in ``q``, three quarters at a fixed number per decade of ``1 - q`` down to
    ``1 - q_top``, so every scale ``ℓ = |δγ|√(1 - q)`` of the law gets the same resolution
    (:func:`continuum_levels` puts half its levels within a factor 10 of ``y(q_top)``, which
    leaves the decades between unresolved when ``y`` diverges). ``q_top = min(q_max, q_cut)``;
    ``y_i`` and the top level as in :func:`continuum_levels`.
    """
    qm = _top_level(y, q_cut)
    L = math.log1p(-qm)
    t = np.arange(K, dtype=np.float64) / (K - 1)
    lo = np.zeros(K)
    hi = np.full(K, qm)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        big = 0.25 * mid / qm + 0.75 * np.log1p(-mid) / L > t
        hi = np.where(big, mid, hi)
        lo = np.where(big, lo, mid)
    q = 0.5 * (lo + hi)
    q[0] = 0.0
    q[-1] = qm
    return _step_values(y, q, qm)


def _richardson(values: list[np.ndarray]) -> np.ndarray:
    """The one value of a discrete cascade, or the Richardson extrapolation ``(4 v_2K − v_K)/3``
    of the step approximations on ``K`` and ``2K`` levels (error ``∝ K⁻²``, §8)."""
    return values[0] if len(values) == 1 else (4.0 * values[1] - values[0]) / 3.0


def _combine(parts: list[Any], get: Any) -> np.ndarray:
    """``get`` of each part (a ``_DiscreteLaw``), Richardson-combined."""
    return _richardson([np.asarray(get(p), dtype=np.float64) for p in parts])


class _EnergyLaw:
    """``R``, ``pdf``, ``cdf``, ``sf`` of ``ΔE`` from a subclass's ``_R_values(x)`` and
    ``_pdf_values(x)`` (1-D arrays, ``x <= 0``): written once for both exact laws."""

    def _R_values(self, x: np.ndarray) -> np.ndarray:  # noqa: N802
        raise NotImplementedError

    def _pdf_values(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def R(self, dE: Any) -> np.ndarray | float:  # noqa: N802
        """``R(x) = P(ΔE >= x)`` for ``x <= 0`` (1 at ``-∞``)."""
        a = checked_floats("dE", dE)
        if np.any(a > 0):
            raise ValueError(f"R is defined for dE <= 0 only, got {a[a > 0].ravel()[0]}")
        return scalar_or_array(self._R_values(a.ravel()).reshape(a.shape))

    def pdf(self, dE: Any) -> np.ndarray | float:
        """Density of ``ΔE`` at ``ΔE < 0`` (``-R'``), 0 for ``ΔE >= 0``."""
        return scalar_or_array(one_sided(dE, "dE", -1, self._pdf_values, 0.0))

    def cdf(self, dE: Any) -> np.ndarray | float:
        """``P(ΔE' <= ΔE)``: ``1 - R(ΔE)`` for ``ΔE < 0``, 1 for ``ΔE >= 0``."""
        out = one_sided(dE, "dE", -1, lambda v: 1.0 - self._R_values(v), 1.0)
        return scalar_or_array(np.clip(out, 0.0, 1.0))

    def sf(self, dE: Any) -> np.ndarray | float:
        """``P(ΔE' > ΔE)``."""
        return scalar_or_array(1.0 - np.asarray(self.cdf(dE)))


class ExactJumpLaw(_EnergyLaw):
    """The exact law of a static jump (see the module docstring). Build with
    :func:`exact_jump_law`.

    Attributes: ``p_no_jump``, ``dgamma``, ``levels`` (the ``(q, y)`` used; for the continuum the
    finer of the two), ``overlap`` (:class:`JumpOverlapLaw`), ``du``, ``dsigma``
    (:class:`ScalarJumpLaw`), ``R_error`` (0 for a discrete cascade; the Richardson error estimate
    of ``R(0)`` for the continuum).
    """

    def __init__(self, parts: list[_DiscreteLaw], dgamma: float, continuum: bool,
                 atom0: float = 0.0, q_max: float = 1.0, merged_top: bool = True) -> None:
        self.dgamma = float(dgamma)
        self._parts = parts
        self.continuum = continuum
        fine = parts[-1]
        self.levels = (fine.rec.q.copy(), fine.rec.y.copy())
        self.p_no_jump = self._combine(lambda p: np.array([p.p_no_jump]))[0]
        self.R_error = (abs(parts[1].p_no_jump - parts[0].p_no_jump) / 3.0
                        if len(parts) == 2 else 0.0)
        # continuum: the first level's mass splits into the atom at q = 0 (share y(0+)/y_1 of
        # its Δy_1 = y_1) and the density part of [0, q_2]
        sets = []
        for p in parts:
            m = p.rec.cluster_masses()
            sets.append((p.rec.q, m, m[0] * min(atom0 / float(p.rec.y[0]), 1.0) if continuum
                         else 0.0))
        self.overlap = JumpOverlapLaw(*sets[-1][:2], self.p_no_jump, continuum=continuum,
                                      atom0=sets[-1][2], q_max=q_max,
                                      coarse=sets[0] if len(sets) == 2 else None,
                                      merged_top=merged_top)
        # the marginal laws' functions hold the parts, not this law: a law that referred to
        # itself through them lived in a reference cycle (~0.3 GB at 64 levels), freed only by a
        # full garbage collection, so a report held several at once
        self.du = ScalarJumpLaw(
            self.p_no_jump,
            lambda w: _combine(parts, lambda p: p.rec.dU_pdf(w)),
            lambda w: _combine(parts, lambda p: p.rec.dU_cdf_jumps(w)),
        )
        self.dsigma = ScalarJumpLaw(
            self.p_no_jump,
            lambda s: _combine(parts, lambda p: p.dsigma_pdf(s)),
            lambda s: _combine(parts, lambda p: p.dsigma_cdf(s)),
            sign=1 if self.dgamma >= 0 else -1,
        )

    def _combine(self, get: Any) -> np.ndarray:
        return _combine(self._parts, get)

    def _R_values(self, x: np.ndarray) -> np.ndarray:  # noqa: N802
        return self._combine(lambda p: p.rec.R(x))  # 1 below each grid's edge

    def _pdf_values(self, x: np.ndarray) -> np.ndarray:
        return self._combine(lambda p: p.rec.dE_pdf(x))


class _TrivialLaw(ExactJumpLaw):
    """``δγ = 0``: the ground state never changes."""

    def __init__(self, q: np.ndarray, y: np.ndarray) -> None:
        self.dgamma = 0.0
        self._parts = []
        self.continuum = False
        self.levels = (q, y)
        self.p_no_jump = 1.0
        self.R_error = 0.0
        zero = lambda s: np.zeros(np.shape(s))  # noqa: E731
        self.overlap = JumpOverlapLaw(q, np.zeros(q.size), 1.0)
        self.du = ScalarJumpLaw(1.0, zero, zero)
        self.dsigma = ScalarJumpLaw(1.0, zero, zero)

    def _combine(self, get: Any) -> np.ndarray:  # pragma: no cover - never reached
        raise AssertionError

    def _R_values(self, x: np.ndarray) -> np.ndarray:  # noqa: N802
        return np.ones(x.shape)

    def _pdf_values(self, x: np.ndarray) -> np.ndarray:
        return np.zeros(x.shape)


def exact_jump_law(
    y: Any,
    dgamma: float,
    *,
    k: int | None = None,
    levels: int = 64,
    q_cut: float | None = None,
    **grid: Any,
) -> ExactJumpLaw:
    """The exact law of a static jump at strain ``dgamma`` (module docstring).

    ``y``: a ``ParisiFunction`` or a pair of arrays ``(q, y)`` (the levels of a ``k``-level
    cascade). A step function (``ParisiFunction.steps``) or arrays give the discrete cascade;
    ``k=`` discretises any function as :meth:`ParisiFunction.discretise` does (the levels of
    :func:`jamlab.theory.sample_cascade_jumps` with ``k=``); otherwise the continuum limit is
    computed from :func:`continuum_levels` with ``levels`` and ``2·levels`` levels (Richardson);
    ``q_cut`` (required when ``q_max = 1``) merges the clusters above ``q_cut`` into one level.
    ``grid``: options of :class:`jamlab.theory.exact.CascadeRecursion`. The uniform grid resolves
    the law only at ``|ΔE| ≳ 10 |δγ|√(1 - q_cut)``; for the law of ``ΔE`` at smaller ``|ΔE|``
    (and without a cut-off) use :func:`exact_energy_jump_law`.
    """
    from jamlab.theory.cascade import validate_levels

    try:
        dg = float(dgamma)
    except (TypeError, ValueError):
        raise ValueError(f"dgamma must be a real number, got {dgamma!r}") from None
    if not math.isfinite(dg):
        raise ValueError(f"dgamma must be finite, got {dgamma!r}")
    if isinstance(y, tuple):
        qa, ya = validate_levels(*y)
        discrete = True
    elif k is not None:
        qa, ya = validate_levels(*y.discretise(validation.integer("k", k)))
        discrete = True
    elif y.step_levels is not None:
        qa, ya = validate_levels(*y.step_levels)
        discrete = True
    else:
        discrete = False
    if discrete:
        if dg == 0.0:
            return _TrivialLaw(qa, ya)
        return ExactJumpLaw([_DiscreteLaw(qa, ya, dg, grid)], dg, continuum=False)
    K = validation.integer("levels", levels, minimum=8)
    coarse = continuum_levels(y, K, q_cut)
    fine = continuum_levels(y, 2 * K, q_cut)
    if dg == 0.0:
        return _TrivialLaw(*fine)
    if fine[0].size == 1:  # y constant up to q_top: exactly the one-level cascade
        return ExactJumpLaw([_DiscreteLaw(*fine, dg, grid)], dg, continuum=False)
    parts = [_DiscreteLaw(*coarse, dg, grid), _DiscreteLaw(*fine, dg, grid)]
    q_top = float(fine[0][-1])
    # the top level is a cluster (an atom of the overlap at q_top) only where y rises above it,
    # i.e. where a cut-off merged the levels above q_top; else its mass falls as 1/K (measured)
    q_end = float(y.q_max) if float(y.q_max) < 1.0 else math.nextafter(1.0, 0.0)
    return ExactJumpLaw(parts, dg, continuum=True, atom0=float(y.atom0), q_max=q_top,
                        merged_top=float(y.y(q_end)) > float(y.y(q_top)))


def _default_q_cut(y: Any, d: float) -> float:
    """``1 - 1e-12``, or lower where the merged top level would have ``y_k d √(1 - q_k)`` above
    :data:`TOP_COUPLING_MAX` (its window costs ``~12 (y_k σ_k)²`` points)."""

    def coupling(e: float) -> float:
        one_m_q = 10.0 ** -e
        return float(y.Y(1.0 - one_m_q)) / one_m_q * d * math.sqrt(one_m_q)

    if float(y.q_max) < 1.0 or coupling(12.0) <= TOP_COUPLING_MAX:
        return Q_CUT_ENERGY
    lo, hi = 1.0, 12.0  # coupling(lo) <= max < coupling(hi), in e = -log10(1 - q)
    if coupling(lo) > TOP_COUPLING_MAX:
        return 1.0 - 10.0 ** -lo
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if coupling(mid) <= TOP_COUPLING_MAX else (lo, mid)
    return 1.0 - 10.0 ** -lo


class ExactEnergyJumpLaw(_EnergyLaw):
    """The exact law of ``ΔE`` alone, on the multi-band grid (:func:`exact_energy_jump_law`).

    Attributes: ``dgamma``, ``p_no_jump`` (``R(0)``), ``levels`` (the finer ``(q, y)`` used),
    ``q_top`` (the top level: ``q_max``, or the merging cut-off ``q_cut``), ``continuum``,
    ``R_error`` (Richardson estimate for ``R(0)``; 0 for a discrete cascade). Methods as
    :class:`ExactJumpLaw`: ``R``, ``pdf``, ``cdf``, ``sf``.
    """

    def __init__(self, recs: list[BandedRecursion], dgamma: float, q_top: float) -> None:
        self.dgamma = float(dgamma)
        self._recs = recs
        self.continuum = len(recs) == 2
        self.levels = (recs[-1].q.copy(), recs[-1].y.copy())
        self.q_top = float(q_top)
        r0 = [float(r.R(0.0)[0]) for r in recs]
        self.p_no_jump = float(self._mix(np.array([[v] for v in r0]))[0])
        self.R_error = abs(r0[1] - r0[0]) / 3.0 if self.continuum else 0.0

    def _mix(self, vals: np.ndarray) -> np.ndarray:
        return _richardson(list(vals))

    def _both(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # R = 1, density 0 below ExactJumpLaw's edge (bands lose precision: R(-1e16) was 4.3)
        lo = max(12.0 * (r.sigma[-1] - 2.0 * r.ell[0]) - 2.0 * r.tilt[0] for r in self._recs)
        out = [r.R_and_pdf(np.maximum(x, lo)) for r in self._recs]  # x >= lo: their own value
        R, P = (self._mix(np.array([o[j] for o in out])) for j in (0, 1))
        return np.where(x < lo, 1.0, R), np.where(x < lo, 0.0, P)

    def _R_values(self, x: np.ndarray) -> np.ndarray:  # noqa: N802
        return self._both(x)[0]

    def _pdf_values(self, x: np.ndarray) -> np.ndarray:
        return self._both(x)[1]


def exact_energy_jump_law(
    y: Any,
    dgamma: float,
    *,
    levels: int = 256,
    q_cut: float | None = None,
) -> ExactEnergyJumpLaw:
    """The exact law of ``ΔE`` (``R``, ``pdf``, ``cdf``) down to small ``|ΔE|``, also without a
    cut-off (``docs/theory-vs-cascade.md`` §8).

    Same law as :func:`exact_jump_law` (same ``R`` and ``pdf``), computed on the multi-band grid of
    :class:`jamlab.theory.exact_bands.BandedRecursion` (its cost does not grow as ``q_top → 1``)
    with :func:`geometric_levels` (``levels`` and ``2·levels``, Richardson) for a continuous
    ``ParisiFunction``; discrete input (arrays ``(q, y)``, a step function) as in
    :func:`exact_jump_law`. Without a cut-off (``q_max = 1``) the clusters above ``q_cut`` are
    merged into one level; this changes ``R`` only at ``|ΔE| ≲ 10 |δγ|√(1 - q_cut)`` (measured in
    the docs). Default ``q_cut``: ``1 - 1e-12``, lowered (with a cost bound) until the merged
    level has ``y |δγ| √(1 - q_cut) <= 100`` (for ``μ_J`` that bites at ``|δγ| > 0.2``: ``1 - q_cut
    = 3e-9`` at ``δγ = 0.5``); the one used is the attribute ``q_top``.
    """
    from jamlab.theory.cascade import validate_levels

    try:
        dg = float(dgamma)
    except (TypeError, ValueError):
        raise ValueError(f"dgamma must be a real number, got {dgamma!r}") from None
    if not math.isfinite(dg) or dg == 0.0:
        raise ValueError(f"dgamma must be finite and nonzero, got {dgamma!r}")
    if isinstance(y, tuple):
        qa, ya = validate_levels(*y)
    elif y.step_levels is not None:
        qa, ya = validate_levels(*y.step_levels)
    else:
        K = validation.integer("levels", levels, minimum=8)
        q_top = _top_level(y, q_cut, _default_q_cut(y, abs(dg)))
        recs = [BandedRecursion(*geometric_levels(y, n, q_top), dg) for n in (K, 2 * K)]
        return ExactEnergyJumpLaw(recs, dg, q_top)
    return ExactEnergyJumpLaw([BandedRecursion(qa, ya, dg)], dg, float(qa[-1]))
