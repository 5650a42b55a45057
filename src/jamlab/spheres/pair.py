"""The pair law: the only place the interaction between two spheres is written.

``SPEC.md`` §5: for spheres of diameters ``D_i``, ``D_j`` at distance ``r``,

    V(r) = ε (1 − r/σ_ij)^α   for r < σ_ij,   0 otherwise,     σ_ij = (D_i + D_j)/2,

with ``ε = 1`` and any exponent ``α > 1``: ``α = 2`` is the harmonic law of the paper
(``SPEC.md`` §3, ``D = 1``), ``α = 5/2`` the Hertzian one. With ``h = 1 − r/σ``

    V' = dV/dr = −(α/σ) h^(α−1),       V'' = d²V/dr² = (α(α−1)/σ²) h^(α−2).

(O'Hern et al. 2003 write ``(ε/α)(1 − r/σ)^α``: their energies are ours divided by ``α``.)

Every numba kernel (energy, forces, virial, Hessian blocks, ``∂F/∂γ``, the AQS kernels) gets
``V``, ``V'`` and ``V''`` from :func:`pair_terms` and ``σ_ij`` from :func:`pair_sigma`; adding a
pair law means changing these two small functions. For ``α = 2`` the expressions are evaluated
in the same floating-point operations as the harmonic kernels written by hand before (bit for bit
the same energies and forces for ``D = 1``).

For continuing a branch across contact changes the AQS code treats every contact of a network as
a spring also in tension (``r > σ``, ``h < 0``). :func:`pair_terms` extends the law there as
``ε |h|^α`` (for ``α = 2`` the polynomial itself); the cut-off is the caller's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "HARMONIC",
    "HERTZIAN",
    "check_alpha",
    "pair_sigma",
    "pair_terms",
    "pair_sigmas",
    "pair_energy",
]

HARMONIC = 2.0
"""``α`` of the harmonic law (the paper's)."""
HERTZIAN = 2.5
"""``α`` of the Hertzian law."""


def check_alpha(alpha: float) -> float:
    """``alpha`` as a float, or ``ValueError`` unless it is finite and ``> 1``."""
    try:
        a = float(alpha)
    except (TypeError, ValueError):
        raise ValueError(f"pair exponent alpha must be a number > 1, got alpha={alpha!r}") from None
    if not (math.isfinite(a) and a > 1.0):
        raise ValueError(f"pair exponent alpha must be finite and > 1, got alpha={alpha!r}")
    return a


@njit(inline="always", cache=True)
def pair_sigma(diam, i, j):
    """``σ_ij = (D_i + D_j)/2``."""
    return 0.5 * (diam[i] + diam[j])


@njit(inline="always", cache=True)
def pair_terms(r, sigma, alpha):
    """``(V, V', V'')`` at distance ``r`` (module docstring); the caller applies the cut-off
    ``r < σ``. Beyond it (``h < 0``, a network spring in tension) this is ``|h|^α``."""
    h = 1.0 - r / sigma
    if alpha == 2.0:
        return h * h, -2.0 * h / sigma, 2.0 / (sigma * sigma)
    a = abs(h)
    hm = a ** (alpha - 2.0)
    return hm * a * a, -alpha * (hm * h) / sigma, alpha * (alpha - 1.0) * hm / (sigma * sigma)


def pair_sigmas(diameters: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``σ_ij = (D_i + D_j)/2`` for index arrays (numpy form of :func:`pair_sigma`)."""
    return 0.5 * (diameters[i] + diameters[j])


def pair_energy(r: np.ndarray, sigma: np.ndarray, alpha: float = HARMONIC) -> np.ndarray:
    """``V(r)`` elementwise (numpy; for tests, plots and documentation)."""
    r = np.asarray(r, dtype=np.float64)
    h = np.clip(1.0 - r / np.asarray(sigma, dtype=np.float64), 0.0, None)
    return h**alpha
