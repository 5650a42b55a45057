"""The pair law: the only place the interaction between two spheres is written.

``SPEC.md`` §5: for spheres of diameters ``D_i``, ``D_j`` at distance ``r``,

    V(r) = ε (1 − r/σ_ij)^α   for r < σ_ij,   0 otherwise,     σ_ij = (D_i + D_j)/2,

with ``ε = 1`` and any exponent ``α > 1``: ``α = 2`` is the harmonic law of the paper
(``SPEC.md`` §3, ``D = 1``), ``α = 5/2`` the Hertzian one. With ``h = 1 − r/σ``

    V' = dV/dr = −(α/σ) h^(α−1),       V'' = d²V/dr² = (α(α−1)/σ²) h^(α−2).

(O'Hern et al. 2003 write ``(ε/α)(1 − r/σ)^α``: their energies are ours divided by ``α``.)

Every numba kernel (energy, forces, virial, Hessian blocks, ``∂F/∂γ``, the AQS kernels) gets
``V``, ``V'`` and ``V''`` from :func:`pair_terms` and ``σ_ij`` from :func:`pair_sigma`; adding a
pair law means changing these two small functions. Kernels take the law as ``(diam, alpha)``
from :func:`kernel_law`: ``diam=None`` (all ``D = 1``) and ``alpha=None`` (``α = 2``) are
compile-time specialisations, so for the paper's system the kernels are the hand-written harmonic
ones — same operations, same bits, same speed (``benchmarks/bench_pair_law.py``).

For continuing a branch across contact changes the AQS code treats every contact of a network as
a spring also in tension (``r > σ``, ``h < 0``). :func:`pair_terms` extends the law there as
``ε |h|^α`` (for ``α = 2`` the polynomial itself); the cut-off is the caller's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload

__all__ = [
    "HARMONIC",
    "HERTZIAN",
    "check_alpha",
    "pair_sigma",
    "pair_terms",
    "harmonic_terms_masked",
    "pair_sigmas",
    "pair_energy",
    "contact_force",
    "kernel_law",
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


def pair_sigma(diam, i, j):
    """``σ_ij = (D_i + D_j)/2`` inside numba kernels; ``diam=None`` means every ``D = 1``.

    The two cases are compiled separately (numba overload on the argument's type), so the
    monodisperse kernels contain no diameter at all: ``σ = 1`` is a compile-time constant and
    they are exactly the harmonic kernels written by hand before pair laws existed (same speed,
    same bits). Use :func:`pair_sigmas` from numpy code."""
    raise NotImplementedError("pair_sigma is for numba kernels; use pair_sigmas")


@overload(pair_sigma, inline="always")
def _pair_sigma_numba(diam, i, j):
    if isinstance(diam, types.NoneType):
        return lambda diam, i, j: 1.0
    return lambda diam, i, j: 0.5 * (diam[i] + diam[j])


@njit(inline="always", cache=True)
def _harmonic_of_h(h, sigma):
    return h * h, -2.0 * h / sigma, 2.0 / (sigma * sigma)


@njit(inline="always", cache=True)
def _harmonic_terms(r, sigma):
    return _harmonic_of_h(1.0 - r / sigma, sigma)


@njit(inline="always", cache=True)
def harmonic_terms_masked(r2, r, sigma):
    """``(V, V')`` of the harmonic law (``α = 2``) at ``r = √r2``, both zero unless
    ``r2 < σ²`` — the kernels' contact test, applied without a branch: ``h`` is set to zero
    beyond contact by a select, so a pair sum has no data-dependent jump (the same bits as
    :func:`pair_terms` inside the cut-off, exact zeros outside). Pays where the contact pattern
    of a neighbour list is too long for the branch predictor to learn (``docs/spheres.md``,
    "Branch-free force kernel")."""
    h = 1.0 - r / sigma
    h = h if r2 < sigma * sigma else 0.0
    v, dv, _ = _harmonic_of_h(h, sigma)
    return v, dv


def pair_terms(r, sigma, alpha):
    """``(V, V', V'')`` at distance ``r`` inside numba kernels (module docstring); the caller
    applies the cut-off ``r < σ``. Beyond it (``h < 0``, a network spring in tension) the law is
    ``|h|^α``. ``alpha=None`` means ``α = 2`` fixed at compile time (the harmonic kernels);
    a float ``alpha`` is read at run time (``α = 2`` and ``α = 5/2`` have exact fast paths:
    ``h^(α−2)`` is 1 and ``√|h|``)."""
    raise NotImplementedError("pair_terms is for numba kernels")


@overload(pair_terms, inline="always")
def _pair_terms_numba(r, sigma, alpha):
    if isinstance(alpha, types.NoneType):
        return lambda r, sigma, alpha: _harmonic_terms(r, sigma)

    def impl(r, sigma, alpha):
        if alpha == 2.0:
            return _harmonic_terms(r, sigma)
        h = 1.0 - r / sigma
        a = abs(h)
        hm = np.sqrt(a) if alpha == 2.5 else a ** (alpha - 2.0)
        return hm * a * a, -alpha * (hm * h) / sigma, alpha * (alpha - 1.0) * hm / (sigma * sigma)

    return impl


def kernel_law(diameters: np.ndarray, alpha: float) -> tuple[np.ndarray | None, float | None]:
    """The pair law as kernels take it: ``(None, ·)`` for all ``D = 1`` and ``(·, None)`` for
    ``α = 2``, so that the paper's system runs the specialised harmonic monodisperse kernels."""
    d = np.ascontiguousarray(diameters, dtype=np.float64)
    return (None if np.all(d == 1.0) else d), (None if alpha == 2.0 else float(alpha))


def pair_energy(r: np.ndarray, sigma: np.ndarray, alpha: float) -> np.ndarray:
    """Numpy form of ``V``: the energy ``(1 − r/σ)^α`` of pairs at ``r < σ`` (0 beyond), for
    arrays (numpy code; kernels use :func:`pair_terms`)."""
    r = np.asarray(r, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    return np.clip(1.0 - r / sigma, 0.0, None) ** alpha


def contact_force(r: np.ndarray, sigma: np.ndarray, alpha: float) -> np.ndarray:
    """Numpy form of ``−V'``: the repulsive force ``f = (α/σ)(1 − r/σ)^(α−1)`` of pairs at
    ``r < σ`` (0 beyond), for arrays (analysis code; kernels use :func:`pair_terms`)."""
    r = np.asarray(r, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    overlap = np.clip(1.0 - r / sigma, 0.0, None)
    return alpha * overlap ** (alpha - 1.0) / sigma


def pair_sigmas(diameters: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``σ_ij = (D_i + D_j)/2`` for index arrays (numpy form of :func:`pair_sigma`)."""
    return 0.5 * (diameters[i] + diameters[j])
