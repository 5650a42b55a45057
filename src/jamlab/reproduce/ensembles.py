"""Reading the stored ensembles of a reproduction: finished samples, avalanche sizes, stress.

The run directories are those of :func:`jamlab.runs.run_study` (``jamming``, ``unsat``,
``stress-strain``), opened as ``xarray`` datasets by :func:`jamlab.runs.open_run`; only the
samples whose status is ``"done"`` count.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "AvalancheSet",
    "CoarseAvalanches",
    "RunSet",
    "avalanche_set",
    "avalanche_sizes_of",
    "coarse_avalanches",
    "counted_steps",
    "finished",
    "intensive_stress",
    "jammed_flags",
    "plastic_flags",
    "sample_strains",
]


def finished(ds: Any, label: str, n: int) -> np.ndarray:
    """Boolean mask over samples: finished (status ``"done"``) at ``(φ label, N)``."""
    return np.asarray(ds.status.sel(phi=label, N=n).values == "done")


@dataclass(frozen=True)
class AvalancheSet:
    """The avalanches of the finished samples at one ``(φ label, N)``.

    ``sizes``: ``S = −ΔE`` of the counted avalanches; ``pressures``: the pressure of the minimum
    each starts from (row ``n − 1`` of the step ``n − 1 → n``); ``steps``: all AQS steps;
    ``samples``; ``jammed_known``: every finished sample has the ``jammed`` column (runs made
    before trace format 2 have not: then nothing is excluded); ``n_steps_excluded``,
    ``n_avalanches_excluded``: steps and would-be avalanches that start or end unjammed
    (:func:`jamlab.analysis.exclusions`); ``minimum_pressures``: the pressure of every minimum
    of the finished samples (what the ensemble actually sampled); ``per_sample``: the sizes of
    each finished sample (``sizes`` is their concatenation)."""

    sizes: np.ndarray
    pressures: np.ndarray
    steps: int
    samples: int
    jammed_known: bool
    n_steps_excluded: int
    n_avalanches_excluded: int
    minimum_pressures: np.ndarray
    per_sample: tuple[np.ndarray, ...] = ()


def counted_steps(ds: Any, label: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(ΔE, counted)`` of the finished samples at ``(φ label, N)``, each ``(samples, steps)``
    (row 0 of the trace has no step): ``counted`` marks the steps that are avalanches by the
    report's rule, plastic steps with ``ΔE < 0`` between two jammed minima
    (:func:`jamlab.analysis.classify_steps` with ``jammed=``)."""
    from jamlab.analysis import classify_steps

    ej, pl, jammed = _step_arrays(ds, label, n, finished(ds, label, n))
    return ej, classify_steps(ej, pl, jammed=jammed)


def _step_arrays(ds: Any, label: str, n: int, done: np.ndarray) -> tuple[np.ndarray, ...]:
    """``ΔE``, the plastic flags (each ``(samples, steps)``) and :func:`jammed_flags` of the
    samples ``done``."""
    ej = np.asarray(ds.energy_jump.sel(phi=label, N=n).values)[done, 1:]
    return ej, plastic_flags(ds, label, n)[:, 1:], jammed_flags(ds, label, n)


def avalanche_set(ds: Any, label: str, n: int) -> AvalancheSet:
    """:class:`AvalancheSet` of the finished samples at ``(φ label, N)``: plastic steps with
    ``ΔE < 0`` between two jammed minima (:func:`counted_steps`), ``S = −ΔE``."""
    from jamlab.analysis import classify_steps, exclusions

    done = finished(ds, label, n)
    ej, pl, jammed = _step_arrays(ds, label, n, done)
    counted = classify_steps(ej, pl, jammed=jammed)
    if not ej.size:
        return AvalancheSet(np.empty(0), np.empty(0), 0, int(done.sum()), True, 0, 0, np.empty(0))
    sizes = -ej[counted]
    pr = np.asarray(ds.pressure.sel(phi=label, N=n).values)[done]
    pressures = pr[:, :-1][counted]
    if jammed is None:
        n_st, n_av = 0, 0
    else:
        ex = exclusions(ej, jammed, pl)
        n_st, n_av = ex.n_steps_excluded, ex.n_avalanches_excluded
    return AvalancheSet(
        sizes,
        pressures,
        int(ej.size),
        int(done.sum()),
        jammed is not None,
        n_st,
        n_av,
        pr[np.isfinite(pr)],
        tuple(-row[m] for row, m in zip(ej, counted, strict=True)),
    )


def avalanche_sizes_of(ds: Any, label: str, n: int) -> tuple[np.ndarray, int, int]:
    """``(sizes, number of AQS steps, number of samples)`` of :func:`avalanche_set`."""
    a = avalanche_set(ds, label, n)
    return a.sizes, a.steps, a.samples


@dataclass(frozen=True)
class CoarseAvalanches:
    """The avalanches of the finished samples at one ``(φ label, N)`` seen at ``k δγ``
    (:func:`coarse_avalanches`). ``sizes``: ``S = −ΔE`` of the blocks of ``k`` steps with a
    plastic step, ``ΔE < 0`` and every minimum jammed (the rule of :func:`avalanche_set`, which
    ``k = 1`` reproduces); ``lost``: such blocks with ``ΔE ≥ 0`` (a jump smaller than the
    branch's curvature energy over the block); ``curvature``: ``½ δγ ΔΣ`` of the elastic blocks, the
    branch's curvature energy over one block; ``strain``: the strain of all blocks of all samples
    (summed over the samples); ``samples``; ``per_sample``: ``sizes`` split by sample (packings as
    units, as :attr:`AvalancheSet.per_sample`)."""

    k: int
    sizes: np.ndarray
    lost: int
    curvature: np.ndarray
    strain: float
    samples: int
    per_sample: tuple[np.ndarray, ...] = ()


