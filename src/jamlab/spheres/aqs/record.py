"""The rows of the AQS trace: what is measured at a minimum, and the :class:`Trace` built from
them."""

from __future__ import annotations

import numpy as np

from jamlab.spheres.aqs.network import backbone_mask, contact_list
from jamlab.spheres.potential import NeighborList, Packing, evaluate
from jamlab.spheres.trace import TRACE_COLUMNS, Trace


def observe(packing: Packing, nl: NeighborList) -> tuple[dict[str, float], np.ndarray]:
    """Row of the trace at a minimum, and the backbone mask (rattlers removed as in
    :func:`~jamlab.spheres.potential.remove_rattlers`, from one contact list)."""
    ev = evaluate(packing, nl)
    ci, cj, _ = contact_list(packing, nl)
    n = packing.n
    keep = backbone_mask(ci, cj, n, packing.dim)
    n_kept = int(keep.sum())
    n_c_kept = int((keep[ci] & keep[cj]).sum())
    row = {
        "energy": ev.energy,
        "shear_stress": ev.shear_stress,
        "pressure": ev.pressure,
        "z": 2.0 * ci.size / n,
        "z_nr": 2.0 * n_c_kept / n_kept if n_kept else 0.0,
        "max_force": ev.max_force,
    }
    return row, keep


# the columns measured at a minimum (the jumps are differences between rows)
ROW_KEYS = tuple(c for c in TRACE_COLUMNS if c not in ("energy_jump", "stress_jump"))


def append_row(
    rows: dict[str, list], gamma: float, row: dict, iterations: int, plastic: bool
) -> None:
    """Append the row of the minimum at strain ``gamma`` (columns :data:`ROW_KEYS`)."""
    rows["gamma"].append(float(gamma))
    for k in ("energy", "shear_stress", "pressure", "z", "z_nr", "max_force"):
        rows[k].append(row[k])
    rows["iterations"].append(int(iterations))
    rows["plastic"].append(bool(plastic))


def make_trace(rows: dict[str, list], attrs: dict, counters: dict) -> Trace:
    """The :class:`~jamlab.spheres.trace.Trace` of the rows, with the run's attributes and
    counters."""
    trace = Trace.from_rows(rows, attrs=dict(attrs))
    trace.attrs.update(counters)
    trace.attrs["n_plastic"] = int(np.count_nonzero(trace.plastic))
    return trace


def jamlab_version() -> str:
    """The version recorded in the trace's attributes."""
    from jamlab import __version__

    return str(__version__)
