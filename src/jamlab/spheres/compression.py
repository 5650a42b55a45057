"""The coordination curve above jamming (paper Fig. 1) and its power-law fits.

``z − z_iso ∝ (φ − φ_J)^(1/2)`` and ``p ∝ (φ − φ_J)`` (O'Hern et al. 2003, ``SPEC.md`` §4).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jamlab import validation
from jamlab.spheres.describe import describe, z_iso
from jamlab.spheres.relax import compress_to
from jamlab.spheres.state import Packing

__all__ = ["CoordinationCurve", "compression_schedule", "coordination_curve", "fit_power_law",
           "fit_power_law_corrected"]

ProgressCallback = Callable[[str], None]


@dataclass(frozen=True, eq=False)
class CoordinationCurve:
    """Minima along a compression from a jammed packing, one entry per step.

    ``phi``, ``dphi = φ − φ_J``, ``z``, ``z_nr``, ``z_iso = 2(d(N'−1)+1)/N'``, ``n_rattlers``,
    total ``energy``, ``pressure``, ``converged``; ``phi_j`` and ``dim`` of the start.
    """

    phi_j: float
    dim: int
    n: int
    phi: np.ndarray
    dphi: np.ndarray
    z: np.ndarray
    z_nr: np.ndarray
    z_iso: np.ndarray
    n_rattlers: np.ndarray
    energy: np.ndarray
    pressure: np.ndarray
    converged: np.ndarray

    def as_columns(self) -> dict[str, np.ndarray]:
        """The per-step arrays by name (for CSV output)."""
        names = ("phi", "dphi", "z", "z_nr", "z_iso", "n_rattlers", "energy", "pressure")
        return {k: getattr(self, k) for k in names} | {"converged": self.converged.astype(int)}


def compression_schedule(phi_j: float, dphi_min: float, dphi_max: float,
                         steps: int) -> np.ndarray:
    """The ``Δφ_k`` of :func:`coordination_curve`: ``steps`` values spaced logarithmically from
    ``dphi_min`` to ``dphi_max``; ValueError unless ``0 < dphi_min < dphi_max``, ``steps ≥ 2``
    and ``φ_J + dphi_max < 1`` (callers check their arguments with it before any work)."""
    if not (0 < dphi_min < dphi_max):
        raise ValueError(f"need 0 < dphi_min < dphi_max, got {dphi_min!r}, {dphi_max!r}")
    if not (validation.is_integer(steps) and steps >= 2):
        raise ValueError(f"steps must be an integer >= 2, got steps={steps!r}")
    dphi = np.geomspace(dphi_min, dphi_max, int(steps))
    if phi_j + dphi[-1] >= 1.0:
        raise ValueError(f"phi_J + dphi_max = {phi_j + dphi[-1]} must stay below 1")
    return dphi


def coordination_curve(
    packing: Packing,
    phi_j: float | None = None,
    dphi_min: float = 1e-6,
    dphi_max: float = 0.3,
    steps: int = 40,
    ftol: float = 1e-12,
    max_iter: int = 1_000_000,
    progress: ProgressCallback | None = None,
) -> CoordinationCurve:
    """Compress a jammed packing to ``φ_k = φ_J + Δφ_k`` with ``Δφ_k`` logarithmically spaced
    from ``dphi_min`` to ``dphi_max`` (``steps`` values); each minimum starts from the previous
    one, affinely rescaled (:func:`compress_to`). ``φ_J`` defaults to the packing's ``φ``."""
    phi_j = packing.phi if phi_j is None else float(phi_j)
    dphi = compression_schedule(phi_j, dphi_min, dphi_max, steps)
    rows = []
    pk = packing
    for k, dp in enumerate(dphi):
        r = compress_to(pk, phi_j + dp, ftol=ftol, max_iter=max_iter)
        pk = r.packing
        s = describe(pk, r.energy)
        rows.append(
            (s.z, s.z_nr, pk.n - s.n_rattlers, s.n_rattlers, s.energy, s.pressure, r.converged)
        )
        if progress is not None:
            progress(f"step {k + 1}/{len(dphi)}: dphi={dp:.2e} p={s.pressure:.3e} z={s.z:.4f}")
    z, z_nr, n_kept, n_ratt, e, p, conv = (np.array(c) for c in zip(*rows, strict=True))
    return CoordinationCurve(
        phi_j=phi_j,
        dim=packing.dim,
        n=packing.n,
        phi=phi_j + dphi,
        dphi=dphi,
        z=z.astype(np.float64),
        z_nr=z_nr.astype(np.float64),
        z_iso=np.where(n_kept > 0, z_iso(np.maximum(n_kept, 1), packing.dim), np.nan),
        n_rattlers=n_ratt.astype(np.int64),
        energy=e.astype(np.float64),
        pressure=p.astype(np.float64),
        converged=conv.astype(bool),
    )


def fit_power_law(
    x: np.ndarray, y: np.ndarray, xmin: float = 1e-4, xmax: float = 1e-1
) -> tuple[float, float, float]:
    """Least-squares fit of ``log y = log c + a log x`` over ``xmin <= x <= xmax`` (and ``y > 0``).

    Returns ``(a, σ_a, c)``; ``σ_a`` is the standard error of the slope from the residual
    scatter (ordinary least squares, ``σ_a² = s² / Σ(log x − mean)²``).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    sel = (x >= xmin) & (x <= xmax) & (y > 0) & np.isfinite(y)
    if sel.sum() < 3:
        raise ValueError(f"need at least 3 points with y > 0 in [{xmin}, {xmax}], got {sel.sum()}")
    lx, ly = np.log(x[sel]), np.log(y[sel])
    a, b = np.polyfit(lx, ly, 1)
    resid = ly - (a * lx + b)
    s2 = float(resid @ resid) / max(len(lx) - 2, 1)
    sa = math.sqrt(s2 / float(((lx - lx.mean()) ** 2).sum()))
    return float(a), sa, float(math.exp(b))


def fit_power_law_corrected(
    x: np.ndarray, y: np.ndarray, xmin: float = 1e-4, xmax: float = 1e-1
) -> tuple[float, float, float, float, float]:
    """Least-squares fit with the leading correction to scaling, ``y = A x^b (1 + c x)``, in
    log space (``log y = log A + b log x + log(1 + c x)``) over ``xmin <= x <= xmax``.

    Returns ``(b, σ_b, A, c, σ_c)``; the standard errors come from the Jacobian at the optimum
    and the residual scatter (as :func:`scipy.optimize.curve_fit`). Starts from the plain fit
    (:func:`fit_power_law`) and ``c = 0``; ``ValueError`` with fewer than 4 points or if the fit
    does not converge.
    """
    from scipy.optimize import curve_fit

    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    sel = (x >= xmin) & (x <= xmax) & (y > 0) & np.isfinite(y)
    if sel.sum() < 4:
        raise ValueError(f"need at least 4 points with y > 0 in [{xmin}, {xmax}], got {sel.sum()}")
    lx, ly = np.log(x[sel]), np.log(y[sel])
    b0, _, a0 = fit_power_law(x, y, xmin, xmax)

    def model(lx: np.ndarray, log_a: float, b: float, c: float) -> np.ndarray:
        return log_a + b * lx + np.log1p(c * np.exp(lx))

    c_min = -0.999 / float(np.exp(lx.max()))  # keeps 1 + c x > 0 over the range
    try:
        popt, pcov = curve_fit(
            model,
            lx,
            ly,
            p0=(math.log(a0), b0, 0.0),
            bounds=((-np.inf, -np.inf, c_min), (np.inf, np.inf, np.inf)),
        )
    except (RuntimeError, ValueError) as exc:
        raise ValueError(f"corrected power-law fit failed: {exc}") from None
    err = np.sqrt(np.clip(np.diag(pcov), 0.0, None))
    return float(popt[1]), float(err[1]), float(math.exp(popt[0])), float(popt[2]), float(err[2])
