"""The ``aqs`` task: one sample = prepare a packing + AQS shear (kept apart so that the run
machinery imports no physics until a worker needs it)."""

from __future__ import annotations

import numpy as np

from jamlab.runs.study import SampleKey, Study
from jamlab.runs.tasks import TRACE_FIELDS, SampleFailed, SampleResult


def prepare_and_shear(study: Study, key: SampleKey, seed: int) -> SampleResult:
    """``jam``/``prepare`` with ``seed``, then ``shear``; :class:`SampleFailed` if a minimisation
    did not converge."""
    try:
        from jamlab.spheres import aqs, packing
    except ImportError as exc:  # pragma: no cover - until the sphere modules are installed
        raise SampleFailed(f"the aqs task needs jamlab.spheres.packing and .aqs: {exc}") from None

    if isinstance(key.phi, str):
        prepared = packing.jam(key.n, study.dim, seed, p_target=study.p_target)
    else:
        prepared = packing.prepare(key.n, study.dim, float(key.phi), seed)
    trace = aqs.shear(prepared, study.dgamma, study.gamma_max)
    traces = {name: np.asarray(getattr(trace, name)) for name in TRACE_FIELDS}
    converged = getattr(trace, "converged", None)
    if converged is not None and not bool(np.all(converged)):
        raise SampleFailed("AQS minimisation did not converge")
    attrs = {"phi_actual": float(prepared.phi), "box_length": float(prepared.box.length)}
    return SampleResult(traces, attrs, {"positions": np.asarray(prepared.positions)})
