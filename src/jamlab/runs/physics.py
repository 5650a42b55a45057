"""The ``aqs`` task: one sample = prepare a packing + AQS shear. The physics modules are imported
inside :func:`prepare_and_shear`, so that the run machinery imports none until a worker needs it."""

from __future__ import annotations

from typing import Any

import numpy as np

from jamlab.runs.results import TRACE_FIELDS, SampleFailed, SampleResult
from jamlab.runs.study import SampleKey, Study


def scalars(prefix: str, obj: Any) -> dict[str, Any]:
    """Numeric/bool/str attributes of a result object (dataclass fields or a dict), prefixed."""
    items = obj.items() if isinstance(obj, dict) else getattr(obj, "__dict__", {}).items()
    out = {}
    for name, value in items:
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, bool | int | float | str) and not name.startswith("_"):
            out[f"{prefix}{name}"] = value
    return out


def prepare_and_shear(study: Study, key: SampleKey, seed: int) -> SampleResult:
    """``jam``/``prepare`` with ``seed``, then ``shear``; :class:`SampleFailed` if a minimisation
    did not converge."""
    from jamlab.spheres import aqs, packing

    if isinstance(key.phi, str):
        prepared = packing.jam(
            key.n,
            study.dim,
            seed,
            p_target=study.p_target,
            ftol=study.force_tol,
            sizes=study.sizes,
            alpha=study.alpha,
        )
    else:
        prepared = packing.prepare(
            key.n,
            study.dim,
            float(key.phi),
            seed,
            ftol=study.force_tol,
            sizes=study.sizes,
            alpha=study.alpha,
        )
    config = prepared.packing
    info = prepared.attrs() if hasattr(prepared, "attrs") else scalars("", prepared)
    # wall-clock times are not reproducible: kept out of the sample's data
    attrs: dict[str, Any] = {
        f"prep_{k}": (v.item() if isinstance(v, np.generic) else v)
        for k, v in info.items()
        if not k.startswith("time")
    }
    if not prepared.converged:
        raise SampleFailed(f"preparation did not converge: {prepared.reason or 'FIRE'}")
    if not prepared.ok:
        raise SampleFailed(f"preparation failed its stopping rule: {prepared.reason}")
    params = None if study.pressure is not None else aqs.AQSParameters(floppy=study.floppy)
    result = aqs.shear(
        config, study.dgamma, study.gamma_max, ftol=study.force_tol, pressure=study.pressure,
        params=params,
    )
    trace = getattr(result, "trace", result)
    traces = {name: np.asarray(getattr(trace, name)) for name in TRACE_FIELDS}
    for name, column in trace.optional_columns().items():  # jammed, phi
        traces[name] = np.asarray(column)
    attrs.update(scalars("shear_", result) if trace is not result else {})
    attrs.pop("shear_time", None)  # wall time: not reproducible, kept out of the sample's data
    if study.floppy != "fire":  # the protocol of the floppy steps, and what it did (FIRE samples
        # keep their earlier attributes, bit for bit)
        attrs["shear_floppy"] = study.floppy
        for name in ("n_projected", "n_projection_failed"):
            attrs[f"shear_{name}"] = int(trace.attrs.get(name, 0))
    n_bad = int(attrs.get("shear_n_not_converged", 0))
    if n_bad:
        raise SampleFailed(f"AQS minimisation did not converge at {n_bad} step(s) (max |F_i|)")
    attrs["phi_actual"] = float(config.phi)
    attrs["box_length"] = float(config.box.length)
    arrays = {"positions": np.asarray(config.positions)}
    if not config.monodisperse:  # (mono samples keep their earlier layout, bit for bit)
        arrays["diameters"] = np.asarray(config.diameters)
    return SampleResult(traces, attrs, arrays)
