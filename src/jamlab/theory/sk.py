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
:func:`sk_k_rsb` minimises ``Q`` over the ``2k - 1`` free parameters with exact (reverse-mode)
gradients of the discretised recursion; :func:`sk_ground_state` extrapolates the ``k``-step energies
to ``k → ∞``, estimates the exponent of ``y`` near ``q = 1`` and returns the Parisi function of the
largest ``k`` (docs/theory-vs-cascade.md §10).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize
from scipy.special import log_ndtr

from jamlab.theory.parisi import ParisiFunction

__all__ = ["SKGroundState", "SKStepSolution", "sk_ground_state", "sk_k_rsb", "sk_top_exponents"]

#: Parisi's T = 0 SK energy per spin, -0.7631667 (Crisanti & Rizzo 2002; Oppermann et al. 2007)
SK_ENERGY_REFERENCE = -0.7631667

_SQ2PI = math.sqrt(2.0 * math.pi)
#: grid points per standard deviation of the narrowest Gaussian a grid samples
_PPSD = 3.0


@dataclass(frozen=True)
class _Layout:
    """The grids of one ``Q`` evaluation, top level first: ``z = j h``, ``|j| <= n``. Each level's
    spacing is an integer multiple of the one above (its points are points of the grid above) and
    at most ``1/ppsd`` of every Gaussian width it samples or resolves; the last level (``q = 0``)
    is needed at ``z = 0`` only."""

    h: tuple[float, ...]
    n: tuple[int, ...]


