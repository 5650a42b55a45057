"""Avalanches (plastic events) from athermal quasi-static (AQS) shear traces.

Conventions of ``SPEC.md`` §3: per step ``n`` (strain ``γ_n → γ_{n+1} = γ_n + δγ_n``),

    ΔE_n = E(γ_{n+1}) − E(γ_n) − δγ_n Σ(γ_n),    ΔΣ_n = Σ(γ_{n+1}) − Σ(γ_n),

with ``E`` and ``Σ = ∂E/∂γ`` extensive. The avalanche size of a plastic step is ``S_n = −ΔE_n``.

On a continuous branch ``E(γ)`` is smooth, so by the trapezoidal rule

    r_n ≡ ΔE_n − ½ δγ_n ΔΣ_n = −δγ³ Σ''/12 + O(δγ⁴) + minimiser noise,

whatever the sign of the local modulus ``ΔΣ_n/δγ_n``; ``ΔE_n`` itself is ``≈ ½ G L^d δγ²``
(``G L^d = ΔΣ/δγ``), which is negative on branches with a negative local modulus (the
``ΔE_n ≈ −6e-9`` stretches of SPEC §3). A jump to another minimum breaks the trapezoidal rule:
``r_n ≈ −S_n``. So ``−r_n`` (the *branch-corrected drop*) is what a threshold should test, and the
threshold is tied to the noise of ``r_n`` on elastic steps (:func:`noise_floor`).

**Unjammed minima.** A step that starts or ends on an unjammed minimum (no rigid backbone, or a
pressure below the resolution floor of the force tolerance, as decided by
``jamlab.spheres.rigidity.is_jammed``) is minimiser noise of a floppy configuration, not an
avalanche. Every function here takes an optional per-*minimum* flag array ``jammed`` (length ``M +
1`` along the last axis, one more than the per-step arrays, as the trace's ``jammed`` dataset);
when given, only steps between two jammed minima (:func:`jammed_steps`) are counted, and
:func:`exclusions` says how many were dropped. Without ``jammed`` nothing changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab import validation

__all__ = [
    "CoarseSteps",
    "NoiseFloor",
    "avalanche_sizes",
    "branch_residual",
    "classify_steps",
    "coarsen_steps",
    "consecutive_events",
    "Exclusions",
    "exclusions",
    "jammed_steps",
    "jumps_from_trace",
    "noise_floor",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

# Normal-consistency factor of the median absolute deviation: σ = 1.4826 MAD for Gaussian noise
_MAD_TO_SIGMA = 1.482602218505602


def jumps_from_trace(
    strain: ArrayLike, energy: ArrayLike, shear_stress: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per-step ``(ΔE_n, ΔΣ_n, δγ_n)`` from a trace of minima at strains ``γ_0 … γ_M``.

    ``ΔE_n = E_{n+1} − E_n − δγ_n Σ_n``, ``ΔΣ_n = Σ_{n+1} − Σ_n``, ``δγ_n = γ_{n+1} − γ_n``
    (SPEC §3; E and Σ extensive). Works along the last axis, so ``(samples, steps+1)`` arrays
    give ``(samples, steps)`` results. Two minima at the same strain (``δγ_n = 0``) raise
    ``ValueError``; NaN (a missing step) passes through.
    """
    strain = np.asarray(strain, dtype=np.float64)
    energy = np.asarray(energy, dtype=np.float64)
    stress = np.asarray(shear_stress, dtype=np.float64)
    if not (strain.shape == energy.shape == stress.shape) or strain.shape[-1] < 2:
        raise ValueError(
            f"strain, energy, shear_stress must share a shape with >= 2 points along the last "
            f"axis; got {strain.shape}, {energy.shape}, {stress.shape}"
        )
    dgamma = np.diff(strain, axis=-1)
    if np.any(dgamma == 0):
        raise ValueError(f"the strain repeats at step {int(np.argwhere(dgamma == 0)[0][-1])}: "
                         "each step needs δγ_n ≠ 0")
    energy_jump = np.diff(energy, axis=-1) - dgamma * stress[..., :-1]
    return energy_jump, np.diff(stress, axis=-1), dgamma


