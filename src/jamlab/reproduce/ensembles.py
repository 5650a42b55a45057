"""Reading the stored ensembles of a reproduction: finished samples, avalanche sizes, stress.

The run directories are those of :func:`jamlab.runs.run_study` (``jamming``, ``unsat``,
``stress-strain``), opened as ``xarray`` datasets by :func:`jamlab.runs.open_run`; only the
samples whose status is ``"done"`` count.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["RunSet", "avalanche_sizes_of", "finished", "intensive_stress"]


def finished(ds: Any, label: str, n: int) -> np.ndarray:
    """Boolean mask over samples: finished (status ``"done"``) at ``(φ label, N)``."""
    return np.asarray(ds.status.sel(phi=label, N=n).values == "done")


def avalanche_sizes_of(ds: Any, label: str, n: int) -> tuple[np.ndarray, int, int]:
    """``(sizes, number of AQS steps, number of samples)`` of the finished samples at
    ``(φ label, N)``: plastic steps with ``ΔE < 0``, ``S = −ΔE`` (row 0 has no step)."""
    from jamlab.analysis import avalanche_sizes

    done = finished(ds, label, n)
    ej = np.asarray(ds.energy_jump.sel(phi=label, N=n).values)[done, 1:]
    pl = np.asarray(ds.plastic.sel(phi=label, N=n).values)[done, 1:] > 0.5
    sizes = avalanche_sizes(ej.ravel(), pl.ravel()) if ej.size else np.empty(0)
    return sizes, int(ej.size), int(done.sum())


def intensive_stress(ds: Any, label: str, n: int) -> np.ndarray:
    """``Σ/L³`` (``L^d`` in general) of the finished samples, ``(samples, steps+1)``."""
    done = finished(ds, label, n)
    stress = np.asarray(ds.shear_stress.sel(phi=label, N=n).values)[done]
    length = np.asarray(ds.box_length.sel(phi=label, N=n).values)[done]
    dim = json.loads(ds.attrs["study"])["dim"]
    return stress / (length[:, None] ** dim)


class RunSet:
    """The run directories under ``runs``, each opened (once, on first use) by name."""

    def __init__(self, runs: Path) -> None:
        self.path = Path(runs)
        self._opened: dict[str, Any] = {}

    def __getitem__(self, name: str) -> Any:
        """The run directory ``name`` opened with :func:`jamlab.runs.open_run`."""
        if name not in self._opened:
            from jamlab.runs import open_run

            self._opened[name] = open_run(self.path / name)
        return self._opened[name]