def _layout(q: np.ndarray, y: np.ndarray, ppsd: float = _PPSD) -> _Layout:
    qe = np.append(q, 1.0)
    v = np.diff(qe)
    sd = np.sqrt(v)
    k = q.size
    # h and the span quantised (a power of 2, an integer) so that the layout of an optimum
    # does not move under parameter changes of the size of the optimiser's last steps
    span = math.ceil(10.0 + 2.0 * float(np.sum(y * v)))
    hs = [2.0 ** math.floor(math.log2(min(float(sd[-1]) / ppsd, 0.05)))]
    for i in range(k - 2, -1, -1):  # the output grid of level i; its input is level i + 1's
        target = min(float(sd[i]), float(sd[i - 1])) / ppsd if i > 0 else hs[-1]
        hs.append(hs[-1] * max(1, math.floor(target / hs[-1])))
    ns = [int(math.ceil(span / hs[0]))]
    for j in range(1, k):
        ns.append(ns[-1] // int(round(hs[j] / hs[j - 1])))
    if k > 1:
        ns[-1] = 0
    return _Layout(tuple(hs), tuple(ns))


def _phi0_grad(q: np.ndarray, y: np.ndarray, lay: _Layout,
               grad: bool) -> tuple[float, np.ndarray | None, np.ndarray | None]:
    """``φ(0, 0)`` for the k-step function ``(q, y)`` (``q_1 = 0``; module docstring) and, if
    ``grad``, its derivatives by ``q_i`` (entry 0 unused) and ``y_i``: reverse mode through the
    level recursion on the grids of ``lay`` (exact derivatives of the discretised value).

    Level ``i`` (Gaussian width ``σ_i = √(q_{i+1} - q_i)``, input spacing ``h``):
    ``g_i(z) = (1/y_i) log Σ_t K_t exp(y_i g_{i+1}(z + t h))``, ``K_t = h e^{-t²h²/2σ²}/(√(2π)σ)``,
    ``g`` continued linearly beyond the grid (``φ ~ |h| + c``); the top level in closed form,
    ``(1/y) log E[e^{y|z + sZ|}] = (1/y) log(e^{yz + b²/2} Φ(z/s + b) + (z → -z))``, ``b = ys``.
    """
    k = q.size
    if q[0] != 0.0:
        raise ValueError(f"the first level must sit at q = 0, got {q[0]}")
    sd = np.sqrt(np.diff(np.append(q, 1.0)))
    z = np.arange(-lay.n[0], lay.n[0] + 1) * lay.h[0]
    s, yk = sd[-1], y[-1]
    b = yk * s
    up, um = z / s + b, -z / s + b
    lp = yk * z + 0.5 * b * b + log_ndtr(up)
    lm = -yk * z + 0.5 * b * b + log_ndtr(um)
    g_top = np.logaddexp(lp, lm) / yk
    g = g_top
    tape = []
    for lev, i in enumerate(range(k - 2, -1, -1), start=1):
        r, sig, h = y[i], sd[i], lay.h[lev - 1]
        m = max(1, int(math.ceil((11.0 + r * sig) * sig / h)))
        t = np.arange(-m, m + 1) * h
        kern = h * np.exp(-0.5 * (t / sig) ** 2) / (_SQ2PI * sig)
        nin = g.size
        gp = np.empty(nin + 2 * m)
        gp[m:m + nin] = g
        gp[:m] = g[0] + (g[1] - g[0]) * np.arange(-m, 0)
        gp[m + nin:] = g[-1] + (g[-1] - g[-2]) * np.arange(1, m + 1)
        stride = int(round(lay.h[lev] / h))
        centre = (nin - 1) // 2 + stride * np.arange(-lay.n[lev], lay.n[lev] + 1)
        win = np.lib.stride_tricks.sliding_window_view(gp, 2 * m + 1)[centre]
        gc = g[centre]
        e = np.exp(r * (win - gc[:, None])) * kern
        tot = e.sum(axis=1)
        gout = gc + np.log(tot) / r
        if grad:
            w = e / tot[:, None]
            d_r = ((w * win).sum(axis=1) - gout) / r
            d_sig = (w @ (t * t / sig ** 3 - 1.0 / sig)) / r
            tape.append((i, m, nin, centre, w, d_r, d_sig))
        g = gout
    phi0 = float(g[g.size // 2])
    if not grad:
        return phi0, None, None
    gbar = np.zeros(g.size)
    gbar[g.size // 2] = 1.0
    ybar = np.zeros(k)
    sdbar = np.zeros(k)
    for i, m, nin, centre, w, d_r, d_sig in reversed(tape):
        ybar[i] += gbar @ d_r
        sdbar[i] += gbar @ d_sig
        idx = (centre[:, None] + np.arange(2 * m + 1)[None, :]).ravel()
        gpb = np.bincount(idx, weights=(gbar[:, None] * w).ravel(), minlength=nin + 2 * m)
        gb = gpb[m:m + nin].copy()
        lo, hi = np.arange(-m, 0.0), np.arange(1.0, m + 1)
        gb[0] += gpb[:m] @ (1.0 - lo)
        gb[1] += gpb[:m] @ lo
        gb[-1] += gpb[m + nin:] @ (1.0 + hi)
        gb[-2] -= gpb[m + nin:] @ hi
        gbar = gb
    # top level: derivatives of (1/y) logaddexp(lp, lm) by y and s (R = φ/Φ, the Mills ratio)
    rp = np.exp(-0.5 * up * up - log_ndtr(up)) / _SQ2PI
    rm = np.exp(-0.5 * um * um - log_ndtr(um)) / _SQ2PI
    pp = np.exp(lp - yk * g_top)
    d_y = (pp * (z + s * rp) + (1.0 - pp) * (-z + s * rm) + yk * s * s - g_top) / yk
    d_s = (pp * (yk - z / (s * s)) * rp + (1.0 - pp) * (yk + z / (s * s)) * rm
           + yk * yk * s) / yk
    ybar[-1] += gbar @ d_y
    sdbar[-1] += gbar @ d_s
    qbar = np.zeros(k + 1)
    dv = sdbar / (2.0 * sd)
    qbar[1:] += dv
    qbar[:-1] -= dv
    return phi0, qbar[:k], ybar


def _penalty(q: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``½ ∫ q y dq = ¼ Σ y_i (q_{i+1}² - q_i²)`` and its derivatives by ``q_i``, ``y_i``."""
    qe = np.append(q, 1.0)
    d2 = qe[1:] ** 2 - qe[:-1] ** 2
    dq = np.zeros(q.size)
    dq[1:] = 0.5 * q[1:] * (y[:-1] - y[1:])
    return 0.25 * float(np.sum(y * d2)), dq, 0.25 * d2


def sk_q_functional(q: np.ndarray, y: np.ndarray) -> float:
    """``Q[y] = φ(0, 0) - ½ ∫ q y`` for the k-step function (``E_0 = -min Q``; ``q_1 = 0``)."""
    q = np.asarray(q, float)
    y = np.asarray(y, float)
    return _phi0_grad(q, y, _layout(q, y), grad=False)[0] - _penalty(q, y)[0]


@dataclass(frozen=True)
class SKStepSolution:
    """Optimal ``k``-step zero-temperature Parisi function: ``q``, ``y``, ``energy = -Q``;
    ``gradient``: the largest ``|∂Q/∂q_i|``, ``|∂Q/∂y_i|`` at the solution (stationarity);
    ``seconds``: wall time of the optimisation."""

    k: int
    q: np.ndarray
    y: np.ndarray
    energy: float
    gradient: float = float("nan")
    seconds: float = float("nan")


def _to_params(q: np.ndarray, y: np.ndarray) -> np.ndarray:
    # 1 - q_i = Π_{1<=j<=i} s_j with s_j = 1/(1 + e^{-a_j}); y_i = Σ_{j<=i} e^{b_j}
    u = 1.0 - q
    s = u[1:] / u[:-1]
    return np.concatenate((np.log(s / (1.0 - s)), np.log(np.diff(np.concatenate(([0.0], y))))))


def _from_params(p: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    s = 1.0 / (1.0 + np.exp(-p[:k - 1]))
    u = np.concatenate(([1.0], np.cumprod(s)))
    return 1.0 - u, np.cumsum(np.exp(p[k - 1:])), s, u


def _newton_polish(obj: Callable[[np.ndarray], tuple[float, np.ndarray]], p: np.ndarray,
                   rounds: int = 3, steps: int = 8, eps: float = 1e-5) -> np.ndarray:
    """Newton steps with the Hessian from central differences of the exact gradient. BFGS stops
    ("precision loss") with ``Q`` still ~1e-9 above its minimum for k >~ 12: the Hessian's
    condition number grows to ~1e5 (the top levels are weakly curved) and the top breakpoints
    are then off by percents. One Hessian serves up to ``steps`` steps (halved up to 4 times
    until ``Q`` does not rise); stop when the Newton decrement ``gᵀH⁻¹g`` is below 1e-24."""
    f, g = obj(p)
    for _ in range(rounds):
        n = p.size
        hess = np.empty((n, n))
        for j in range(n):
            d = np.zeros(n)
            d[j] = eps
            hess[:, j] = (obj(p + d)[1] - obj(p - d)[1]) / (2.0 * eps)
        hess = 0.5 * (hess + hess.T)
        for _ in range(steps):
            try:
                step = np.linalg.solve(hess, -g)
            except np.linalg.LinAlgError:
                return p
            if -float(g @ step) < 1e-24:
                return p
            for _ in range(5):
                f2, g2 = obj(p + step)
                if f2 <= f:
                    break
                step = 0.5 * step
            else:
                break
            p, f, g = p + step, f2, g2
    return p


def sk_k_rsb(k: int, start: SKStepSolution | None = None) -> SKStepSolution:
    """Minimise ``Q`` over ``k``-step functions (``q_1 = 0``: ``y > 0`` from ``q = 0`` on, the
    zero-field SK optimum) by BFGS with exact gradients (reverse mode through the discretised
    recursion) over ``2k - 1`` unconstrained parameters. The grids are held fixed during a BFGS
    run (so ``Q`` is smooth in the parameters) and rebuilt for the solution until they no longer
    change; then Newton steps (``k >= 3``; BFGS alone stalls ~1e-9 above the minimum at large
    ``k``). ``start``: a ``(k-1)``-step solution to start from (a level added at the top)."""
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")
    t0 = time.perf_counter()
    if start is None or start.k != k - 1:
        q0 = 1.0 - np.geomspace(1.0, 0.5 / (k + 1), k)
        y0 = np.linspace(1.0, 1.0 + 2.0 * k, k)
    else:
        q0 = np.append(start.q, 1.0 - 0.5 * (1.0 - start.q[-1]))
        y0 = np.append(start.y, start.y[-1] * 1.6)
    q0[0] = 0.0
    p = _to_params(q0, y0)
    lay = None
    for _ in range(5):
        q, y, _, _ = _from_params(p, k)
        new = _layout(q, y)
        if new == lay:
            break
        lay = new

        def obj(par: np.ndarray, lay: _Layout = new) -> tuple[float, np.ndarray]:
            q, y, s, u = _from_params(par, k)
            phi, gq, gy = _phi0_grad(q, y, lay, grad=True)
            pen, pq, py = _penalty(q, y)
            gq, gy = gq - pq, gy - py
            ga = -(1.0 - s) * np.cumsum((gq[1:] * u[1:])[::-1])[::-1]
            gb = np.exp(par[k - 1:]) * np.cumsum(gy[::-1])[::-1]
            return phi - pen, np.concatenate((ga, gb))

        # Q is stationary at the optimum: a gradient of 1e-10 leaves the energy exact to ~1e-15
        res = optimize.minimize(obj, p, jac=True, method="BFGS",
                                options={"gtol": 1e-10, "maxiter": 5000})
        p = res.x
    if k > 2:
        p = _newton_polish(obj, p)
    q, y, _, _ = _from_params(p, k)
    lay = _layout(q, y)
    phi, gq, gy = _phi0_grad(q, y, lay, grad=True)
    pen, pq, py = _penalty(q, y)
    gmax = float(max(np.abs(gq[1:] - pq[1:]).max(initial=0.0), np.abs(gy - py).max()))
    return SKStepSolution(k, q, y, -(phi - pen), gmax, time.perf_counter() - t0)


@dataclass(frozen=True)
class SKGroundState:
    """Result of :func:`sk_ground_state`.

    ``energy``: the ``k → ∞`` extrapolation of the k-step energies ``energies`` (``E_k = E_∞ +
    a k^{-p}`` through the last three ``k``), ``energy_error`` the change from the previous
    triple; ``y``: the Parisi function (``ParisiFunction.tabulated`` through the level midpoints
    of the largest ``k``).

    The exponent of ``y ≈ A (1-q)^(-μ)`` near ``q = 1``, from the top step ``(u_k, y_k)``
    (``u_k = 1 - q_k``, ``y_k`` its value) of the optimal ``k``-step functions: near ``q = 1``
    the zero-temperature Parisi equation is invariant under ``1 - q → λ(1 - q)``, ``h → √λ h``,
    ``y → y/λ^μ`` with ``μ = 1/2``, so the top of the ladder is one shape at the scale ``u_k →
    0`` and ``y_k ∝ u_k^{-μ}`` across ``k``. Two estimates that converge from either side
    (observed for ``k_max = 7 .. 16``, docs/theory-vs-cascade.md §10; a bracket, not a bound):

    - ``mu_upper``: ``-Δ log y_k / Δ log u_k`` between ``k_max - 1`` and ``k_max`` (no
      correction to scaling; decreases with ``k``);
    - ``mu_lower``: ``μ`` of ``y_k = A u_k^{-μ} + B`` least-squares fitted on the last five ``k``
      (the constant ``B`` over-corrects; increases with ``k``);

    ``mu`` is their midpoint and ``mu_error`` half their distance (``nan`` for ``k_max < 7``).
    ``mu_fit_error``: the standard error of the fitted ``μ``. ``local_mu``: the within-``k``
    local exponents ``-Δ log y/Δ log(1-q)`` between neighbouring breakpoints of ``k_max``, with
    ``y(q_i) ≈ √(y_{i-1} y_i)`` (bottom to top; their top entry is biased by the top level's
    shape, ~0.504 at ``k = 13``). ``max_gradient``: the largest ``|∂Q/∂q_i|``, ``|∂Q/∂y_i|``
    over the optima (stationarity); ``steps``: every ``SKStepSolution``.
    """

    energy: float
    energy_error: float
    energies: dict[int, float]
    exponent_p: float
    y: ParisiFunction
    mu: float
    mu_error: float
    mu_lower: float
    mu_upper: float
    mu_fit_error: float
    local_mu: np.ndarray
    max_gradient: float
    steps: list[SKStepSolution] = field(repr=False)


def sk_top_exponents(steps: list[SKStepSolution]) -> tuple[float, float, float]:
    """``(mu_upper, mu_lower, mu_fit_error)`` from the top steps of consecutive ``k``-step
    solutions (:class:`SKGroundState`); needs the last six ``k`` consecutive and ``>= 2``."""
    top = [s for s in steps if s.k >= 2][-6:]
    if len(top) < 6 or [s.k for s in top] != list(range(top[0].k, top[0].k + 6)):
        return float("nan"), float("nan"), float("nan")
    u = np.array([1.0 - s.q[-1] for s in top])
    yk = np.array([s.y[-1] for s in top])
    upper = float(-math.log(yk[-1] / yk[-2]) / math.log(u[-1] / u[-2]))
    popt, pcov = optimize.curve_fit(lambda x, a, m, b: a * x ** (-m) + b, u[1:], yk[1:],
                                    p0=[1.0, 0.5, 0.0], maxfev=20000)
    return upper, float(popt[1]), float(math.sqrt(max(pcov[1, 1], 0.0)))


def sk_ground_state(k_max: int = 9) -> SKGroundState:
    """Zero-temperature SK Parisi solution from ``k = 1 .. k_max`` step functions (module doc;
    ``k_max = 9`` takes ~20 s, ``16`` ~2 min of one core)."""
    if k_max < 3:
        raise ValueError(f"k_max must be >= 3 (the energy extrapolation), got {k_max}")
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
    err = abs(fits[-1][0] - fits[-2][0]) if len(fits) > 1 else abs(es[-1] - e_inf)
    top = steps[-1]
    qe = np.append(top.q, 1.0)
    mid = 0.5 * (qe[1:] + qe[:-1])
    yfun = ParisiFunction.tabulated(mid, top.y, q_max=float(mid[-1]))
    qb = top.q[1:]
    yb = np.sqrt(top.y[:-1] * top.y[1:])
    local_mu = -np.diff(np.log(yb)) / np.diff(np.log1p(-qb))
    upper, lower, fit_err = sk_top_exponents(steps)
    return SKGroundState(e_inf, err, dict(zip(ks.astype(int).tolist(), es.tolist(), strict=True)),
                         p, yfun, 0.5 * (upper + lower), 0.5 * abs(upper - lower), lower, upper,
                         fit_err, local_mu, max(s.gradient for s in steps), steps)
