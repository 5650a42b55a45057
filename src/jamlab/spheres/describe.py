"""Contact statistics of a minimum: ``z``, ``z_nr``, rattlers, isostaticity (``SPEC.md`` §3, §5).

A packing is *isostatic* when its rattler-free backbone has exactly the number of contacts needed
for rigidity in a periodic box, ``N_c' = d(N' − 1) + 1`` (``d(N'−1)`` non-trivial degrees of
freedom, plus one for the box volume / pressure); equivalently ``z_nr = z_iso(N')`` with

    z_iso(N') = 2 (d (N' − 1) + 1) / N'  →  2d  as  N' → ∞.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamlab.spheres.contacts import contacts, remove_rattlers
from jamlab.spheres.potential import energy_and_forces, pressure
from jamlab.spheres.state import Packing

__all__ = ["isostatic_contacts", "z_iso", "PackingState", "describe"]



def isostatic_contacts(n_nonrattlers: int, dim: int) -> int:
    """``N_c,iso = d (N' − 1) + 1`` contacts for a rigid backbone of ``N'`` particles."""
    return dim * (n_nonrattlers - 1) + 1


def z_iso(n_nonrattlers: int | np.ndarray, dim: int) -> float | np.ndarray:
    """``z_iso(N') = 2(d(N' − 1) + 1)/N'``, the isostatic coordination at finite ``N'``."""
    n = np.asarray(n_nonrattlers, dtype=np.float64)
    out = 2.0 * (dim * (n - 1.0) + 1.0) / n
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True)
class PackingState:
    """Contact statistics of a minimum: ``phi``, total ``energy``, ``pressure``, ``z = 2N_c/N``,
    ``z_nr = 2N_c'/N'``, ``n_rattlers = N − N'``, ``n_contacts`` (N_c), ``n_contacts_nr`` (N_c'),
    ``n_contacts_iso = d(N'−1)+1``, ``isostatic`` (``N_c' == n_contacts_iso``)."""

    phi: float
    energy: float
    pressure: float
    z: float
    z_nr: float
    n_rattlers: int
    n_contacts: int
    n_contacts_nr: int
    n_contacts_iso: int
    isostatic: bool

    def as_attrs(self, prefix: str = "") -> dict[str, float | int | bool]:
        """The fields as a flat dict (HDF5 attributes)."""
        return {f"{prefix}{k}": v for k, v in self.__dict__.items()}


def describe(packing: Packing, energy: float | None = None) -> PackingState:
    """Contact statistics of ``packing`` (see :class:`PackingState`)."""
    ci, _, _ = contacts(packing)
    rr = remove_rattlers(packing)
    n_kept = packing.n - rr.n_rattlers
    n_iso = isostatic_contacts(n_kept, packing.dim) if n_kept > 0 else 0
    if energy is None:
        energy = energy_and_forces(packing)[0]
    return PackingState(
        phi=packing.phi,
        energy=float(energy),
        pressure=pressure(packing),
        z=2.0 * len(ci) / packing.n,
        z_nr=rr.z_nr,
        n_rattlers=rr.n_rattlers,
        n_contacts=len(ci),
        n_contacts_nr=rr.n_contacts_nr,
        n_contacts_iso=n_iso,
        isostatic=bool(n_kept > 0 and rr.n_contacts_nr == n_iso),
    )

