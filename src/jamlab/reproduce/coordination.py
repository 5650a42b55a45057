"""Coordination exponents near jamming: jammed packings compressed step by step (paper Fig. 1).

Rule (``docs/reproduce.md``): ``coord_samples`` jammed packings of ``coord_n`` spheres (seeds
``seed + 1 + i``), each compressed along ``coord_steps`` log-spaced ``Δφ`` in ``[1e-6, 0.3]``;
least-squares slopes of ``z_nr − z_iso(N')`` and ``p`` against ``φ − φ_J`` over ``[1e-4, 1e-1]``
(:func:`jamlab.spheres.packing.fit_power_law`); mean over packings, σ = the standard error over
packings (the fit error when only one packing).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jamlab.paper import COORDINATION_EXPONENTS
from jamlab.reproduce.cache import cache_file, load_curve, save_curve
from jamlab.reproduce.scales import Scale

__all__ = ["CoordinationExponent", "CoordinationResult", "coordination",
           "coordination_curves", "coordination_exponents"]


@dataclass(frozen=True)
class CoordinationExponent:
    """One exponent: mean over packings, its σ and the number of packings fitted."""

    exponent: float
    sigma: float
    packings: int


@dataclass(frozen=True)
class CoordinationResult:
    """The curves (one per jammed packing) and the exponents, keyed as
    :data:`jamlab.paper.COORDINATION_EXPONENTS` (``"z_nr - z_iso"``, ``"p"``)."""

    curves: tuple[Any, ...]
    exponents: dict[str, CoordinationExponent]

    @property
    def phi_j_first(self) -> float:
        """φ_J of the first packing (NaN when none jammed)."""
        return self.curves[0].phi_j if self.curves else math.nan


def coordination_curves(scale: Scale, cache: Path, log: Callable[[str], None]) -> list[Any]:
    """Coordination curves of ``coord_samples`` packings, read from or written to the cache
    directory ``cache`` (:mod:`jamlab.reproduce.cache`); a packing that fails to jam is skipped
    (and logged)."""
    from jamlab.spheres.packing import coordination_curve, jam

    cache.mkdir(parents=True, exist_ok=True)
    curves = []
    for i in range(scale.coord_samples):
        seed = scale.seed + 1 + i
        f = cache_file(cache, scale.coord_n, seed, scale.coord_steps, scale.sizes, scale.alpha)
        if f.is_file():
            curves.append(load_curve(f))
            continue
        t = time.perf_counter()
        res = jam(scale.coord_n, 3, seed, sizes=scale.sizes, alpha=scale.alpha)
        if not res.ok:
            log(f"coordination: packing seed {seed} failed ({res.reason}); skipped")
            continue
        c = coordination_curve(res.packing, res.phi_j, steps=scale.coord_steps)
        save_curve(f, c)
        log(f"coordination: packing seed {seed} (N={scale.coord_n}) "
            f"in {time.perf_counter() - t:.0f} s")
        curves.append(c)
    return curves


def coordination_exponents(curves: list[Any]) -> dict[str, tuple[float, float, int]]:
    """``{name: (mean exponent, σ, packings)}`` for ``z_nr − z_iso`` and ``p`` (module rule)."""
    from jamlab.spheres.packing import fit_power_law

    out: dict[str, tuple[float, float, int]] = {}
    for name in COORDINATION_EXPONENTS:
        fits = []
        for c in curves:
            y = c.z_nr - c.z_iso if name == "z_nr - z_iso" else c.pressure
            try:
                fits.append(fit_power_law(c.dphi, y))
            except ValueError:
                continue
        if not fits:
            out[name] = (math.nan, math.nan, 0)
            continue
        a = np.array([f[0] for f in fits])
        err = float(a.std(ddof=1) / math.sqrt(a.size)) if a.size > 1 else float(fits[0][1])
        out[name] = (float(a.mean()), err, a.size)
    return out


def coordination(scale: Scale, cache: Path, log: Callable[[str], None]) -> CoordinationResult:
    """Curves (cached in ``cache``) and exponents of the module rule."""
    curves = coordination_curves(scale, cache, log)
    exps = {k: CoordinationExponent(*v) for k, v in coordination_exponents(curves).items()}
    return CoordinationResult(tuple(curves), exps)