def coarse_avalanches(ds: Any, label: str, n: int, k: int) -> CoarseAvalanches:
    """:class:`CoarseAvalanches` of ``(label, n)``: the steps of each finished sample grouped
    ``k`` at a time by :func:`jamlab.analysis.coarsen_steps` (what a run at ``k δγ`` through the
    same minima would record; trailing steps that do not fill a block are left out)."""
    from jamlab.analysis import classify_steps, coarsen_steps

    done = finished(ds, label, n)
    if not done.any():
        return CoarseAvalanches(int(k), np.empty(0), 0, np.empty(0), 0.0, 0)
    ej = np.asarray(ds.energy_jump.sel(phi=label, N=n).values)[done, 1:]
    sj = np.asarray(ds.stress_jump.sel(phi=label, N=n).values)[done, 1:]
    dg = np.diff(np.asarray(ds.gamma.sel(phi=label, N=n).values)[done], axis=1)
    c = coarsen_steps(ej, sj, dg, k, plastic=plastic_flags(ds, label, n)[:, 1:],
                      jammed=jammed_flags(ds, label, n))
    jammed = np.ones_like(c.plastic) if c.jammed is None else c.jammed
    events = c.plastic & jammed
    counted = classify_steps(c.energy_jump, events)  # the report's rule: also ΔE < 0
    elastic = ~c.plastic & jammed
    return CoarseAvalanches(
        int(k), -c.energy_jump[counted], int(np.count_nonzero(events & (c.energy_jump >= 0))),
        0.5 * c.strain_step[elastic] * c.stress_jump[elastic], float(c.strain_step.sum()),
        int(done.sum()),
        tuple(-row[m] for row, m in zip(c.energy_jump, counted, strict=True)))


def jammed_flags(ds: Any, label: str, n: int) -> np.ndarray | None:
    """The ``jammed`` flag of every minimum of the finished samples, ``(samples, steps+1)``;
    ``None`` for runs made before trace format 2 (no flags)."""
    if "jammed" not in ds:
        return None
    flags = np.asarray(ds.jammed.sel(phi=label, N=n).values)[finished(ds, label, n)]
    if flags.size and np.all(np.isfinite(flags)):
        return flags > 0.5
    return None


def plastic_flags(ds: Any, label: str, n: int) -> np.ndarray:
    """The ``plastic`` flag of every row of the finished samples, ``(samples, steps+1)`` (row
    ``k`` flags the step ``k − 1 → k``; row 0 is False)."""
    return np.asarray(ds.plastic.sel(phi=label, N=n).values)[finished(ds, label, n)] > 0.5


def sample_strains(ds: Any, label: str, n: int) -> np.ndarray:
    """The strain sheared by each finished sample at ``(φ label, N)``: its largest ``γ`` less its
    first (rows past a sample's end are NaN)."""
    gam = np.asarray(ds.gamma.sel(phi=label, N=n).values)[finished(ds, label, n)]
    return np.nanmax(gam, axis=1) - gam[:, 0] if gam.size else np.empty(0)


def last_rows(values: np.ndarray) -> np.ndarray:
    """The index of each sample's last row, the last finite entry of each row of a ``(samples,
    steps)`` array (rows past a sample's end are NaN; every row needs one finite entry)."""
    return np.array([np.flatnonzero(np.isfinite(row))[-1] for row in values], dtype=np.int64)


def intensive_stress(ds: Any, label: str, n: int) -> np.ndarray:
    """``Σ/V`` of the finished samples, ``(samples, steps+1)``: each row's shear stress over its
    box volume. At constant volume ``V = L^d``, the box a sample file keeps; at fixed pressure
    (a study with ``pressure`` set) the volume of each row, :func:`row_volumes`: the prepared box
    is the packing's before it is brought to the pressure, ``|V/L^d − 1|`` up to 2.0 % at
    p = 1e-2 and 0.07–0.1 % at p = 1e-4 … 1e-6 in ``data/runs``. A fixed-pressure run made
    before trace format 2 keeps no row volumes: ``ValueError`` rather than the prepared box."""
    done = finished(ds, label, n)
    stress = np.asarray(ds.shear_stress.sel(phi=label, N=n).values)[done]
    study = json.loads(ds.attrs["study"])
    if study.get("pressure") is not None:
        volume = row_volumes(ds, label, n)
        if volume is None:
            raise ValueError(
                "a fixed-pressure run without per-row φ (phi_step, trace format 2) keeps no row "
                "volumes to divide its stress by")
        return stress / volume
    length = np.asarray(ds.box_length.sel(phi=label, N=n).values)[done]
    return stress / (length[:, None] ** study["dim"])


def row_volumes(ds: Any, label: str, n: int) -> np.ndarray | None:
    """The box volume ``V`` of every row of the finished samples at ``(φ label, N)``,
    ``(samples, steps+1)``: the particles' volume ``v = L^d φ`` (the box side and packing
    fraction a sample file keeps, those of the start of its shear) over each row's φ
    (``phi_step``; at constant volume that is ``L^d`` at every row). ``None`` for a run made
    before trace format 2 (no ``phi_step``)."""
    if "phi_step" not in ds:
        return None
    done = finished(ds, label, n)
    sel = {"phi": label, "N": n}
    dim = int(json.loads(ds.attrs["study"])["dim"])
    length = np.asarray(ds.box_length.sel(**sel).values)[done]
    phi_start = np.asarray(ds.phi_actual.sel(**sel).values)[done]
    phi = np.asarray(ds.phi_step.sel(**sel).values)[done]
    return (length**dim * phi_start)[:, None] / phi


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
