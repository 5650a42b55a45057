"""The rows of the AQS trace: what is measured at a minimum, and the :class:`Trace` built from
them."""

from __future__ import annotations

import json

import numpy as np

from jamlab.spheres.aqs.network import backbone_mask, contact_list
from jamlab.spheres.potential import NeighborList, Packing, evaluate
from jamlab.spheres.rigidity import jammed_verdict, pressure_floor
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
        # what the jammed verdict needs, from this same contact pass (resolved in make_trace,
        # where the run's ftol is known)
        "rigidity": (packing.dim, n, packing.box.length, n_kept, n_c_kept, ev.pressure),
    }
    return row, keep


# the columns measured at a minimum (the jumps are differences between rows); ``jammed`` holds,
# while the run goes, the rigidity tuple of :func:`observe` (a bool for resumed rows)
ROW_KEYS = tuple(c for c in TRACE_COLUMNS if c not in ("energy_jump", "stress_jump")) + ("jammed",)


def resumed_rows(previous: Trace, last: dict) -> dict[str, list]:
    """The rows of a trace being continued (columns :data:`ROW_KEYS`); ``last``: the
    :func:`observe` row of the configuration it continues from (its rigidity counts serve the
    next lean step). A trace without the ``jammed`` column (format version 1) gives ``None``
    flags, and the continued trace then has no ``jammed`` column (unknown for its first rows)."""
    rows = {k: list(getattr(previous, k)) for k in ROW_KEYS if k != "jammed"}
    flags = previous.jammed
    rows["jammed"] = [None] * len(rows["gamma"]) if flags is None else [bool(f) for f in flags]
    rows["jammed"][-1] = last["rigidity"] if flags is not None else None
    return rows


def jammed_flag(value: tuple | bool | None, ftol: float) -> bool | None:
    """One row's ``jammed`` entry resolved: :func:`~jamlab.spheres.rigidity.jammed_verdict` of
    its rigidity tuple (:func:`observe`: backbone counts and pressure) against
    ``p_floor(ftol)``, a recorded flag as it is, ``None`` if unknown."""
    if value is None or isinstance(value, bool | np.bool_):
        return None if value is None else bool(value)
    dim, n, length, n_kept, n_c_kept, p = value
    return not jammed_verdict(dim, n_kept, n_c_kept, p, pressure_floor(n, dim, length, ftol))


def jammed_flags(rows: dict[str, list], ftol: float) -> np.ndarray | None:
    """The ``jammed`` column: :func:`jammed_flag` of each row, and ``False`` for a row that is
    not a minimum (``max_force ≥ ftol``: as :func:`~jamlab.spheres.rigidity.is_jammed`);
    ``None`` if a row is unknown."""
    out = []
    for value, fmax in zip(rows.get("jammed", []), rows["max_force"], strict=True):
        flag = jammed_flag(value, ftol)
        if flag is None:
            return None
        out.append(flag and fmax < ftol)
    return np.asarray(out, dtype=bool)


def append_row(
    rows: dict[str, list], gamma: float, row: dict, iterations: int, plastic: bool
) -> None:
    """Append the row of the minimum at strain ``gamma`` (columns :data:`ROW_KEYS`)."""
    rows["gamma"].append(float(gamma))
    for k in ("energy", "shear_stress", "pressure", "z", "z_nr", "max_force"):
        rows[k].append(row[k])
    rows["iterations"].append(int(iterations))
    rows["plastic"].append(bool(plastic))
    flags = rows.setdefault("jammed", [])
    rigidity = row.get("rigidity")
    if rigidity is None and flags and isinstance(flags[-1], tuple):
        # the lean step keeps the previous minimum's backbone (lean.py): its size is known,
        # its contacts follow from z_nr = 2 N_c'/N'
        dim, n, length, n_kept, _, _ = flags[-1]
        n_c_kept = int(round(0.5 * row["z_nr"] * n_kept))
        rigidity = (dim, n, length, n_kept, n_c_kept, row["pressure"])
    flags.append(rigidity)


def make_trace(rows: dict[str, list], attrs: dict, counters: dict) -> Trace:
    """The :class:`~jamlab.spheres.trace.Trace` of the rows, with the run's attributes and
    counters; ``jammed`` judged at ``attrs["ftol"]``, ``phi`` the constant ``attrs["phi"]``
    (constant volume)."""
    full = dict(rows)
    full["jammed"] = jammed_flags(rows, float(attrs["ftol"]))
    full["phi"] = np.full(len(rows["gamma"]), float(attrs["phi"]))
    trace = Trace.from_rows(full, attrs=dict(attrs))
    trace.attrs.update(counters)
    trace.attrs["n_plastic"] = int(np.count_nonzero(trace.plastic))
    trace.attrs["protocol"] = "constant-volume"
    if trace.jammed is not None:
        trace.attrs["n_unjammed"] = int(np.count_nonzero(~trace.jammed))
    return trace


def invocations(previous: Trace | None) -> str:
    """The trace's ``provenance`` attribute (JSON): where each invocation ran
    (:func:`jamlab.provenance.continued`), the records of the resumed trace ``previous`` and
    this invocation's, which resumes from its last step."""
    from jamlab.provenance import continued

    if previous is None:
        return json.dumps(continued(None, -1))
    return json.dumps(continued(previous.attrs.get("provenance"), int(previous.n_steps)))


def jamlab_version() -> str:
    """The version recorded in the trace's attributes."""
    from jamlab import __version__

    return str(__version__)
