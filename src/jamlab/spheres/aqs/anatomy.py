"""The avalanche records of an AQS run (``shear(..., keep_avalanches=True)``): for every plastic
step the anatomy of :mod:`jamlab.analysis.anatomy` measured on the minima before and after it,
collected into the trace group ``avalanches`` (``docs/formats.md``). The anatomy numbers are
those of the event field: the step's non-affine displacement without the linear elastic
response of the minimum before (:func:`elastic_nonaffine_response`)."""

from __future__ import annotations

import numpy as np

from jamlab.analysis.anatomy import (
    N_EFF_LOCALIZED,
    elastic_response,
    event_anatomy,
    moved_particles,
)
from jamlab.spheres.contacts import backbone_mask, contacts
from jamlab.spheres.potential import Packing, dforce_dstrain, hessian

__all__ = [
    "AVALANCHE_COLUMNS",
    "EXTENT_COLUMNS",
    "MOVED_THRESHOLD",
    "AvalancheRecorder",
    "elastic_nonaffine_response",
]

MOVED_THRESHOLD = 1e-3
"""Default ``|u|`` (units of the mean diameter) above which a particle's displacement is kept."""

# one row per plastic step
AVALANCHE_COLUMNS: tuple[str, ...] = (
    "step",
    "energy_jump",
    "stress_jump",
    "participation",
    "n_eff",
    "max_displacement",
    "n_opened",
    "n_closed",
    "only_bucklers_rattlers",
    "localized",
    "n_moved",
    "elastic_fraction",
)

# one row per plastic step, ``d`` values each (:func:`jamlab.analysis.anatomy.event_extent`)
EXTENT_COLUMNS: tuple[str, ...] = ("radii", "thin_axis")


def elastic_nonaffine_response(
    packing: Packing, dgamma: float, backbone: np.ndarray | None = None
) -> np.ndarray:
    """``u^el = δγ K⁺ Ξ`` of the minimum ``packing`` (:func:`jamlab.analysis.anatomy.
    elastic_response`), Hessian and ``∂F/∂γ`` of the contacts between ``backbone`` particles
    (default: rattlers removed from the contact list, ``d + 1`` contacts)."""
    if backbone is None:
        ci, cj, _ = contacts(packing)
        backbone = backbone_mask(ci, cj, packing.n, packing.dim + 1)
    return elastic_response(
        hessian(packing, backbone=backbone),
        dforce_dstrain(packing, backbone=backbone),
        dgamma,
        backbone,
    )


