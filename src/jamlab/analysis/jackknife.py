"""The delete-one jackknife variance of an estimator (one formula, used by every fit that
reports a jackknife error).

From the estimates ``θ_(i)`` with unit ``i`` left out, ``i = 1 … m``:
``v = (m − 1)/m · Σ_i (θ_(i) − θ̄)²``, ``θ̄`` their mean (Efron & Tibshirani, *An Introduction
to the Bootstrap*, ch. 11). For the sample mean it is exactly ``s²/m`` (``s²`` with ``m − 1``
in the denominator). A stratified jackknife sums this over strata.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def jackknife_variance(leave_one_out: ArrayLike) -> NDArray[np.float64] | float:
    """The jackknife variance from the leave-one-out estimates along axis 0 (one row per unit
    left out; further axes are separate parameters). Needs at least two rows."""
    v = np.asarray(leave_one_out, dtype=np.float64)
    if v.ndim == 0 or v.shape[0] < 2:
        raise ValueError("the jackknife needs at least two leave-one-out estimates")
    m = v.shape[0]
    var = (m - 1) / m * np.sum((v - v.mean(axis=0)) ** 2, axis=0)
    return float(var) if v.ndim == 1 else var
