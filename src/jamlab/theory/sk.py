r"""Zero-temperature Parisi solution of the Sherrington–Kirkpatrick model (``H = -Σ_{i<j} J_ij
s_i s_j``, ``J_ij ~ N(0, 1/N)``, no field).

At ``T → 0`` with ``y(q) = β x(q)`` finite, Parisi's formula for the ground-state energy per spin is

    E_0 = -min_y Q[y],    Q[y] = φ(0, 0) - ½ ∫_0^1 q y(q) dq,
    ∂_q φ + ½ (∂_h² φ + y(q) (∂_h φ)²) = 0,    φ(1, h) = |h|.

(From ``P = log 2 + Φ(0,0) - ½ ∫ m q ξ'' dq``, ``ξ = β² q²/2``, with ``Φ = β φ``, ``x = β h``,
``y = β m``.) ``y = 0`` gives the replica-symmetric ``-√(2/π)``. For a ``k``-step function
(``y = y_i`` on ``[q_i, q_{i+1})``, ``y = 0`` below ``q_1``, ``q_{k+1} = 1``) the equation is
solved exactly level by level (Cole–Hopf):
``φ(q_i, h) = (1/y_i) log E[exp(y_i φ(q_{i+1}, h + √(q_{i+1} - q_i) ξ))]``, the top level in closed
form, ``φ(0, 0) = E[φ(q_1, √q_1 ξ)]`` and ``½ ∫ q y = ¼ Σ_i y_i (q_{i+1}² - q_i²)``.
:func:`sk_k_rsb` minimises ``Q`` over the ``2k`` parameters; :func:`sk_ground_state` extrapolates
the ``k``-step energies to ``k → ∞`` and returns the Parisi function of the largest ``k``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize
from scipy.special import log_ndtr

from jamlab.theory.parisi import ParisiFunction

__all__ = ["SKGroundState", "SKStepSolution", "sk_ground_state", "sk_k_rsb"]

#: Parisi's T = 0 SK energy per spin, -0.7631667 (Crisanti & Rizzo 2002; Oppermann et al. 2007)
SK_ENERGY_REFERENCE = -0.7631667

_SQ2PI = math.sqrt(2.0 * math.pi)


def _kern(sigma: float, h: float, extra: float) -> np.ndarray:
    m = max(1, int(math.ceil((11.0 + extra) * sigma / h)))
    t = np.arange(-m, m + 1) * h
    return h * np.exp(-0.5 * (t / sigma) ** 2) / (_SQ2PI * sigma)


def _log_smooth(g: np.ndarray, r: float, sigma: float, h: float, extra: float) -> np.ndarray:
    """``log E[exp(r g(z + σξ))]`` on a uniform grid symmetric about 0; ``g`` continued linearly
    beyond both ends (``φ ~ |h| + c``)."""
    kern = _kern(sigma, h, extra)
    m = (kern.size - 1) // 2
    n = g.size
    gp = np.empty(n + 2 * m)
    gp[m:m + n] = g
    sl = (g[1] - g[0]) / h
    sr = (g[-1] - g[-2]) / h
    gp[:m] = g[0] + sl * h * np.arange(-m, 0)
    gp[m + n:] = g[-1] + sr * h * np.arange(1, m + 1)
    win = np.lib.stride_tricks.sliding_window_view(gp, 2 * m + 1)
    e = np.exp(r * (win - g[:, None])) @ kern
    return r * g + np.log(e)


def _phi0(q: np.ndarray, y: np.ndarray, ppsd: float = 3.0) -> float:
    """``φ(0, 0)`` for the k-step function ``(q, y)`` (module docstring)."""
    k = q.size
    qe = np.append(q, 1.0)
    v = np.diff(qe)
    sd = np.sqrt(v)
    h = min(float(sd.min()) / ppsd, 0.05)
    span = 10.0 + 2.0 * float(np.sum(y * v))
    n = int(math.ceil(span / h))
    z = np.arange(-n, n + 1) * h
    s, b = sd[-1], y[-1] * sd[-1]
    # (1/y) log E[e^{y|h + sZ|}]
    lp = y[-1] * z + 0.5 * b * b + log_ndtr(z / s + b)
    lm = -y[-1] * z + 0.5 * b * b + log_ndtr(-z / s + b)
    g = np.logaddexp(lp, lm) / y[-1]
    for i in range(k - 2, -1, -1):
        g = _log_smooth(g, y[i], sd[i], h, extra=y[i] * sd[i]) / y[i]
    if q[0] <= 0.0:
        return float(np.interp(0.0, z, g))
    kern = _kern(math.sqrt(q[0]), h, 0.0)
    m = (kern.size - 1) // 2
    idx = np.arange(-m, m + 1) + n
    gi = g[np.clip(idx, 0, g.size - 1)]
    # beyond the grid continue |h|-like linearly
    lo = idx < 0
    hi = idx >= g.size
    gi[lo] = g[0] + (g[1] - g[0]) * (idx[lo])
    gi[hi] = g[-1] + (g[-1] - g[-2]) * (idx[hi] - g.size + 1)
    return float(kern @ gi)


def sk_q_functional(q: np.ndarray, y: np.ndarray) -> float:
    """``Q[y] = φ(0, 0) - ½ ∫ q y`` for the k-step function (``E_0 = -min Q``)."""
    qe = np.append(q, 1.0)
    return _phi0(q, y) - 0.25 * float(np.sum(y * (qe[1:] ** 2 - qe[:-1] ** 2)))


def _unpack(p: np.ndarray, k: int, free_q1: bool) -> tuple[np.ndarray, np.ndarray]:
    a = p[:k]
    b = p[k:2 * k]
    s = 1.0 / (1.0 + np.exp(-a))  # 1 - q_i = Π_{j<=i} s_j
    u = np.cumprod(s)
    q = 1.0 - u
    if not free_q1:
        q = 1.0 - np.cumprod(np.concatenate(([1.0], s[1:])))
    y = np.cumsum(np.exp(b))
    return q, y


@dataclass(frozen=True)
class SKStepSolution:
    """Optimal ``k``-step zero-temperature Parisi function: ``q``, ``y``, ``energy = -Q``."""

    k: int
    q: np.ndarray
    y: np.ndarray
    energy: float


def sk_k_rsb(k: int, start: SKStepSolution | None = None) -> SKStepSolution:
    """Minimise ``Q`` over ``k``-step functions (``q_1 = 0``: ``y > 0`` from ``q = 0`` on, the
    zero-field SK optimum). ``start``: a ``(k-1)``-step solution to start from (a level added
    at the top)."""
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")
    if start is None or start.k != k - 1:
        u = np.geomspace(1.0, 0.5 / (k + 1), k)
        y0 = np.linspace(1.0, 1.0 + 2.0 * k, k)
    else:
        u = np.append(1.0 - start.q, 0.5 * (1.0 - start.q[-1]))
        y0 = np.append(start.y, start.y[-1] * 1.6)
    s = np.concatenate(([0.5], u[1:] / u[:-1]))
    a0 = np.log(s / (1.0 - s))
    b0 = np.log(np.diff(np.concatenate(([0.0], y0))))

    def obj(p: np.ndarray) -> float:
        q, y = _unpack(np.concatenate((p[:k], p[k:])), k, free_q1=False)
        return sk_q_functional(q, y)

    p0 = np.concatenate((a0, b0))
    # Q is stationary at the optimum: parameters to ~1e-6 (finite-difference BFGS) give the
    # energy to ~1e-12
    res = optimize.minimize(obj, p0, method="BFGS", options={"gtol": 1e-8, "maxiter": 4000})
    for _ in range(3):  # restarts (fresh Hessian) until Q stops moving
        again = optimize.minimize(obj, res.x, method="BFGS",
                                  options={"gtol": 1e-9, "maxiter": 4000})
        done = res.fun - again.fun < 1e-11
        res = again if again.fun < res.fun else res
        if done:
            break
    q, y = _unpack(res.x, k, free_q1=False)
    return SKStepSolution(k, q, y, -float(res.fun))


@dataclass(frozen=True)
class SKGroundState:
    """Result of :func:`sk_ground_state`.

    ``energy``: the ``k → ∞`` extrapolation of the k-step energies ``energies`` (``E_k = E_∞ +
    a k^{-p}`` through the last three ``k``), ``energy_error`` the change from the previous
    triple; ``y``: the Parisi function (``ParisiFunction.tabulated`` through
    the level midpoints of the largest ``k``); ``mu``, ``mu_error``: exponent of
    ``y ≈ A (1-q)^(-μ) + B`` fitted to ``y(q_i) ≈ √(y_{i-1} y_i)`` at the top (up to) five
    breakpoints (``nan`` for ``k < 5``); ``local_mu``: ``-Δ log y / Δ log(1-q)`` between
    neighbouring breakpoints (tends to ``μ`` at the top); ``steps``: every ``SKStepSolution``.
    """

    energy: float
    energy_error: float
    energies: dict[int, float]
    exponent_p: float
    y: ParisiFunction
    mu: float
    mu_error: float
    local_mu: np.ndarray
    steps: list[SKStepSolution] = field(repr=False)


def sk_ground_state(k_max: int = 6) -> SKGroundState:
    """Zero-temperature SK Parisi solution from ``k = 1 .. k_max`` step functions (module doc)."""
    steps: list[SKStepSolution] = []
    prev = None
    for k in range(1, k_max + 1):
        prev = sk_k_rsb(k, prev)
        steps.append(prev)
    ks = np.array([s.k for s in steps], float)
    es = np.array([s.energy for s in steps])

    def fit(sel: slice) -> tuple[float, float]:
        kk, ee = ks[sel], es[sel]

        def resid(p: np.ndarray) -> np.ndarray:
            return ee - (p[0] + p[1] * kk ** (-p[2]))

        r = optimize.least_squares(resid, [ee[-1], ee[0] - ee[-1], 3.0])
        return float(r.x[0]), float(r.x[2])

    fits = [fit(slice(j, j + 3)) for j in range(max(0, len(ks) - 4), len(ks) - 2)]
    e_inf, p = fits[-1]
    err = float(np.std([f[0] for f in fits])) if len(fits) > 1 else abs(es[-1] - e_inf)
    top = steps[-1]
    qe = np.append(top.q, 1.0)
    mid = 0.5 * (qe[1:] + qe[:-1])
    yfun = ParisiFunction.tabulated(mid, top.y, q_max=float(mid[-1]))
    # exponent: y at the breakpoints, y(q_i) ≈ √(y_{i-1} y_i) (the step values interlace the
    # continuous y), fitted by A (1-q)^(-μ) + B on the top (up to) five breakpoints
    qb = top.q[1:]
    yb = np.sqrt(top.y[:-1] * top.y[1:])
    sel = slice(max(0, qb.size - 5), qb.size)
    mu, mu_err = float("nan"), float("nan")
    local_mu = -np.diff(np.log(yb)) / np.diff(np.log1p(-qb))
    if qb[sel].size >= 4:
        popt, pcov = optimize.curve_fit(lambda q, a, m, b: a * (1 - q) ** (-m) + b, qb[sel],
                                        yb[sel], p0=[0.5, 0.5, 0.0], maxfev=20000)
        mu, mu_err = float(popt[1]), float(math.sqrt(max(pcov[1, 1], 0.0)))
    return SKGroundState(e_inf, err, dict(zip(ks.astype(int).tolist(), es.tolist(), strict=True)),
                         p, yfun, mu, mu_err, local_mu, steps)