class AvalancheRecorder:
    """The hook ``(previous minimum, new minimum, step)`` of :func:`~jamlab.spheres.aqs.shear`
    that measures every plastic step; ``first_row``: the trace row of the first step it sees.
    ``threshold``: event displacements ``|u_i| > threshold`` are kept (CSR: ``moved_offsets``,
    ``moved_index``, ``moved_displacement``); ``n_eff_max``: the localized/extended rule.
    ``previous``: the group of a resumed trace; rows written before ``elastic_fraction``
    existed get NaN there (their fields were not corrected), and so do rows written before the
    :data:`EXTENT_COLUMNS` existed."""

    def __init__(
        self,
        first_row: int,
        threshold: float = MOVED_THRESHOLD,
        n_eff_max: float = N_EFF_LOCALIZED,
        previous: dict[str, np.ndarray] | None = None,
    ) -> None:
        if not (np.isfinite(threshold) and threshold >= 0):
            raise ValueError(f"avalanche threshold must be finite and >= 0, got {threshold!r}")
        self.row = int(first_row)
        self.threshold, self.n_eff_max = float(threshold), float(n_eff_max)
        self.rows: dict[str, list] = {k: [] for k in AVALANCHE_COLUMNS}
        self.index: list[np.ndarray] = []
        self.vectors: list[np.ndarray] = []
        self.extent: dict[str, list] = {k: [] for k in EXTENT_COLUMNS}
        self.dim: int | None = None
        if previous is not None:
            offsets = np.asarray(previous["moved_offsets"])
            rows = offsets.size - 1
            for k in AVALANCHE_COLUMNS:
                self.rows[k] = list(previous[k]) if k in previous else [np.nan] * rows
            for k in EXTENT_COLUMNS:  # (rows without them: NaN in ``table``)
                self.extent[k] = (list(np.asarray(previous[k], dtype=np.float64))
                                  if k in previous else [np.zeros(0)] * rows)
            for a, b in zip(offsets[:-1], offsets[1:], strict=True):
                self.index.append(np.asarray(previous["moved_index"][a:b]))
                self.vectors.append(np.asarray(previous["moved_displacement"][a:b]))

    def __call__(self, before: Packing, after: Packing, step: object) -> None:
        n = self.row
        self.row += 1
        if getattr(step, "plastic", False):
            self.record(n, before, after)

    def record(self, n: int, before: Packing, after: Packing) -> None:
        """Add the row of the plastic step ending at trace row ``n`` (minima ``before`` and
        ``after``; rows must come in increasing ``n``). If the box side changed in the step
        (fixed pressure), the affine part includes the isotropic dilation ``L_a/L_b``: the
        positions before are rescaled to the box after before the difference is taken. The
        elastic response subtracted is the fixed-box one of the minimum before (its shear
        response; the non-affine response to the step's elastic volume change stays in the
        event field, ``docs/criticality.md``)."""
        dim = before.dim
        self.dim = dim
        b0, b1 = contacts(before), contacts(after)
        keep0 = backbone_mask(b0[0], b0[1], before.n, dim + 1)
        keep1 = backbone_mask(b1[0], b1[1], after.n, dim + 1)
        elastic = elastic_nonaffine_response(before, after.strain - before.strain, keep0)
        x_before = np.asarray(before.positions, dtype=np.float64)
        if after.box.length != before.box.length:
            x_before = x_before * (after.box.length / before.box.length)
        an = event_anatomy(
            x_before,
            after.positions,
            after.box.length,
            before.strain,
            after.strain,
            (b0[0], b0[1]),
            (b1[0], b1[1]),
            keep0,
            keep1,
            n_eff_max=self.n_eff_max,
            elastic=elastic,
        )
        idx, vec = moved_particles(an.u, self.threshold)
        r = self.rows
        r["step"].append(n)
        r["energy_jump"].append(np.nan)  # filled from the trace's rows (table)
        r["stress_jump"].append(np.nan)
        r["participation"].append(an.participation)
        r["n_eff"].append(an.n_eff)
        r["max_displacement"].append(an.max_displacement)
        r["n_opened"].append(an.opened.shape[0])
        r["n_closed"].append(an.closed.shape[0])
        r["only_bucklers_rattlers"].append(an.only_bucklers_rattlers)
        r["localized"].append(an.localized)
        r["n_moved"].append(idx.size)
        r["elastic_fraction"].append(an.elastic_fraction)
        self.extent["radii"].append(an.radii)
        self.extent["thin_axis"].append(an.thin_axis)
        self.index.append(idx)
        self.vectors.append(vec)

    def table(self, energy_jump: np.ndarray, stress_jump: np.ndarray, dim: int) -> dict:
        """The group ``avalanches``: the columns, ``ΔE``/``ΔΣ`` taken from the trace's
        ``energy_jump``/``stress_jump`` at each row ``step``, and the CSR displacement field."""
        steps = np.asarray(self.rows["step"], dtype=np.int64)
        out: dict = {"step": steps}
        for k in AVALANCHE_COLUMNS[1:]:
            dtype = (
                bool
                if k in ("only_bucklers_rattlers", "localized")
                else (np.int64 if k.startswith("n_") and k != "n_eff" else np.float64)
            )
            out[k] = np.asarray(self.rows[k], dtype=dtype)
        for k in EXTENT_COLUMNS:
            # rows resumed from a trace written before these columns existed: NaN
            rows = [v if v.size == dim else np.full(dim, np.nan) for v in self.extent[k]]
            out[k] = np.asarray(rows, dtype=np.float64).reshape(-1, dim)
        out["energy_jump"] = np.asarray(energy_jump, dtype=np.float64)[steps]
        out["stress_jump"] = np.asarray(stress_jump, dtype=np.float64)[steps]
        sizes = np.array([i.size for i in self.index], dtype=np.int64)
        out["moved_offsets"] = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        out["moved_index"] = (
            np.concatenate(self.index).astype(np.int64) if self.index else np.zeros(0, np.int64)
        )
        out["moved_displacement"] = (
            np.concatenate(self.vectors).reshape(-1, dim) if self.vectors else np.zeros((0, dim))
        )
        out["attrs"] = {"threshold": self.threshold, "n_eff_max": self.n_eff_max}
        return out
