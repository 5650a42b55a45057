"""Parisi functions ``y(q)`` on ``[0, 1]`` (SPEC §1).

A Parisi function is non-decreasing with ``y >= 0``. It may jump at ``q = 0``: ``y(0+) > 0`` is an
atom of ``y'`` at ``q = 0`` (``atom0``) that every ``∫ dq y'(q) ...`` includes. A cut-off
``q_max < 1`` (the paper's ``q_EA = 1 - N^-β``) makes ``y`` constant, equal to ``y(q_max)``, on
``[q_max, 1]``; then ``y'`` has no mass above ``q_max`` and its integrals run over ``[0, q_max]``.

Internally every function is evaluated in the gap variable ``u = 1 - q`` so that points with
``1 - q`` far below the float64 spacing of ``q`` near 1 (``1 - q ~ 1e-24`` occurs in the jump
distribution) are represented exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

# relative tolerance under which two neighbouring levels of a discretisation count as equal
_MERGE_RTOL = 1e-12


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value}")
    return value


def _check_q_max(q_max: float) -> float:
    q_max = _finite("q_max", q_max)
    if not 0.0 < q_max <= 1.0:
        raise ValueError(f"q_max must lie in (0, 1], got {q_max}")
    return q_max


def _as_q(q: ArrayLike) -> FloatArray:
    arr = np.asarray(q, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"q must be finite, got {arr[~np.isfinite(arr)].ravel()[0]}")
    if np.any((arr < 0.0) | (arr > 1.0)):
        bad = arr[(arr < 0.0) | (arr > 1.0)].ravel()[0]
        raise ValueError(f"q must lie in [0, 1], got {bad}")
    return arr


def _ret(x: FloatArray) -> FloatArray | float:
    return float(x) if x.ndim == 0 else x


class ParisiFunction:
    """A Parisi function ``y(q)`` with optional cut-off ``q_max``.

    Build one with :meth:`power_law`, :meth:`linear`, :meth:`tabulated` or :meth:`steps`.
    Conventions: ``y(0)`` denotes ``y(0+)`` (the atom of ``y'`` at ``q = 0``, :attr:`atom0`);
    ``y`` is right-continuous; ``dy`` is the density part of ``y'`` (atoms excluded, zero above
    ``q_max``); ``Y(q) = ∫_q^1 y(q') dq'``.
    """

    q_max: float

    # ----------------------------------------------------------------- constructors
    @staticmethod
    def power_law(
        mu: float, amplitude: float = 1.0, y0: float = 0.0, q_max: float = 1.0
    ) -> ParisiFunction:
        """``y(q) = y0 + amplitude·((1-q)^(-mu) - 1)`` for ``q < q_max``; ``y'(q) ~ (1-q)^(-mu-1)``.

        ``0 < mu < 1`` (so that ``Y`` is finite), ``amplitude >= 0``, ``y0 >= 0`` (``y0`` is the
        atom at ``q = 0``), ``0 < q_max <= 1``.
        """
        mu = _finite("mu", mu)
        if not 0.0 < mu < 1.0:
            raise ValueError(f"mu must lie in (0, 1), got {mu}")
        amplitude = _finite("amplitude", amplitude)
        if amplitude < 0.0:
            raise ValueError(f"amplitude must be >= 0 (y non-decreasing), got {amplitude}")
        y0 = _finite("y0", y0)
        if y0 < 0.0:
            raise ValueError(f"y0 must be >= 0, got {y0}")
        return _PowerLaw(q_max=_check_q_max(q_max), mu=mu, amplitude=amplitude, y0=y0)

    @staticmethod
    def linear(slope: float, y0: float = 0.0, q_max: float = 1.0) -> ParisiFunction:
        """``y(q) = y0 + slope·q`` for ``q < q_max`` (``slope >= 0``, ``y0 >= 0``)."""
        slope = _finite("slope", slope)
        if slope < 0.0:
            raise ValueError(f"slope must be >= 0 (y non-decreasing), got {slope}")
        y0 = _finite("y0", y0)
        if y0 < 0.0:
            raise ValueError(f"y0 must be >= 0, got {y0}")
        return _Linear(q_max=_check_q_max(q_max), slope=slope, y0=y0)

    @staticmethod
    def tabulated(q: ArrayLike, y: ArrayLike, q_max: float | None = None) -> ParisiFunction:
        """Piecewise-linear interpolation of the table ``(q_j, y_j)``.

        ``q`` strictly increasing in ``[0, 1]``, ``y`` non-decreasing and ``>= 0``. Below ``q_0``
        ``y = y_0`` (so ``y_0`` is the atom at ``q = 0``), above the last node ``y`` is constant.
        ``q_max`` defaults to the last node.
        """
        qa = np.asarray(q, dtype=np.float64).ravel()
        ya = np.asarray(y, dtype=np.float64).ravel()
        _check_table(qa, ya, strict_q=True)
        if qa[-1] > 1.0:
            raise ValueError(f"q must lie in [0, 1], got {qa[-1]}")
        q_max = float(qa[-1]) if q_max is None else _check_q_max(q_max)
        if q_max <= 0.0:
            raise ValueError(f"q_max must lie in (0, 1], got {q_max}")
        return _Tabulated(q_max=q_max, q=qa.copy(), yv=ya.copy())

    @staticmethod
    def steps(q: ArrayLike, y: ArrayLike) -> ParisiFunction:
        """k-RSB step function: ``y = y_i`` on ``[q_i, q_{i+1})``, ``q_{k+1} = 1``, ``y = 0`` below
        ``q_1``.

        ``y'`` is a sum of atoms of size ``y_i - y_{i-1}`` at ``q_i`` (``y_0 = 0``). This converts
        the output of :meth:`discretise` back into a Parisi function. ``0 <= q_1 < ... < q_k < 1``,
        ``0 <= y_1 <= ... <= y_k``.
        """
        qa = np.asarray(q, dtype=np.float64).ravel()
        ya = np.asarray(y, dtype=np.float64).ravel()
        _check_table(qa, ya, strict_q=True)
        if qa[-1] >= 1.0:
            raise ValueError(f"step positions q must lie in [0, 1), got {qa[-1]}")
        return _Steps(q_max=1.0, q=qa.copy(), yv=ya.copy())

    # ----------------------------------------------------------------- public evaluation
    def y(self, q: ArrayLike) -> FloatArray | float:
        """``y(q)`` (right-continuous; ``y(0)`` means ``y(0+)``)."""
        return _ret(self._y_q(_as_q(q)))

    def dy(self, q: ArrayLike) -> FloatArray | float:
        """Density part of ``y'(q)`` (atoms excluded; 0 for ``q >= q_max``)."""
        return _ret(self._dy_q(_as_q(q)))

    def Y(self, q: ArrayLike) -> FloatArray | float:  # noqa: N802 - the paper's name
        """``Y(q) = ∫_q^1 y(q') dq'`` (with ``y = y(q_max)`` on ``[q_max, 1]``)."""
        return _ret(self._Y_q(_as_q(q)))

    @property
    def atom0(self) -> float:
        """``y(0+)``: the mass of the atom of ``y'`` at ``q = 0``."""
        return float(self.y_u(np.float64(1.0)))

    def atoms(self) -> tuple[FloatArray, FloatArray]:
        """All atoms of ``y'`` as ``(positions q, masses)``, including the one at ``q = 0``."""
        a = self.atom0
        if a > 0.0:
            return np.array([0.0]), np.array([a])
        return np.empty(0), np.empty(0)

    def discretise(self, k: int) -> tuple[FloatArray, FloatArray]:
        """k-level step approximation ``(q, y)`` for a Derrida–Ruelle cascade.

        Levels: if ``q_max < 1`` then ``q_i = q_max (i-1)/(k-1)``, ``i = 1..k`` (the last level sits
        at ``q_max``; needs ``k >= 2``), ``y_i = (Y(q_i) - Y(q_{i+1}))/(q_{i+1} - q_i)`` (the mean
        of ``y`` over ``[q_i, q_{i+1}]``) for ``i < k`` and ``y_k = y(q_max)``. If ``q_max = 1``
        then ``q_i = (i-1)/k`` and every ``y_i`` is the mean over ``[q_i, q_{i+1}]`` with
        ``q_{k+1} = 1``. An atom at ``q = 0`` is included automatically (``y_1 >= y(0+)``).

        Flat parts: a level whose ``y`` does not exceed the previous one (within a relative
        ``1e-12``, rounding in the ``Y`` differences) is dropped, so the returned ``y`` is strictly
        increasing and may have fewer than ``k`` entries. ``q[0] = 0`` always; if ``y`` vanishes
        on the whole first interval the cascade is ill-defined and ``ValueError`` is raised.
        """
        if isinstance(k, bool) or int(k) != k:
            raise ValueError(f"k must be an integer, got {k}")
        k = int(k)
        if self.q_max < 1.0:
            if k < 2:
                raise ValueError(f"k must be >= 2 when q_max < 1, got {k}")
            q = self.q_max * np.arange(k, dtype=np.float64) / (k - 1)
            q[-1] = self.q_max
            Yq = np.asarray(self.Y(q), dtype=np.float64)
            y = np.empty(k)
            y[:-1] = (Yq[:-1] - Yq[1:]) / (q[1:] - q[:-1])
            y[-1] = float(self.y(self.q_max))
        else:
            if k < 1:
                raise ValueError(f"k must be >= 1, got {k}")
            q = np.arange(k, dtype=np.float64) / k
            qe = np.append(q, 1.0)
            Yq = np.asarray(self.Y(qe), dtype=np.float64)
            y = (Yq[:-1] - Yq[1:]) / (qe[1:] - qe[:-1])
        if not y[0] > 0.0:
            raise ValueError(
                f"y vanishes on [0, {q[1] if k > 1 else 1.0}]: a cascade needs y_1 > 0; "
                "use more levels or a function with y > 0 there"
            )
        keep = [0]
        for i in range(1, len(y)):
            if y[i] > y[keep[-1]] * (1.0 + _MERGE_RTOL):
                keep.append(i)
        idx = np.asarray(keep)
        return q[idx].copy(), y[idx].copy()

    # ----------------------------------------------------------------- gap-variable surface
    # Public evaluation in the gap variable ``u = 1 - q`` (exact for ``1 - q`` far below the float64
    # spacing of ``q`` near 1) and the quadrature hints used by the jump distributions
    # (:mod:`jamlab.theory.jumps`, :mod:`jamlab.theory.exact`). Smooth kinds are evaluated in
    # ``u``; tables and steps in ``q`` (their node positions are exact in ``q``).
    def _y_q(self, q: FloatArray) -> FloatArray:
        return self.y_u(1.0 - q)

    def _dy_q(self, q: FloatArray) -> FloatArray:
        return self.dy_u(1.0 - q)

    def _Y_q(self, q: FloatArray) -> FloatArray:  # noqa: N802
        return self.Y_u(1.0 - q)

    def y_u(self, u: FloatArray) -> FloatArray:
        """``y(1 - u)`` for an array of gaps ``u = 1 - q`` in ``[0, 1]`` (no input checks)."""
        raise NotImplementedError

    def dy_u(self, u: FloatArray) -> FloatArray:
        """Density part of ``y'`` at ``q = 1 - u`` (0 at and above ``q_max``; no input checks)."""
        raise NotImplementedError

    def Y_u(self, u: FloatArray) -> FloatArray:  # noqa: N802
        """``Y(1 - u) = ∫_{1-u}^1 y(q') dq'`` (no input checks)."""
        raise NotImplementedError

    def has_density(self) -> bool:
        """Whether ``y'`` has a non-zero density part (besides atoms)."""
        return True

    def breakpoints_q(self) -> FloatArray:
        """Points in ``(0, q_max)`` where ``dy`` is not smooth (quadrature panel edges)."""
        return np.empty(0)

    def density_tail_s(self, eps: float) -> float:
        """An ``s = -log(1-q)`` beyond which ``∫ dy √(1-q) dq`` is below ``eps`` (``inf`` when
        that integral diverges)."""
        raise NotImplementedError

    @property
    def step_levels(self) -> tuple[FloatArray, FloatArray] | None:
        """``(q, y)`` of a k-RSB step function (:meth:`steps`), ``None`` for any other kind."""
        return None


def _check_table(q: FloatArray, y: FloatArray, strict_q: bool) -> None:
    if q.size == 0 or q.size != y.size:
        raise ValueError(f"q and y must be non-empty and of equal length, got {q.size}, {y.size}")
    for name, arr in (("q", q), ("y", y)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite, got {arr[~np.isfinite(arr)][0]}")
    if q[0] < 0.0 or q[-1] > 1.0:
        raise ValueError(f"q must lie in [0, 1], got {q[0] if q[0] < 0 else q[-1]}")
    if strict_q and np.any(np.diff(q) <= 0.0):
        i = int(np.argmax(np.diff(q) <= 0.0))
        raise ValueError(f"q must be strictly increasing, got q[{i}]={q[i]}, q[{i + 1}]={q[i + 1]}")
    if np.any(y < 0.0):
        raise ValueError(f"y must be >= 0, got {y[y < 0.0][0]}")
    if np.any(np.diff(y) < 0.0):
        i = int(np.argmax(np.diff(y) < 0.0))
        raise ValueError(f"y must be non-decreasing, got y[{i}]={y[i]} > y[{i + 1}]={y[i + 1]}")


@dataclass(frozen=True)
class _PowerLaw(ParisiFunction):
    q_max: float
    mu: float
    amplitude: float
    y0: float
    u_min: float = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "u_min", 1.0 - self.q_max)

    def _raw_y(self, u: FloatArray) -> FloatArray:
        with np.errstate(divide="ignore"):
            return self.y0 + self.amplitude * np.expm1(-self.mu * np.log(u))

    def _raw_Y(self, u: FloatArray) -> FloatArray:  # noqa: N802
        # ∫_{1-u}^1 y = y0 u + A (u^(1-mu)/(1-mu) - u)
        return self.y0 * u + self.amplitude * (u ** (1.0 - self.mu) / (1.0 - self.mu) - u)

    def y_u(self, u: FloatArray) -> FloatArray:
        u = np.asarray(u, dtype=np.float64)
        return self._raw_y(np.maximum(u, self.u_min))

    def dy_u(self, u: FloatArray) -> FloatArray:
        u = np.asarray(u, dtype=np.float64)
        inside = (u > self.u_min) & (u < 1.0 + 1e-300) & (u > 0.0)
        with np.errstate(divide="ignore", over="ignore"):
            dens = self.amplitude * self.mu * np.exp((-self.mu - 1.0) * np.log(u))
        return np.where(inside, dens, 0.0)

    def Y_u(self, u: FloatArray) -> FloatArray:  # noqa: N802
        u = np.asarray(u, dtype=np.float64)
        if self.u_min == 0.0:
            return self._raw_Y(u)
        um = self.u_min
        ymax = self._raw_y(np.float64(um))
        above = self._raw_Y(np.maximum(u, um)) - self._raw_Y(np.float64(um)) + um * ymax
        return np.where(u > um, above, u * ymax)

    def has_density(self) -> bool:
        return self.amplitude > 0.0

    def density_tail_s(self, eps: float) -> float:
        if self.amplitude == 0.0:
            return 0.0
        if self.mu >= 0.5:
            return math.inf
        # ∫_0^u A mu v^(-mu-1/2) dv = A mu u^(1/2-mu)/(1/2-mu)
        c = self.amplitude * self.mu / (0.5 - self.mu)
        return max(0.0, math.log(c / eps) / (0.5 - self.mu))


@dataclass(frozen=True)
class _Linear(ParisiFunction):
    q_max: float
    slope: float
    y0: float

    def y_u(self, u: FloatArray) -> FloatArray:
        q = 1.0 - np.asarray(u, dtype=np.float64)
        return self.y0 + self.slope * np.minimum(q, self.q_max)

    def dy_u(self, u: FloatArray) -> FloatArray:
        u = np.asarray(u, dtype=np.float64)
        return np.where(u > 1.0 - self.q_max, self.slope, 0.0)

    def Y_u(self, u: FloatArray) -> FloatArray:  # noqa: N802
        u = np.asarray(u, dtype=np.float64)
        um = 1.0 - self.q_max
        ymax = self.y0 + self.slope * self.q_max

        def raw(v: FloatArray) -> FloatArray:
            # ∫_{1-v}^1 (y0 + s q) dq = y0 v + s (v - v²/2)
            return self.y0 * v + self.slope * (v - 0.5 * v * v)

        above = raw(np.maximum(u, um)) - raw(np.float64(um)) + um * ymax
        return np.where(u > um, above, u * ymax)

    def has_density(self) -> bool:
        return self.slope > 0.0

    def density_tail_s(self, eps: float) -> float:
        if self.slope == 0.0:
            return 0.0
        # ∫_0^u slope √v dv = (2/3) slope u^(3/2)
        return max(0.0, math.log(2.0 * self.slope / (3.0 * eps)) / 1.5)


@dataclass(frozen=True, eq=False)
class _Tabulated(ParisiFunction):
    q_max: float
    q: FloatArray
    yv: FloatArray
    _cum: FloatArray = field(init=False, repr=False)
    _qn: FloatArray = field(init=False, repr=False)
    _yn: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # effective nodes: the table clipped at q_max, extended constant to q = 1
        qm = self.q_max
        y_at_qmax = float(np.interp(qm, self.q, self.yv))
        inner = self.q < qm
        qn = np.concatenate([[0.0], self.q[inner & (self.q > 0.0)], [qm, 1.0]])
        yn = np.concatenate([[self.yv[0]], self.yv[inner & (self.q > 0.0)], [y_at_qmax, y_at_qmax]])
        qn, idx = np.unique(qn, return_index=True)
        yn = yn[idx]
        # Y at the nodes by the exact trapezoid rule from the top
        seg = 0.5 * (yn[1:] + yn[:-1]) * np.diff(qn)
        cum = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])
        object.__setattr__(self, "_qn", qn)
        object.__setattr__(self, "_yn", yn)
        object.__setattr__(self, "_cum", cum)

    def _y_q(self, q: FloatArray) -> FloatArray:
        q = np.asarray(q, dtype=np.float64)
        return np.interp(q, self._qn, self._yn)

    def _dy_q(self, q: FloatArray) -> FloatArray:
        q = np.asarray(q, dtype=np.float64)
        slopes = np.diff(self._yn) / np.diff(self._qn)
        i = np.clip(np.searchsorted(self._qn, q, side="right") - 1, 0, slopes.size - 1)
        return np.where(q < self.q_max, slopes[i], 0.0)

    def _Y_q(self, q: FloatArray) -> FloatArray:  # noqa: N802
        q = np.asarray(q, dtype=np.float64)
        i = np.clip(np.searchsorted(self._qn, q, side="right") - 1, 0, self._qn.size - 2)
        q1 = self._qn[i + 1]
        yq = np.interp(q, self._qn, self._yn)
        return self._cum[i + 1] + 0.5 * (yq + self._yn[i + 1]) * (q1 - q)

    def breakpoints_q(self) -> FloatArray:
        return self._qn[(self._qn > 0.0) & (self._qn < self.q_max)]

    def has_density(self) -> bool:
        return bool(np.any(np.diff(self._yn) > 0.0))

    def density_tail_s(self, eps: float) -> float:
        if self.q_max < 1.0:
            return -math.log1p(-self.q_max)
        slopes = np.diff(self._yn) / np.diff(self._qn)
        smax = float(np.max(slopes)) if slopes.size else 0.0
        if smax == 0.0:
            return 0.0
        return max(0.0, math.log(2.0 * smax / (3.0 * eps)) / 1.5)

    def y_u(self, u: FloatArray) -> FloatArray:
        return self._y_q(1.0 - np.asarray(u, dtype=np.float64))

    def dy_u(self, u: FloatArray) -> FloatArray:
        return self._dy_q(1.0 - np.asarray(u, dtype=np.float64))

    def Y_u(self, u: FloatArray) -> FloatArray:  # noqa: N802
        return self._Y_q(1.0 - np.asarray(u, dtype=np.float64))