def jammed_steps(jammed: ArrayLike, n_steps: int | None = None) -> BoolArray:
    """Per step ``n`` (minimum ``n`` → ``n + 1``): True when both minima are jammed.

    ``jammed`` holds one flag per minimum along the last axis (``M + 1`` of them); the result has
    ``M`` along the last axis. ``n_steps`` (optional) checks that ``M`` matches the per-step
    arrays it will be combined with.
    """
    flags = np.asarray(jammed)
    if flags.dtype != np.bool_:
        raise ValueError(f"jammed must be a boolean array, got dtype {flags.dtype}")
    if flags.ndim == 0 or flags.shape[-1] < 2:
        raise ValueError(f"jammed needs >= 2 minima along the last axis, got shape {flags.shape}")
    if n_steps is not None and flags.shape[-1] != n_steps + 1:
        raise ValueError(
            f"jammed has {flags.shape[-1]} minima along the last axis; {n_steps} steps need "
            f"{n_steps + 1} (one flag per minimum, rows 0..M of the trace)"
        )
    return flags[..., :-1] & flags[..., 1:]


def _jammed_mask(jammed: ArrayLike | None, shape: tuple[int, ...]) -> BoolArray | None:
    if jammed is None:
        return None
    if not shape:
        raise ValueError("jammed needs per-step arrays with a step axis")
    mask = jammed_steps(jammed, shape[-1])
    if mask.shape != shape:
        raise ValueError(f"jammed gives steps of shape {mask.shape}, the jumps have {shape}")
    return mask


def branch_residual(
    energy_jump: ArrayLike, stress_jump: ArrayLike, strain_step: ArrayLike | float
) -> FloatArray:
    """Trapezoidal-rule residual ``r_n = ΔE_n − ½ δγ_n ΔΣ_n`` (≈ 0 on a continuous branch)."""
    energy_jump = np.asarray(energy_jump, dtype=np.float64)
    return energy_jump - 0.5 * np.asarray(strain_step, dtype=np.float64) * np.asarray(
        stress_jump, dtype=np.float64
    )


@dataclass(frozen=True)
class NoiseFloor:
    """Energy noise of converged minima, measured on elastic steps.

    ``sigma``: robust standard deviation (1.4826 × median absolute deviation) of the residual
    ``r_n`` over the elastic steps; ``median``: its median (≈ 0; a systematic offset would signal
    a biased minimiser or a wrong ``δγ``); ``modulus``: the median extensive modulus
    ``G L^d = ΔΣ_n/δγ_n`` over those steps; ``n_elastic``: steps used; ``local``: whether the
    residual used each step's own ``ΔΣ_n`` (True) or the median modulus (False).
    """

    sigma: float
    median: float
    modulus: float
    n_elastic: int
    local: bool

    def threshold(self, n_sigma: float = 10.0) -> float:
        """A drop threshold ``|median| + n_sigma · sigma`` for :func:`avalanche_sizes`."""
        return abs(self.median) + n_sigma * self.sigma


