"""The laws of the jump's scalars beside ``ΔE``: ``ΔU``, ``ΔΣ`` (:class:`ScalarJumpLaw`) and the
overlap ``q`` between old and new ground states (:class:`JumpOverlapLaw`), as
:class:`jamlab.theory.exact_law.ExactJumpLaw` exposes them (``du``, ``dsigma``, ``overlap``); and
the argument checks the exact laws share (:func:`checked_floats`, :func:`one_sided`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from jamlab.theory.jumps import scalar_or_array

__all__ = ["JumpOverlapLaw", "ScalarJumpLaw", "checked_floats", "one_sided"]


class ScalarJumpLaw:
    """Law of ``ΔU`` or ``ΔΣ``: an atom ``p_no_jump`` at 0 and the density ``pdf`` of the jumps.

    ``sign = +1``: the jumps' values are positive (``ΔU``; ``ΔΣ`` for ``δγ > 0``); ``-1``: negative
    (``ΔΣ`` for ``δγ < 0``). ``cdf(s) = P(X <= s)``.
    """

    def __init__(self, p_no_jump: float, pdf_pos: Any, cdf_pos: Any, sign: int = 1) -> None:
        self.p_no_jump = float(p_no_jump)
        self._pdf = pdf_pos  # density at s > 0 of |X|
        self._cdf = cdf_pos  # P(0 < |X| <= s), s >= 0
        self.sign = 1 if sign >= 0 else -1

    def pdf(self, s: Any) -> np.ndarray | float:
        """Density of the jumps' part at ``s`` (0 on the wrong side of 0)."""
        values = one_sided(s, "s", self.sign, lambda v: self._pdf(self.sign * v), 0.0)
        return scalar_or_array(values)

    def cdf(self, s: Any) -> np.ndarray | float:
        """``P(X <= s)``, the atom at 0 included."""
        a = checked_floats("s", s)
        flat = a.ravel()
        out = np.empty(flat.size)
        jumps_total = 1.0 - self.p_no_jump
        if self.sign > 0:
            neg = flat < 0
            out[neg] = 0.0
            if np.any(~neg):
                out[~neg] = self.p_no_jump + self._cdf(flat[~neg])
        else:
            pos = flat >= 0
            out[pos] = 1.0
            if np.any(~pos):
                out[~pos] = jumps_total - self._cdf(-flat[~pos])
        return scalar_or_array(np.clip(out, 0.0, 1.0).reshape(a.shape))


class JumpOverlapLaw:
    """Law of the overlap ``q`` between old and new ground states.

    ``levels``: the overlaps ``q_i``; ``masses``: ``P(q = q_i)``; ``p_no_jump``: the atom at
    ``q = 1``. For a discrete cascade the law is atomic (:meth:`atoms`; ``pdf`` is 0). For the
    continuum (``continuum=True``) the levels are a fine graded grid: the masses become the density
    ``pdf`` (mass per unit ``q`` between neighbouring levels, from the finer of the two level
    sets, not extrapolated) except an atom of mass ``atom0`` at ``q = 0`` when ``y(0+) > 0`` and,
    when the top level sits at ``q_max`` (as :func:`exact_jump_law` builds it), the top level's
    mass: an atom at ``q_max`` (the new ground state in the old one's lowest cluster; with a
    cut-off ``q_cut``, every overlap above it).
    """

    def __init__(self, levels: np.ndarray, masses: np.ndarray, p_no_jump: float,
                 continuum: bool = False, atom0: float = 0.0, q_max: float = 1.0) -> None:
        self.levels = np.asarray(levels, dtype=np.float64)
        self.masses = np.asarray(masses, dtype=np.float64)
        self.p_no_jump = float(p_no_jump)
        self.continuum = continuum
        self.atom0 = float(atom0)
        self.q_max = q_max
        # the top level at q_max has no width: its mass is an atom there, not a density
        self._top_atom = (float(self.masses[-1]) if continuum and self.levels[-1] >= q_max
                          else 0.0)

    def _density_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """The cells' edges and masses of the density (``atom0`` and the top atom taken out)."""
        top = self.levels[-1] >= self.q_max
        edges = self.levels if top else np.append(self.levels, self.q_max)
        m = self.masses[:-1].copy() if top else self.masses.copy()
        m[0] -= self.atom0
        return edges, m

    def atoms(self) -> tuple[np.ndarray, np.ndarray]:
        """``(positions, masses)`` of the atoms, ``q = 1`` (no jump) last."""
        if self.continuum:
            pos = ([0.0] if self.atom0 > 0 else []) + ([self.q_max] if self._top_atom > 0 else [])
            mass = (([self.atom0] if self.atom0 > 0 else [])
                    + ([self._top_atom] if self._top_atom > 0 else []))
            return np.array(pos + [1.0]), np.array(mass + [self.p_no_jump])
        return np.append(self.levels, 1.0), np.append(self.masses, self.p_no_jump)

    def pdf(self, q: Any) -> np.ndarray | float:
        """Density of ``q`` (continuum; 0 for a discrete cascade)."""
        qa = checked_floats("q", q)
        if not self.continuum:
            return scalar_or_array(np.zeros(qa.shape))
        edges, m = self._density_cells()
        dens = m / np.diff(edges)
        centres = 0.5 * (edges[1:] + edges[:-1])
        out = np.interp(qa, centres, dens, left=dens[0], right=dens[-1])
        return scalar_or_array(np.where((qa >= 0) & (qa < self.q_max), out, 0.0))

    def cdf(self, q: Any) -> np.ndarray | float:
        """``P(q_jump <= q)`` (the atom at ``q = 1`` included at ``q = 1``)."""
        qa = checked_floats("q", q)
        if not self.continuum:
            cum = np.cumsum(self.masses)
            idx = np.searchsorted(self.levels, qa, side="right")
            out = np.where(idx > 0, cum[np.maximum(idx, 1) - 1], 0.0)
        else:
            edges, m = self._density_cells()
            cum = np.concatenate(([self.atom0], self.atom0 + np.cumsum(m)))
            out = np.interp(qa, edges, cum, left=0.0, right=cum[-1])
            out = np.where(qa < 0, 0.0, out)
            out = np.where(qa >= self.q_max, out + self._top_atom, out)
        out = np.where(qa >= 1.0, out + self.p_no_jump, out)
        return scalar_or_array(np.clip(out, 0.0, 1.0))


def checked_floats(name: str, x: Any) -> np.ndarray:
    """``x`` as float64; ValueError naming the argument if any value is NaN."""
    a = np.asarray(x, dtype=np.float64)
    if np.any(np.isnan(a)):
        raise ValueError(f"{name} must not be NaN, got {name} = nan")
    return a


def one_sided(x: Any, name: str, side: int, values: Any, fill: float) -> np.ndarray:
    """``values(x_i)`` where ``side · x_i > 0``, ``fill`` elsewhere (the shape of ``x``): a law
    given on one side of 0 only."""
    a = checked_floats(name, x)
    flat = a.ravel()
    out = np.full(flat.size, fill)
    on = side * flat > 0
    if np.any(on):
        out[on] = values(flat[on])
    return out.reshape(a.shape)
