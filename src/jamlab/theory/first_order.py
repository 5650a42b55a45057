"""First order in ``δγ``: the jump rate, the overlap and stress densities of jumps per unit
``|δγ|`` (SPEC §1; derivations in ``docs/theory.md``), for any Parisi function ``y(q)``.

The ``q`` integrals use the panels of :mod:`jamlab.theory.jumps` (in ``s = -log(1-q)``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from jamlab.theory.jumps import FloatArray, panel_edges, panel_nodes, s_of_q, scalar_or_array
from jamlab.theory.parisi import ParisiFunction

__all__ = [
    "jump_rate_first_order",
    "overlap_atoms_first_order",
    "overlap_density_first_order",
    "stress_jump_density_first_order",
]

_SQRT_PI = math.sqrt(math.pi)


def _density_integral(y: ParisiFunction, f, s_end: float) -> float:
    """``∫_0^{q_max} dq dy(q) f(1-q)`` over the density part, in ``s = -log(1-q)``."""
    edges = panel_edges(y, np.array([s_end]))
    s, w = panel_nodes(edges)
    u = np.exp(-s)
    return float(np.sum(y.dy_u(u) * u * w * f(u)))


def jump_rate_first_order(y: ParisiFunction) -> float:
    """Jump probability per unit ``|δγ|`` at small ``δγ``: ``(1/√π) ∫ dq y'(q) √(1-q)``.

    Includes the atoms of ``y'`` (the one at ``q = 0`` contributes ``y(0+)/√π``); ``inf`` when the
    integral diverges (``y' ~ (1-q)^(-μ-1)``, ``μ >= 1/2``, no cut-off).
    """
    qa, m = y.atoms()
    total = float(np.sum(m * np.sqrt(1.0 - qa)))
    s_end = min(float(s_of_q(np.float64(y.q_max))), y.density_tail_s(1e-18))
    if not math.isfinite(s_end):
        return math.inf
    if s_end > 0.0:
        total += _density_integral(y, np.sqrt, s_end)
    return total / _SQRT_PI


def overlap_density_first_order(y: ParisiFunction, q: ArrayLike) -> FloatArray | float:
    """Density of jumps per unit ``|δγ|`` at overlap ``q``: ``P[q] = √((1-q)/π) y'(q)``.

    Only the density part of ``y'`` is returned; the atoms (including the one at ``q = 0``) are
    point masses given by :func:`overlap_atoms_first_order`. Integrating the density over ``q``
    and adding the atoms gives :func:`jump_rate_first_order`.
    """
    qq = np.asarray(q, dtype=np.float64)
    return scalar_or_array(np.sqrt((1.0 - qq) / math.pi) * np.asarray(y.dy(qq)))


def overlap_atoms_first_order(y: ParisiFunction) -> tuple[FloatArray, FloatArray]:
    """Point masses of ``P[q]`` per unit ``|δγ|``: ``(q_a, m_a √(1-q_a)/√π)`` for each atom
    ``m_a`` of ``y'`` at ``q_a`` (e.g. ``y(0+)/√π`` at ``q = 0``)."""
    qa, m = y.atoms()
    return qa, m * np.sqrt(1.0 - qa) / _SQRT_PI


def stress_jump_density_first_order(y: ParisiFunction, dSigma: ArrayLike) -> FloatArray | float:
    """Density of stress jumps per unit ``δγ > 0`` (derived in ``docs/theory.md``)::

        P[ΔΣ] = θ(ΔΣ) ΔΣ ∫ dq y'(q) exp(-ΔΣ²/(4(1-q))) / √(4π(1-q))

    (atoms of ``y'`` included). The paper prints ``4π(1-q)`` in the exponent and denominator, a
    typo: two states at overlap ``q`` differ in stress by ``N(0, 2(1-q))``. ``∫ P[ΔΣ] dΔΣ`` equals
    :func:`jump_rate_first_order`. For ``δγ < 0`` mirror ``ΔΣ → -ΔΣ``.
    """
    ds = np.asarray(dSigma, dtype=np.float64)
    flat = ds.ravel()
    out = np.zeros_like(flat)
    qa, m = y.atoms()
    s_max = float(s_of_q(np.float64(y.q_max)))
    pos = np.flatnonzero(flat > 0.0)
    for i in pos:
        d = flat[i]
        val = 0.0
        for q0, m0 in zip(qa, m, strict=True):
            u0 = 1.0 - q0
            val += m0 * math.exp(-d * d / (4.0 * u0)) / math.sqrt(4.0 * math.pi * u0)
        # the Gaussian kills the integrand once d²/(4u) > 120
        s_end = min(s_max, math.log(480.0 / (d * d)) if d * d < 480.0 else 0.0)
        s_end = max(s_end, 0.0)
        if s_end > 0.0:
            val += _density_integral(
                y, lambda u, d=d: np.exp(-d * d / (4.0 * u)) / np.sqrt(4.0 * math.pi * u), s_end
            )
        out[i] = d * val
    return scalar_or_array(out.reshape(ds.shape))
