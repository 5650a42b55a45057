"""The Lees–Edwards periodic lattice of a sheared cube: reduced strain, minimum image, wrapping.

One implementation in numpy, imported by the box of :mod:`jamlab.spheres.box` and by the
analysis of positions (:mod:`jamlab.analysis.anatomy`, :mod:`jamlab.analysis.contact_geometry`),
which must not import ``jamlab.spheres`` (its compiled kernels) to read a configuration. The
compiled kernels keep their own per-pair copy of the same rule
(``jamlab.spheres.kernels.geometry``), checked against this one in the tests.

Conventions (``SPEC.md`` §3): side ``L``, flow ``x`` (axis 0), gradient ``y`` (axis 1). The
images of ``r`` are ``r + n_x L e_x + n_y (γ L e_x + L e_y) + Σ_{k≥2} n_k L e_k``; only ``γ``
modulo 1 matters.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["reduced_strain", "minimum_image", "wrap"]


def reduced_strain(strain: float) -> float:
    """``γ − round(γ)`` in ``[−1/2, 1/2]``: the strain that gives the same periodic lattice."""
    return strain - math.floor(strain + 0.5)


def minimum_image(dr: ArrayLike, length: float, strain: float) -> NDArray[np.float64]:
    """Minimum-image separation vectors (a new array ``(..., d)``, ``d ≥ 2``).

    First the ``y`` image: ``n_y = round(Δy/L)``, ``Δx −= n_y γ' L``, ``Δy −= n_y L`` with the
    reduced strain ``γ'``; then every other axis ``Δ_a −= round(Δ_a/L) L``. When ``L`` is
    above twice the cut-off, any image closer than the cut-off is unique and this finds it.
    """
    dr = np.array(dr, dtype=np.float64, copy=True)
    L = float(length)
    ny = np.floor(dr[..., 1] / L + 0.5)
    dr[..., 0] -= ny * reduced_strain(float(strain)) * L
    dr[..., 1] -= ny * L
    for a in range(dr.shape[-1]):
        if a == 1:
            continue
        dr[..., a] -= np.floor(dr[..., a] / L + 0.5) * L
    return dr


def wrap(positions: ArrayLike, length: float, strain: float) -> NDArray[np.float64]:
    """Equivalent positions inside ``[0, L)^d`` (a new array ``(N, d)``, sheared frame).

    Crossing the ``y`` boundary ``k`` times moves ``x`` by ``−k γ' L``; all other axes, and then
    ``x``, are reduced modulo ``L``. ``⌊x/L⌋ L`` can round ``x`` up to exactly ``L``: such a
    coordinate becomes ``0`` by the subtraction, and one rounded below ``0`` is set to ``0``.
    """
    pos = np.array(positions, dtype=np.float64, copy=True)
    L = float(length)
    ky = np.floor(pos[:, 1] / L)
    pos[:, 0] -= ky * reduced_strain(float(strain)) * L
    pos[:, 1] -= ky * L
    for a in range(pos.shape[1]):
        if a == 1:
            continue
        pos[:, a] -= np.floor(pos[:, a] / L) * L
    pos[pos >= L] -= L
    pos[pos < 0] = 0.0
    return pos
