"""The scales of a reproduction: ensemble sizes, sample counts, fit settings and expected cost.

A :class:`Scale` fixes everything that sets the size of ``jamlab reproduce`` (all seeds derive
from ``Scale.seed``); :data:`SCALES` holds the named ones (``tiny`` for tests, ``quick`` for a
laptop, ``medium`` for a night, ``paper`` for a cluster) and :func:`studies` turns a scale into
the :class:`jamlab.runs.Study` it runs (three at constant volume, one per fixed pressure).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from jamlab import validation

__all__ = [
    "SCALES",
    "UNSAT_PHI",
    "Scale",
    "get_scale",
    "pressure_run_name",
    "studies",
    "with_seed",
]

UNSAT_PHI = (0.75, 0.8)
"""The packing fractions above jamming (the paper's UNSAT ensembles)."""


@dataclass(frozen=True)
class Scale:
    """Everything that sets the size of a reproduction (all seeds derive from ``seed``)."""

    name: str
    jamming_n: tuple[int, ...]
    jamming_samples: int
    unsat_n: tuple[int, ...]
    unsat_samples: int
    dgamma: float
    gamma_max: float
    jamming_gamma_max: float
    stress_phi: float
    stress_n: int
    stress_samples: int
    stress_dgamma: float
    stress_gamma_max: float
    coord_n: int
    coord_samples: int
    coord_steps: int
    moduli_lags: tuple[int, ...]
    moduli_fit_max_lag: int
    min_tail: int
    n_boot: int
    cascade_k: int
    cascade_samples: int
    cascade_dgammas: tuple[float, ...]
    cascade_check_dgamma: float
    seed: int = 0
    bins_per_decade: int = 5
    expected: str = ""
    sizes: str = "mono"  # the pair law of every ensemble (SPEC.md §5; the paper: mono, α = 2)
    alpha: float = 2.0
    # fixed-pressure ensembles (issue 18): τ(p) at each p, the jamming packings brought to p
    pressures: tuple[float, ...] = ()
    pressure_n: tuple[int, ...] = ()
    pressure_samples: int = 0
    pressure_gamma_max: float = 0.0
    # their strain step (0: dgamma). A scale whose constant-volume ensembles take coarse steps
    # (quick: 1e-4) shears at fixed p with the paper's 1e-5, below the linear-response strain
    # at p = 1e-5 (docs/aqs.md, "Linear-response strain against p")
    pressure_dgamma: float = 0.0
    # the largest lag of the fixed-pressure moduli slopes (jamlab.reproduce.pressure_moduli):
    # δγ ≤ 10 δγ_0, where the lag-1 correlation, not the bounded stress, decides the slope
    pressure_moduli_fit_max_lag: int = 10
    # how the constant-volume jamming study takes a step from an unjammed minimum
    # (jamlab.runs.Study.floppy: "fire", the paper's minimiser, or "project", docs/aqs.md)
    floppy: str = "fire"
    # every study's samples saved every this many steps (jamlab.runs.Study.checkpoint_every; 0:
    # off): the paper's samples at N = 2000-4000 take hours, longer than a SLURM allocation
    checkpoint_every: int = 0

    def __post_init__(self) -> None:
        validation.floppy(self.floppy)
        validation.integer("checkpoint_every", self.checkpoint_every, minimum=0)
        steps = round(min(self.gamma_max, self.jamming_gamma_max) / self.dgamma)
        if not (self.moduli_lags and max(self.moduli_lags) < steps):
            raise ValueError(f"moduli_lags {self.moduli_lags} must lie below the number of steps")
        if self.cascade_check_dgamma not in self.cascade_dgammas:
            raise ValueError("cascade_check_dgamma must be one of cascade_dgammas")
        if not (self.pressure_dgamma >= 0 and math.isfinite(self.pressure_dgamma)):
            raise ValueError(f"pressure_dgamma must be finite and >= 0 (0: dgamma), got "
                             f"{self.pressure_dgamma!r}")
        if self.pressures and not (self.pressure_n and self.pressure_samples > 0
                                   and self.pressure_gamma_max > self.pressure_step):
            raise ValueError("fixed-pressure ensembles need pressure_n, pressure_samples and "
                             "pressure_gamma_max > their strain step")

    @property
    def pressure_step(self) -> float:
        """The fixed-pressure ensembles' strain step: ``pressure_dgamma``, else ``dgamma``."""
        return self.pressure_dgamma if self.pressure_dgamma > 0 else self.dgamma


QUICK_PRESSURE = 1e-5
QUICK_P_SAMPLES = 40
"""The ``quick`` scale's fixed-pressure ensemble: 40 packings of N = 125 sheared at p = 1e-5 in
the paper's steps (1000 of 1e-5), a decade nearer jamming than the pressures its
constant-volume avalanches are fitted at, and held there (docs/reproduce.md, "The quick
report")."""

MEDIUM_CV_SAMPLES = 3
MEDIUM_P_SAMPLES = 20
MEDIUM_EXPECTED = (
    "≈ 5.8 CPU-hours ≈ 2.9 h on 2 cores, projected (a session cannot host it) from samples "
    "measured with the current code: constant volume 0.37 CPU-h, the scale's study run whole "
    "(CPU s per sample with its preparation: N = 500 14, 81, 92; N = 1000 229, 227, 698 — the "
    "costly ones hover at the edge of jamming); fixed pressure ≈ 5.0 CPU-h from the scale's "
    "first 2 samples at every (N, p) (N = 500: 115, 38, 20, 11 s per 1000-step sample at p = "
    "1e-5, 1e-4, 1e-3, 1e-2; N = 1000: 509, 125, 49, 34 s); the τ those samples gave: "
    "docs/reproduce.md, \"Times\""
)

"""The ``medium`` scale (issue 18): τ(p) at fixed p = 1e-2, 1e-3, 1e-4, 1e-5 and the paper's
constant-volume protocol, both at N = 500 and 1000, δγ = 1e-5, sized for ≤ 10 h on 2 cores."""

SCALES: dict[str, Scale] = {
    "tiny": Scale(
        name="tiny",
        jamming_n=(32,),
        jamming_samples=3,
        unsat_n=(32,),
        unsat_samples=3,
        dgamma=1e-3,
        gamma_max=0.02,
        jamming_gamma_max=0.02,
        stress_phi=0.75,
        stress_n=32,
        stress_samples=3,
        stress_dgamma=1e-2,
        stress_gamma_max=0.15,
        coord_n=32,
        coord_samples=1,
        coord_steps=8,
        moduli_lags=(1, 2, 4, 8),
        moduli_fit_max_lag=8,
        min_tail=5,
        n_boot=20,
        cascade_k=4,
        cascade_samples=2000,
        cascade_dgammas=(0.1, 0.3),
        cascade_check_dgamma=0.3,
        expected="about 1 minute on one core (tests)",
    ),
    "quick": Scale(
        name="quick",
        jamming_n=(64, 128),
        jamming_samples=30,
        unsat_n=(128, 256),
        unsat_samples=120,
        dgamma=1e-4,
        gamma_max=0.02,
        jamming_gamma_max=0.01,
        stress_phi=0.75,
        stress_n=128,
        stress_samples=32,
        stress_dgamma=1e-4,
        stress_gamma_max=0.15,
        coord_n=256,
        coord_samples=3,
        coord_steps=30,
        moduli_lags=(1, 2, 3, 5, 10, 20, 30, 50),
        moduli_fit_max_lag=10,
        min_tail=50,
        n_boot=200,
        cascade_k=16,
        cascade_samples=40_000,
        cascade_dgammas=(0.05, 0.1, 0.3, 0.5),
        cascade_check_dgamma=0.3,
        pressures=(QUICK_PRESSURE,),
        pressure_n=(125,),
        pressure_samples=QUICK_P_SAMPLES,
        pressure_gamma_max=0.01,
        pressure_dgamma=1e-5,
        expected=("≈ 6–10 minutes on 2 idle cores (measured: 8.8 min on an AMD EPYC Zen 4 of "
                  "2026-12-08, of which 4.3 the fixed-pressure ensemble; without it 3.5 min on "
                  "an Intel Xeon of 2026-12-07, 3.1 on an AMD EPYC Zen 5, ≈ 9 on slower "
                  "machines; budget 30 minutes)"),
    ),
    "medium": Scale(
        name="medium",
        jamming_n=(500, 1000),
        jamming_samples=MEDIUM_CV_SAMPLES,
        unsat_n=(128, 256),
        unsat_samples=60,
        dgamma=1e-5,
        gamma_max=0.01,
        jamming_gamma_max=0.01,
        stress_phi=0.75,
        stress_n=128,
        stress_samples=32,
        stress_dgamma=1e-4,
        stress_gamma_max=0.15,
        coord_n=256,
        coord_samples=3,
        coord_steps=30,
        moduli_lags=(1, 2, 5, 10, 20, 50, 100, 200, 500),
        moduli_fit_max_lag=100,
        min_tail=50,
        n_boot=200,
        cascade_k=16,
        cascade_samples=40_000,
        cascade_dgammas=(0.05, 0.1, 0.3, 0.5),
        cascade_check_dgamma=0.3,
        pressures=(1e-2, 1e-3, 1e-4, 1e-5),
        pressure_n=(500, 1000),
        pressure_samples=MEDIUM_P_SAMPLES,
        pressure_gamma_max=0.01,
        floppy="project",
        expected=MEDIUM_EXPECTED,
    ),
    "paper": Scale(
        name="paper",
        jamming_n=(500, 1000, 2000, 4000),
        jamming_samples=300,
        unsat_n=(500, 1000, 2000, 4000),
        unsat_samples=1000,
        dgamma=1e-5,
        gamma_max=0.01,
        jamming_gamma_max=0.01,
        stress_phi=0.75,
        stress_n=256,
        stress_samples=200,
        stress_dgamma=1e-4,
        stress_gamma_max=0.15,
        coord_n=1000,
        coord_samples=8,
        coord_steps=40,
        moduli_lags=(1, 2, 5, 10, 20, 50, 100, 200, 500),
        moduli_fit_max_lag=100,
        min_tail=50,
        n_boot=500,
        cascade_k=64,
        cascade_samples=200_000,
        cascade_dgammas=(0.05, 0.1, 0.3, 0.5),
        cascade_check_dgamma=0.3,
        floppy="project",
        checkpoint_every=100,
        expected="10³–10⁴ CPU hours, extrapolated (jamming samples dominate): a Dask cluster",
    ),
}


def studies(scale: Scale) -> dict[str, Any]:
    """The :class:`jamlab.runs.Study` of a scale, by run-directory name: three at constant volume
    and one per fixed pressure."""
    from jamlab.runs import Study

    return {
        "jamming": Study(phi=("jamming",), n=scale.jamming_n, samples=scale.jamming_samples,
                         dgamma=scale.dgamma, gamma_max=scale.jamming_gamma_max,
                         seed=scale.seed, sizes=scale.sizes, alpha=scale.alpha,
                         floppy=scale.floppy, checkpoint_every=scale.checkpoint_every),
        "unsat": Study(phi=UNSAT_PHI, n=scale.unsat_n, samples=scale.unsat_samples,
                       dgamma=scale.dgamma, gamma_max=scale.gamma_max, seed=scale.seed,
                       sizes=scale.sizes, alpha=scale.alpha,
                       checkpoint_every=scale.checkpoint_every),
        "stress-strain": Study(phi=(scale.stress_phi,), n=(scale.stress_n,),
                               samples=scale.stress_samples, dgamma=scale.stress_dgamma,
                               gamma_max=scale.stress_gamma_max, seed=scale.seed,
                               sizes=scale.sizes, alpha=scale.alpha,
                               checkpoint_every=scale.checkpoint_every),
    } | {
        pressure_run_name(p): Study(phi=("jamming",), n=scale.pressure_n,
                                    samples=scale.pressure_samples,
                                    dgamma=scale.pressure_step,
                                    gamma_max=scale.pressure_gamma_max, seed=scale.seed,
                                    sizes=scale.sizes, alpha=scale.alpha, pressure=p,
                                    checkpoint_every=scale.checkpoint_every)
        for p in scale.pressures
    }


def pressure_run_name(p: float) -> str:
    """The run directory of the fixed-pressure ensemble at ``p`` (``pressure-1e-04``)."""
    return f"pressure-{p:.0e}"


def get_scale(scale: Scale | str) -> Scale:
    """``scale`` itself, or the named scale of :data:`SCALES` (``ValueError`` for an unknown
    name)."""
    if isinstance(scale, str):
        if scale not in SCALES:
            raise ValueError(f"unknown scale {scale!r}: valid scales are {', '.join(SCALES)}")
        return SCALES[scale]
    return scale


def with_seed(scale: Scale, seed: int) -> Scale:
    """The same scale with another master seed (an integer in ``[0, SEED_MAX]``)."""
    from jamlab import validation

    return replace(scale, seed=validation.seed("seed", seed))


def with_pair_law(scale: Scale, sizes: str = "mono", alpha: float = 2.0) -> Scale:
    """The same scale for another system: diameters ``sizes`` and pair exponent ``alpha``
    (``SPEC.md`` §5). The paper's reference values stay those of its system (mono, α = 2)."""
    from jamlab import validation

    return replace(
        scale,
        sizes=validation.sizes("sizes", sizes),
        alpha=validation.pair_exponent("alpha", alpha),
    )
