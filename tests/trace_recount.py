"""An independent recount of a run directory's avalanches for the tests, read with h5py from the
sample files (not through ``jamlab.reproduce``): the report's rule, plastic steps with
``ΔH < 0`` between two jammed minima, ``S = −ΔH``."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np


def finished_samples(run: Path) -> list[Path]:
    """The sample files of the run directory ``run`` (finished samples only are written)."""
    return sorted(Path(run).glob("samples/*/*/*.h5"))


def recount_sample(path: Path) -> np.ndarray:
    """The avalanche sizes of one sample file."""
    with h5py.File(path, "r") as h5:
        de = h5["trace/energy_jump"][1:]
        pl = h5["trace/plastic"][1:].astype(bool)
        jm = h5["trace/jammed"][()]
    return -de[pl & (de < 0) & jm[:-1] & jm[1:]]


def recount_steps(path: Path, first: int, last: int) -> np.ndarray:
    """The avalanche sizes of one sample file at AQS steps ``first`` … ``last`` (1-based, both
    included: step ``k`` goes from trace row ``k − 1`` to row ``k``)."""
    with h5py.File(path, "r") as h5:
        de = h5["trace/energy_jump"][()]
        pl = h5["trace/plastic"][()].astype(bool)
        jm = h5["trace/jammed"][()]
    k = np.arange(first, last + 1)
    keep = pl[k] & (de[k] < 0) & jm[k - 1] & jm[k]
    return -de[k][keep]


def recount(run: Path) -> np.ndarray:
    """The avalanche sizes of every sample file of ``run``, concatenated."""
    return np.concatenate([np.empty(0)] + [recount_sample(f) for f in finished_samples(run)])


def step_count(run: Path) -> int:
    """The AQS steps of every sample file of ``run`` (trace rows minus the starting one)."""
    total = 0
    for f in finished_samples(run):
        with h5py.File(f, "r") as h5:
            total += h5["trace/energy_jump"].size - 1
    return total