def noise_floor(
    energy_jump: ArrayLike,
    stress_jump: ArrayLike,
    strain_step: ArrayLike | float,
    plastic: ArrayLike | None = None,
    *,
    local: bool = True,
    jammed: ArrayLike | None = None,
) -> NoiseFloor:
    """Estimate the energy noise of the minima from the elastic steps of a trace.

    Elastic steps: ``~plastic`` when flags are given, otherwise all steps (the median absolute
    deviation ignores a minority of jumps). Residual per step:

    - ``local=True``: ``r_n = ΔE_n − ½ δγ_n ΔΣ_n`` (each step's own modulus ``ΔΣ_n/δγ_n``; exact
      to ``O(δγ³)`` on a smooth branch, so ``r_n`` is minimiser noise);
    - ``local=False``: ``r_n = ΔE_n − ½ G L^d δγ_n²`` with one ``G L^d = median(ΔΣ_n/δγ_n)``; this
      also contains the sample's modulus fluctuations along the trace, so it is an upper bound.

    Returns a :class:`NoiseFloor` with ``sigma = 1.4826 · median|r_n − median r_n|``.
    ``jammed`` (per minimum, see the module docstring): only steps between jammed minima are used.
    A NaN ``ΔE_n`` or ``ΔΣ_n`` is a missing step (as in :func:`classify_steps`) and is not used;
    ``ValueError`` for ``±inf`` in any input, or a NaN ``δγ_n`` of a step that is not missing.
    """
    shape = np.shape(energy_jump)
    jmask = _jammed_mask(jammed, shape)
    energy_jump = np.asarray(energy_jump, dtype=np.float64).ravel()
    stress_jump = np.asarray(stress_jump, dtype=np.float64).ravel()
    try:  # a step per row, per column or per step of the jumps' array
        step = np.broadcast_to(np.asarray(strain_step, dtype=np.float64), shape).ravel()
    except ValueError:
        raise ValueError(f"strain_step {np.shape(strain_step)} does not broadcast to the jumps' "
                         f"shape {shape}") from None
    if stress_jump.shape != energy_jump.shape:
        raise ValueError(
            f"energy_jump {energy_jump.shape} and stress_jump {stress_jump.shape} differ in shape"
        )
    for name, values in (("energy_jump", energy_jump), ("stress_jump", stress_jump),
                         ("strain_step", step)):
        if np.any(np.isinf(values)):
            i = int(np.argmax(np.isinf(values)))
            raise ValueError(f"{name} holds {float(values[i])!r} at flat index {i}: a trace's "
                             "steps are finite (NaN marks a missing step)")
    missing = np.isnan(energy_jump) | np.isnan(stress_jump)
    if np.any(np.isnan(step) & ~missing):
        i = int(np.argmax(np.isnan(step) & ~missing))
        raise ValueError(f"strain_step is NaN at flat index {i}, a step whose jumps are there")
    if np.any(step == 0):
        raise ValueError("strain_step contains zero; the modulus ΔΣ/δγ is undefined there")
    elastic = ~missing
    if plastic is not None:
        elastic = elastic & ~np.asarray(plastic, dtype=bool).ravel()
    if jmask is not None:
        elastic = elastic & jmask.ravel()
    if np.count_nonzero(elastic) < 3:
        raise ValueError(f"need >= 3 elastic steps, got {np.count_nonzero(elastic)} "
                         f"({np.count_nonzero(missing)} NaN steps left out)")
    modulus = float(np.median(stress_jump[elastic] / step[elastic]))
    if local:
        resid = branch_residual(energy_jump, stress_jump, step)[elastic]
    else:
        resid = energy_jump[elastic] - 0.5 * modulus * step[elastic] ** 2
    med = float(np.median(resid))
    sigma = _MAD_TO_SIGMA * float(np.median(np.abs(resid - med)))
    return NoiseFloor(
        sigma=sigma, median=med, modulus=modulus, n_elastic=int(elastic.sum()), local=local
    )


def classify_steps(
    energy_jump: ArrayLike,
    plastic: ArrayLike | None = None,
    threshold: float | None = None,
    *,
    stress_jump: ArrayLike | None = None,
    strain_step: ArrayLike | float | None = None,
    jammed: ArrayLike | None = None,
) -> BoolArray:
    """Boolean mask of the steps counted as avalanches.

    Rule: start from the ``plastic`` flags (all steps if None); if ``threshold`` is given keep
    only steps whose drop exceeds it, the drop being ``−r_n = −(ΔE_n − ½ δγ_n ΔΣ_n)`` when
    ``stress_jump`` and ``strain_step`` are given (recommended: immune to continuous branches
    with negative modulus) and ``−ΔE_n`` otherwise. At least one of ``plastic`` and
    ``threshold`` is required. Steps with ``−ΔE_n ≤ 0`` are never avalanches. With ``jammed``
    (one flag per minimum) steps that start or end unjammed are never avalanches. A NaN ``ΔE_n``
    is a step that is not there (the padding of ensembles of unequal length,
    :func:`jamlab.runs.open_run`) and is never counted; ``±inf`` raises ``ValueError``.
    """
    energy_jump = np.asarray(energy_jump, dtype=np.float64)
    if np.any(np.isinf(energy_jump)):
        raise ValueError("energy_jump holds inf: a trace's jumps are finite (NaN marks a "
                         "missing step)")
    jmask = _jammed_mask(jammed, energy_jump.shape)
    if plastic is None and threshold is None:
        raise ValueError("give plastic flags, a threshold, or both (threshold=None uses flags)")
    mask = np.ones(energy_jump.shape, dtype=bool)
    if plastic is not None:
        mask = np.asarray(plastic, dtype=bool)
        if mask.shape != energy_jump.shape:
            raise ValueError(f"plastic {mask.shape} and energy_jump {energy_jump.shape} differ")
    if threshold is not None:
        if not threshold >= 0:
            raise ValueError(f"threshold={threshold!r} must be >= 0")
        if (stress_jump is None) != (strain_step is None):
            raise ValueError("give both stress_jump and strain_step, or neither")
        if stress_jump is not None:
            drop = -branch_residual(energy_jump, stress_jump, strain_step)
        else:
            drop = -energy_jump
        mask = mask & (drop > threshold)
    mask = mask & (-energy_jump > 0)
    return mask if jmask is None else mask & jmask