@dataclass(frozen=True, eq=False)
class _Steps(ParisiFunction):
    q_max: float
    q: FloatArray
    yv: FloatArray

    def _y_q(self, q: FloatArray) -> FloatArray:
        q = np.asarray(q, dtype=np.float64)
        i = np.searchsorted(self.q, q, side="right") - 1
        return np.where(i >= 0, self.yv[np.maximum(i, 0)], 0.0)

    def _dy_q(self, q: FloatArray) -> FloatArray:
        return np.zeros_like(np.asarray(q, dtype=np.float64))

    def _Y_q(self, q: FloatArray) -> FloatArray:  # noqa: N802
        q = np.asarray(q, dtype=np.float64)
        edges = np.append(self.q, 1.0)
        seg = self.yv * np.diff(edges)
        cum = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])  # Y at the edges
        i = np.searchsorted(self.q, q, side="right") - 1
        ic = np.maximum(i, 0)
        inside = cum[ic + 1] + self.yv[ic] * (edges[ic + 1] - q)
        return np.where(i >= 0, inside, cum[0])

    @property
    def step_levels(self) -> tuple[FloatArray, FloatArray] | None:
        return self.q.copy(), self.yv.copy()

    def atoms(self) -> tuple[FloatArray, FloatArray]:
        sizes = np.diff(np.concatenate([[0.0], self.yv]))
        keep = sizes > 0.0
        return self.q[keep].copy(), sizes[keep]

    def has_density(self) -> bool:
        return False

    def density_tail_s(self, eps: float) -> float:
        return 0.0

    def y_u(self, u: FloatArray) -> FloatArray:
        return self._y_q(1.0 - np.asarray(u, dtype=np.float64))

    def dy_u(self, u: FloatArray) -> FloatArray:
        return self._dy_q(1.0 - np.asarray(u, dtype=np.float64))

    def Y_u(self, u: FloatArray) -> FloatArray:  # noqa: N802
        return self._Y_q(1.0 - np.asarray(u, dtype=np.float64))
