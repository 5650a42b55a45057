"""Sizes drawn from known laws, for the tests of the fits (imported by name: ``tests`` is on the
test path)."""

from __future__ import annotations

import numpy as np


def cutoff_power_law(rng: np.random.Generator, tau: float, s_c: float, m: int,
                     x_min: float = 1.0) -> np.ndarray:
    """``m`` sizes of ``S^−τ e^(−S/S_c)`` on ``S ≥ x_min``: Pareto draws (inverse transform of
    ``rng.random``) thinned by the cut-off ``e^(−(S − x_min)/S_c)``."""
    out = np.empty(0)
    while out.size < m:
        s = x_min * (1 - rng.random(4 * m)) ** (-1 / (tau - 1))
        out = np.concatenate([out, s[rng.random(s.size) < np.exp(-(s - x_min) / s_c)]])
    return out[:m]