def avalanche_sizes(
    energy_jump: ArrayLike,
    plastic: ArrayLike | None = None,
    threshold: float | None = None,
    *,
    stress_jump: ArrayLike | None = None,
    strain_step: ArrayLike | float | None = None,
    jammed: ArrayLike | None = None,
) -> FloatArray:
    """Avalanche sizes ``S_n = −ΔE_n`` (total, extensive energy) of the steps selected by
    :func:`classify_steps` (same arguments and rule), as a flat array of positive numbers.

    ``threshold=None`` (default) means "use the plastic flags". To tie a threshold to the noise
    floor: ``threshold=noise_floor(...).threshold(n_sigma)`` with ``stress_jump`` and
    ``strain_step`` given. The raw ``ΔE_n`` stay available to histogram either way.
    """
    energy_jump = np.asarray(energy_jump, dtype=np.float64)
    mask = classify_steps(
        energy_jump,
        plastic,
        threshold,
        stress_jump=stress_jump,
        strain_step=strain_step,
        jammed=jammed,
    )
    return -energy_jump[mask]


@dataclass(frozen=True)
class Exclusions:
    """What the ``jammed`` flags removed (:func:`exclusions`).

    ``n_steps``: all steps; ``n_steps_excluded``: steps that start or end unjammed;
    ``n_avalanches``: avalanches counted without the flags; ``n_avalanches_excluded``: those of
    them that start or end unjammed (so ``n_avalanches − n_avalanches_excluded`` are counted).
    """

    n_steps: int
    n_steps_excluded: int
    n_avalanches: int
    n_avalanches_excluded: int


def exclusions(
    energy_jump: ArrayLike,
    jammed: ArrayLike,
    plastic: ArrayLike | None = None,
    threshold: float | None = None,
    *,
    stress_jump: ArrayLike | None = None,
    strain_step: ArrayLike | float | None = None,
) -> Exclusions:
    """Count the steps and avalanches (rule of :func:`classify_steps`, same arguments) that the
    per-minimum ``jammed`` flags exclude."""
    energy_jump = np.asarray(energy_jump, dtype=np.float64)
    jmask = _jammed_mask(jammed, energy_jump.shape)
    assert jmask is not None
    every = classify_steps(
        energy_jump, plastic, threshold, stress_jump=stress_jump, strain_step=strain_step
    )
    return Exclusions(
        n_steps=int(energy_jump.size),
        n_steps_excluded=int(np.count_nonzero(~jmask)),
        n_avalanches=int(np.count_nonzero(every)),
        n_avalanches_excluded=int(np.count_nonzero(every & ~jmask)),
    )


@dataclass(frozen=True)
class CoarseSteps:
    """The steps of a trace seen at ``k`` times its strain step (:func:`coarsen_steps`).

    Per coarse step ``K`` (minima ``Kk → (K+1)k``): ``energy_jump``, ``stress_jump``,
    ``strain_step`` as :func:`jumps_from_trace` of the sub-sampled minima; ``plastic``: any of its
    ``k`` steps plastic; ``jammed``: every one of its ``k + 1`` minima jammed (``None`` without
    flags). ``k``; ``dropped``: the trailing steps that did not fill a block."""

    energy_jump: FloatArray
    stress_jump: FloatArray
    strain_step: FloatArray
    plastic: BoolArray | None
    jammed: BoolArray | None
    k: int
    dropped: int


