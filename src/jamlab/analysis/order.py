"""Bond-orientational order of a configuration: is a sheared packing still amorphous?

Steinhardt, Nelson and Ronchetti's order parameters (Phys. Rev. B 28, 784 (1983)) with the
crystalline-particle criterion of ten Wolde, Ruiz-Montero and Frenkel (J. Chem. Phys. 104,
9932 (1996)). Bonds join the pairs closer than ``cutoff · σ_ij`` (``σ_ij = (D_i + D_j)/2``;
the default ``cutoff = 1`` makes them the contacts of an over-jammed packing, and a larger one
reaches the first shell of a looser one); per particle

    q_lm(i) = (1/n_i) Σ_{j ∈ bonds(i)} Y_lm(r̂_ij),     q_l(i) = √(4π/(2l+1) Σ_m |q_lm(i)|²),

and over the whole configuration ``Q_l = √(4π/(2l+1) Σ_m |Q_lm|²)`` with ``Q_lm`` the average of
``Y_lm`` over all bonds. For ``l = 6``: ``Q_6`` of a perfect fcc lattice (12 neighbours) is
0.5745, hcp 0.4848, bcc (first shell of 8) 0.6285, simple cubic 0.3536; an isotropic
configuration's ``Q_6`` falls as ``(number of bonds)^(−1/2)``. A bond is *ordered* where the
normalised ``q_6`` vectors of its two ends have a real scalar product above ``0.7``
(``q̂_6(i) · q̂_6(j)* > 0.7``), and a particle is *crystalline* with at least 7 ordered bonds.

The bonds are the pairs of :func:`jamlab.analysis.contact_geometry.pairs_within` (Lees–Edwards
images in a k-d tree, ``h_max = cutoff − 1``), which refuses a cut-off distance of half the box
side or more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import sph_harm_y

from jamlab import validation
from jamlab.analysis.contact_geometry import pairs_within

__all__ = ["BondOrder", "bond_order"]

ORDERED_BOND = 0.7
"""ten Wolde's threshold of ``q̂_6(i) · q̂_6(j)*`` for an ordered bond."""
CRYSTALLINE_BONDS = 7
"""ten Wolde's number of ordered bonds that makes a particle crystalline."""


@dataclass(frozen=True)
class BondOrder:
    """Bond-orientational order of one configuration (``l`` the harmonic degree)."""

    l: int  # noqa: E741 - the harmonic degree's name in every paper
    global_q: float
    """``Q_l`` over all bonds."""
    local_q: NDArray[np.float64]
    """``q_l(i)`` per particle (``nan`` for a particle without bonds)."""
    crystalline: NDArray[np.bool_]
    """ten Wolde's crystalline particles (needs ``l = 6`` to mean what it says)."""
    neighbours: NDArray[np.int64]
    """Bonds per particle."""

    @property
    def crystalline_fraction(self) -> float:
        """Share of the particles that are crystalline."""
        return float(np.mean(self.crystalline))


def bond_order(
    positions: ArrayLike, length: float, strain: float = 0.0,
    diameters: ArrayLike | None = None, cutoff: float = 1.0, l: int = 6,  # noqa: E741
) -> BondOrder:
    """Steinhardt's ``Q_l``, ``q_l(i)`` and ten Wolde's crystalline particles of a 3D
    configuration (module docstring); bonds: the pairs closer than ``cutoff · σ_ij``,
    ``cutoff ≥ 1`` (the contacts at least); ``l`` even (odd degrees vanish for undirected
    bonds)."""
    x = np.asarray(positions, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"bond order needs 3D positions (N, 3), not {x.shape}")
    if not (validation.is_integer(l) and l >= 2 and l % 2 == 0):
        raise ValueError(f"l must be an even integer >= 2, not {l}")
    if not (math.isfinite(cutoff) and cutoff >= 1):
        raise ValueError(f"cutoff must be >= 1 (the contacts at least), not {cutoff}")
    n = x.shape[0]
    pairs = pairs_within(x, length, strain, diameters, h_max=cutoff - 1.0)
    i, j, r = pairs.i, pairs.j, pairs.rij  # r = r_i − r_j: the sign does not enter for even l
    count = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    if i.size == 0:
        return BondOrder(l, math.nan, np.full(n, math.nan), np.zeros(n, dtype=bool), count)
    dist = np.linalg.norm(r, axis=1)
    polar = np.arccos(np.clip(r[:, 2] / dist, -1.0, 1.0))
    azimuth = np.arctan2(r[:, 1], r[:, 0])
    m = np.arange(-l, l + 1)
    ylm = sph_harm_y(l, m[None, :], polar[:, None], azimuth[:, None])  # (bonds, 2l+1)
    # the bond seen from j is −r, and Y_lm(−r̂) = Y_lm(r̂) for even l
    qlm = np.zeros((n, 2 * l + 1), dtype=np.complex128)
    np.add.at(qlm, i, ylm)
    np.add.at(qlm, j, ylm)
    norm = 4.0 * math.pi / (2 * l + 1)
    total = ylm.mean(axis=0)
    global_q = math.sqrt(norm * float(np.sum(np.abs(total) ** 2)))
    with np.errstate(invalid="ignore", divide="ignore"):
        per = qlm / count[:, None]
        local = np.sqrt(norm * np.sum(np.abs(per) ** 2, axis=1))
        unit = per / np.linalg.norm(per, axis=1)[:, None]
    dot = np.real(np.sum(unit[i] * np.conj(unit[j]), axis=1))
    ordered = dot > ORDERED_BOND
    n_ordered = np.bincount(i[ordered], minlength=n) + np.bincount(j[ordered], minlength=n)
    local = np.where(count > 0, local, math.nan)
    return BondOrder(l, global_q, local, n_ordered >= CRYSTALLINE_BONDS, count)