def coarsen_steps(
    energy_jump: ArrayLike,
    stress_jump: ArrayLike,
    strain_step: ArrayLike,
    k: int,
    *,
    plastic: ArrayLike | None = None,
    jammed: ArrayLike | None = None,
) -> CoarseSteps:
    """What a run at strain step ``k δγ`` through the same minima would have recorded: the steps
    of a trace (per-step arrays along the last axis, as the trace's ``energy_jump``,
    ``stress_jump`` and ``diff(gamma)``) grouped ``k`` at a time. With ``Σ_j = Σ_(Kk) + Σ_(i<j)
    ΔΣ_i`` the stress at minimum ``j`` of block ``K``,

        ΔE_K = E_((K+1)k) − E_(Kk) − (Σ_j δγ_j) Σ_(Kk) = Σ_j [ΔE_j + δγ_j (Σ_j − Σ_(Kk))],

    so no absolute energy or stress is needed, and ``k = 1`` returns the input unchanged.
    It is a test of the strain step's convergence without a new run: an avalanche whose size
    depends on ``δγ`` (the branch's curvature ``½ G L^d δγ²`` and the stress drop times the
    strain between the jump and the step's end both enter ``ΔE``) shows as a distribution of
    sizes that moves with ``k``. It is not a rerun: a run at ``k δγ`` may land in other minima,
    and events of one block merge into one. ``jammed`` is one flag per minimum (``M + 1`` along
    the last axis, as :func:`classify_steps` takes it). ``ValueError`` for mismatched shapes or
    ``k`` not a positive integer no larger than the number of steps."""
    ej = np.asarray(energy_jump, dtype=np.float64)
    sj = np.asarray(stress_jump, dtype=np.float64)
    dg = np.broadcast_to(np.asarray(strain_step, dtype=np.float64), ej.shape)
    if sj.shape != ej.shape or ej.ndim == 0:
        raise ValueError(f"energy_jump {ej.shape} and stress_jump {sj.shape} must share a "
                         "shape with a step axis")
    m = ej.shape[-1]
    if not (validation.is_integer(k) and 1 <= k <= m):
        raise ValueError(f"k must be an integer in [1, {m}] (the steps), got {k!r}")
    k = int(k)
    blocks = m // k
    shape = (*ej.shape[:-1], blocks, k)
    ejb = ej[..., : blocks * k].reshape(shape)
    sjb = sj[..., : blocks * k].reshape(shape)
    dgb = dg[..., : blocks * k].reshape(shape)
    before = np.cumsum(sjb, axis=-1) - sjb  # Σ_j − Σ_(Kk): the stress jumps before step j
    pl = None
    if plastic is not None:
        pl = np.asarray(plastic, dtype=bool)
        if pl.shape != ej.shape:
            raise ValueError(f"plastic {pl.shape} and energy_jump {ej.shape} differ")
        pl = pl[..., : blocks * k].reshape(shape).any(axis=-1)
    jm = None
    if jammed is not None:
        jm = _jammed_mask(jammed, ej.shape)
        assert jm is not None
        jm = jm[..., : blocks * k].reshape(shape).all(axis=-1)
    return CoarseSteps(
        energy_jump=(ejb + dgb * before).sum(axis=-1),
        stress_jump=sjb.sum(axis=-1),
        strain_step=dgb.sum(axis=-1),
        plastic=pl,
        jammed=jm,
        k=k,
        dropped=m - blocks * k,
    )


def consecutive_events(events: ArrayLike) -> tuple[NDArray[np.intp], ...]:
    """Where two events follow at consecutive steps: for a boolean mask ``events`` of shape
    ``(..., steps)`` (steps along the last axis, e.g. the counted avalanches above a size), the
    indices (as :func:`numpy.nonzero`) of the first event of each pair; the second is one step
    later along the last axis. A run of ``r`` consecutive events gives ``r − 1`` overlapping
    pairs."""
    ev = np.asarray(events, dtype=bool)
    if ev.ndim == 0:
        raise ValueError("events must have a steps axis")
    return np.nonzero(ev[..., :-1] & ev[..., 1:])
