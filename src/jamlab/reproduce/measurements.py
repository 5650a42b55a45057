"""The numbers measured on the ensembles, as typed results (no rendering here).

Rules (``docs/reproduce.md``; each re-derived independently in ``tests/test_reproduce.py``):

- avalanches: for every finished sample, the steps flagged ``plastic`` by the AQS runner with
  ``ΔE < 0`` between two jammed minima (:func:`jamlab.analysis.avalanche_sizes`,
  ``threshold=None``, ``jammed=`` the trace's column; runs without it exclude nothing and say
  so); ``S = −ΔE`` (total); the excluded steps and avalanches are counted
  (:func:`jamlab.analysis.exclusions`), and the pressures of the minima each fitted avalanche
  (``S ≥ x_min``) starts from are summarised (median, 10 and 90 % quantiles);
- ``τ``: :func:`jamlab.analysis.fit_power_law` on the sizes pooled over ``N`` at one φ, truncated
  model with ``x_max`` = the largest size (τ may be ≤ 1 above jamming), ``x_min`` by the KS rule
  (tail ≥ ``min_tail``), 95 % percentile bootstrap with ``n_boot`` resamples and seed
  ``scale.seed``; our σ = (CI width)/(2·1.96);
- ``τ`` at fixed pressure also with an exponential cut-off
  (:func:`jamlab.analysis.fit_cutoff_power_law`, ``p(S) ∝ S^(−τ) e^(−S/S_c)``, ``x_min`` by the
  KS rule with that model over at most 20 candidates, tail ≥ ``min_tail``, the same bootstrap):
  the truncated fit's local τ rises with ``x_min`` where the finite-size cut-off bends the tail;
- ``φ_J``: mean and standard error of ``phi_actual`` over the finished jamming samples (all N);
- moduli: :func:`jamlab.analysis.moduli_from_trace` on the intensive stress ``Σ/L³`` of each
  finished sample (overlapping differences at the lags ``moduli_lags``, i.e. subsampling one fine
  trace per sample, no separate runs); slope of ``log⟨μ_1²⟩`` vs ``log δγ`` by
  :func:`jamlab.analysis.fit_log_slope` over the lags ``≤ moduli_fit_max_lag``, at the largest N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from jamlab import validation
from jamlab.reproduce.ensembles import (
    avalanche_set,
    counted_steps,
    finished,
    intensive_stress,
    jammed_flags,
)
from jamlab.reproduce.scales import UNSAT_PHI, Scale

__all__ = [
    "MODULI_LABELS",
    "TAU_LABELS",
    "ModuliResult",
    "OneTrace",
    "PhiJEstimate",
    "StressStrain",
    "TauEstimate",
    "fit_tau",
    "fit_tau_cutoff",
    "moduli",
    "one_trace",
    "phi_j_estimate",
    "predicted_tau",
    "sigma_from_ci95",
    "pressure_tau_estimates",
    "tau_estimate",
    "pressure_summary",
    "stress_strain",
    "tau_estimates",
    "tau_sigma",
    "outside_interval",
    "OUTSIDE_NOTE",
    "interval_note",
    "with_cutoff",
    "CONVERGED_STEP",
    "ConvergedWindow",
    "coarse_sizes",
    "converged_window",
    "COARSE_K",
    "cutoff_coarse",
    "cutoff_shape",
]

TAU_LABELS = ("jamming",) + tuple(repr(p) for p in UNSAT_PHI)
"""The φ labels with a τ fit, in report order (``"jamming"``, ``"0.75"``, ``"0.8"``)."""
MODULI_LABELS = ("jamming", "0.75")
"""The φ labels with moduli moments, in report order."""

_Z_95 = 1.959963984540054  # the two-sided 95 % standard-normal quantile


def predicted_tau(label: str) -> float:
    """The theory's τ: ``τ_J`` (:func:`jamlab.theory.tau_jamming`) at jamming, 1 above."""
    from jamlab.theory import tau_jamming

    return tau_jamming() if label == "jamming" else 1.0


def fit_tau(sizes: np.ndarray, scale: Scale) -> Any:
    """The τ fit of the module rule, or None when there are fewer than ``min_tail`` sizes."""
    from jamlab.analysis import fit_power_law

    if sizes.size < scale.min_tail:
        return None
    return fit_power_law(sizes, x_max=float(np.max(sizes)), min_tail=scale.min_tail,
                         n_boot=scale.n_boot, seed=scale.seed)


CUTOFF_CANDIDATES = 20
"""Most candidate ``x_min`` of the cut-off fit's KS rule (each candidate is a 2-parameter MLE)."""


def fit_tau_cutoff(sizes: np.ndarray, scale: Scale) -> Any:
    """The τ fit with an exponential cut-off of the module rule, or None when there are not
    more than ``max(min_tail, 10)`` sizes."""
    from jamlab.analysis import fit_cutoff_power_law

    tail = max(scale.min_tail, 10)  # the 2-parameter fit needs 10 at least
    if sizes.size <= tail:
        return None
    return fit_cutoff_power_law(sizes, min_tail=tail,
                                max_candidates=CUTOFF_CANDIDATES, n_boot=scale.n_boot,
                                seed=scale.seed)


def sigma_from_ci95(low: float, high: float) -> float:
    """Our 1σ from a 95 % interval: its width over ``2 × 1.96``."""
    return (high - low) / (2 * _Z_95)


def tau_sigma(fit: Any) -> float:
    """Our 1σ of a τ fit: half the 95 % bootstrap interval over 1.96 (the asymptotic standard
    error without a bootstrap interval; NaN without a fit). Where the estimate lies outside its
    own bootstrap interval (:func:`outside_interval`) this σ describes the resamples, not the
    estimate: the printed fits say so (:data:`OUTSIDE_NOTE`; docs/analysis.md)."""
    if fit is None:
        return math.nan
    if math.isfinite(fit.ci_low) and math.isfinite(fit.ci_high):
        return sigma_from_ci95(fit.ci_low, fit.ci_high)
    return fit.tau_stderr


def outside_interval(fit: Any) -> bool:
    """Whether a τ fit's estimate lies outside its bootstrap interval (False without one)."""
    return (fit is not None and math.isfinite(fit.ci_low) and math.isfinite(fit.ci_high)
            and not fit.ci_low <= fit.tau <= fit.ci_high)


OUTSIDE_NOTE = ("the estimate lies outside its bootstrap interval: resampled, the KS rule "
                "chooses other windows, and σ is the resamples' spread")
"""Said beside a τ fit whose estimate lies outside its bootstrap interval."""


def interval_note(fit: Any) -> str:
    """``"; "`` and :data:`OUTSIDE_NOTE` after a printed fit's interval where
    :func:`outside_interval`, else nothing."""
    return f"; {OUTSIDE_NOTE}" if outside_interval(fit) else ""


@dataclass(frozen=True)
class TauEstimate:
    """τ at one φ label: the fit (None with too few sizes) and its σ, the counts it rests on, and
    the size histograms per N (the sources of one N pooled) and of all (``P(S)`` per AQS
    step; ``pooled`` is None without avalanches)."""

    label: str
    fit: Any
    sigma: float
    n_avalanches: int
    steps: int
    samples: int
    per_n: dict[int, Any]
    pooled: Any
    jammed_known: bool = False
    n_steps_excluded: int = 0
    n_avalanches_excluded: int = 0
    fit_pressures: tuple[float, float, float] | None = None
    sampled_pressures: tuple[float, float, float] | None = None
    cutoff: Any = None  # the fit with an exponential cut-off (None: too few sizes, or not made)
    cutoff_sigma: float = math.nan
    cutoff_made: bool = False  # whether the cut-off fit was asked for (with_cutoff)
    cutoff_shape: Any = None  # the profile over the cut-off's shape at the cut-off fit's x_min
    cutoff_coarse: Any = None  # the cut-off fit at COARSE_K δγ (steps paired), at the same x_min
    cutoff_converged: Any = None  # ConvergedWindow: the cut-off fit from the δγ-converged floor
    cutoff_per_n: dict[int, Any] | None = None  # each N (its sources pooled) in that window
    size_difference: Any = None  # SizeDifference of the smallest and largest N in that window

    @property
    def exclusion_text(self) -> str:
        """How many steps and avalanches the jammed flags removed (or that they are absent)."""
        if not self.jammed_known:
            return "no jammed flags in these runs (made before trace format 2): nothing excluded"
        return (f"excluded as unjammed: {self.n_steps_excluded} of {self.steps} steps, "
                f"{self.n_avalanches_excluded} of "
                f"{self.n_avalanches + self.n_avalanches_excluded} avalanches")


def pressure_summary(p: np.ndarray) -> tuple[float, float, float] | None:
    """``(median, 10 %, 90 %)`` quantiles of ``p`` (None when empty)."""
    if not p.size:
        return None
    q10, q50, q90 = np.quantile(p, [0.1, 0.5, 0.9])
    return float(q50), float(q10), float(q90)


def _group_by_n(ns: list[int], items: list[Any]) -> dict[int, list[Any]]:
    """``items`` (one per source, ``ns`` their sizes N) listed per N, in the order of first
    appearance: the sources of one N (two realisations of it) together."""
    out: dict[int, list[Any]] = {}
    for n, x in zip(ns, items, strict=True):
        out.setdefault(n, []).append(x)
    return out


def _by_n(ns: list[int], arrays: list[np.ndarray]) -> dict[int, np.ndarray]:
    """``arrays`` (one per source) concatenated per N (:func:`_group_by_n`)."""
    return {n: np.concatenate(v) for n, v in _group_by_n(ns, arrays).items()}


def tau_estimate(label: str, sources: list[tuple[Any, int]], scale: Scale) -> TauEstimate:
    """:class:`TauEstimate` of the avalanches at φ label ``label`` pooled over ``sources``
    (``(run dataset, N)`` pairs), by the module rule."""
    from jamlab.analysis import log_histogram

    all_sizes, all_p, minima_p, steps, samples = [], [], [], 0, 0
    steps_of: dict[int, int] = {}  # AQS steps per N, its sources summed
    known, n_st, n_av = True, 0, 0
    for ds, n in sources:
        a = avalanche_set(ds, label, n)
        s, st, sa = a.sizes, a.steps, a.samples
        all_sizes.append(s)
        all_p.append(a.pressures)
        minima_p.append(a.minimum_pressures)
        known = known and (a.jammed_known or not st)
        n_st += a.n_steps_excluded
        n_av += a.n_avalanches_excluded
        steps += st
        steps_of[n] = steps_of.get(n, 0) + st
        samples += sa
    # the histogram of each N pools the sources of that N (two realisations of one N: both)
    per_n = {n: log_histogram(s, scale.bins_per_decade, n_total=max(steps_of[n], 1))
             for n, s in _by_n([n for _, n in sources], all_sizes).items() if s.size}
    sizes = np.concatenate(all_sizes) if all_sizes else np.empty(0)
    p_av = np.concatenate(all_p) if all_p else np.empty(0)
    # no avalanches: no histogram (a placeholder histogram was drawn as a point of data, Fig. 5d)
    pooled = (log_histogram(sizes, scale.bins_per_decade, n_total=max(steps, 1))
              if sizes.size else None)
    fit = fit_tau(sizes, scale)
    used = p_av if fit is None else p_av[sizes >= fit.x_min]
    return TauEstimate(label, fit, tau_sigma(fit), int(sizes.size), steps, samples, per_n,
                       pooled, known and steps > 0, n_st, n_av, pressure_summary(used),
                       pressure_summary(np.concatenate(minima_p) if minima_p else np.empty(0)))


def with_cutoff(est: TauEstimate, sources: list[tuple[Any, int]], scale: Scale) -> TauEstimate:
    """``est`` (of the avalanches pooled over ``sources``) with the fit of the same avalanches
    with an exponential cut-off (:func:`fit_tau_cutoff`), the profile over the cut-off's shape
    at that fit's ``x_min`` (:func:`cutoff_shape`), the same fit at ``COARSE_K δγ``
    (:func:`cutoff_coarse`) and from the lowest floor where the two agree
    (:func:`converged_window`); with more than one N, the cut-off fit of each N alone in the
    pooled fit's window (``cutoff_per_n``: a fit per N of the sizes of all its sources, no
    bootstrap, None with fewer than 10 sizes there) — one window for all N, since the local τ
    rises with ``x_min`` — and the difference of τ between the largest and the smallest N there
    with whole packings resampled (``size_difference``: :func:`jamlab.analysis.size_difference`,
    ``scale.n_boot`` resamples; None with ``n_boot < 2`` or fewer than 10 sizes of an N there)."""
    sets = [avalanche_set(ds, est.label, n) for ds, n in sources]
    sizes = [a.sizes for a in sets]
    pooled = np.concatenate(sizes) if sizes else np.empty(0)
    cut = fit_tau_cutoff(pooled, scale)
    two = None if cut is None else coarse_sizes(est.label, sources)
    conv = None if cut is None else converged_window(
        pooled, two, cut.x_min, min_tail=max(scale.min_tail, 10), n_boot=scale.n_boot,
        seed=scale.seed)
    sets_of = _group_by_n([n for _, n in sources], sets)
    pooled_n = {n: np.concatenate([a.sizes for a in v]) for n, v in sets_of.items()}
    per_n = None if cut is None or len(pooled_n) < 2 else {
        n: _fit_from(s, cut.x_min) for n, s in pooled_n.items()}
    diff = None
    if per_n is not None and scale.n_boot >= 2:
        from jamlab.analysis import size_difference

        ends = (min(pooled_n), max(pooled_n))
        packings = {n: [x for a in sets_of[n] for x in a.per_sample] for n in ends}
        try:
            diff = size_difference(packings, cut.x_min, scale.n_boot, scale.seed)
        except ValueError:  # an N with fewer than 10 sizes in the window: no difference
            diff = None
    return replace(est, cutoff=cut, cutoff_sigma=tau_sigma(cut), cutoff_made=True,
                   cutoff_shape=cutoff_shape(pooled, cut),
                   cutoff_coarse=None if cut is None else _fit_from(two, cut.x_min),
                   cutoff_converged=conv, cutoff_per_n=per_n, size_difference=diff)


#: The strain step of the report's convergence check, in units of the run's ``δγ``.
COARSE_K = 2


def coarse_sizes(label: str, sources: list[tuple[Any, int]]) -> np.ndarray:
    """The avalanche sizes at ``COARSE_K δγ`` pooled over ``sources`` (the steps of each sample
    paired, :func:`jamlab.reproduce.ensembles.coarse_avalanches`)."""
    from jamlab.reproduce.ensembles import coarse_avalanches

    parts = [coarse_avalanches(ds, label, n, COARSE_K).sizes for ds, n in sources]
    return np.concatenate(parts) if parts else np.empty(0)


def cutoff_coarse(label: str, sources: list[tuple[Any, int]], cut: Any) -> Any:
    """The fit with an exponential cut-off of the avalanches at ``COARSE_K δγ``
    (:func:`coarse_sizes`) at ``cut``'s ``x_min``, no bootstrap; None without ``cut`` or with
    fewer than 10 sizes there. Its difference from ``cut`` is what doubling the strain step
    does to τ in that window: a check of the run's ``δγ`` (where the change grows with the
    step, halving ``δγ`` moves τ by less; the ``δγ → 0`` correction can exceed it:
    docs/reproduce.md)."""
    if cut is None:
        return None
    return _fit_from(coarse_sizes(label, sources), cut.x_min)


def _fit_from(sizes: np.ndarray, x_min: float) -> Any:
    """The cut-off fit of ``sizes`` at the fixed ``x_min``, no bootstrap (None with fewer than
    10 sizes there)."""
    from jamlab.analysis import fit_cutoff_power_law

    if np.count_nonzero(sizes >= x_min) < 10:
        return None
    return fit_cutoff_power_law(sizes, x_min)


CONVERGED_STEP = 10.0 ** 0.25
"""The ratio between successive floors :func:`converged_window` tries (four per decade)."""


@dataclass(frozen=True)
class ConvergedWindow:
    """The result of :func:`converged_window`. ``fit``: the fit with an exponential cut-off from
    the lowest floor at which the strain step is converged (None: no floor with enough sizes
    passed), with a bootstrap interval at that fixed floor; ``coarse``: the fit at
    ``COARSE_K δγ`` from that floor. ``tried``: for every floor tried, in order,
    ``(x_min, τ, τ at COARSE_K δγ, asymptotic σ of τ)``."""

    fit: Any
    coarse: Any
    tried: tuple[tuple[float, float, float, float], ...]

    @property
    def raised(self) -> int:
        """How many quarter-decade steps the floor went up from the KS window (−1 without a
        converged floor)."""
        return len(self.tried) - 1 if self.fit is not None else -1


def converged_window(sizes: np.ndarray, coarse: np.ndarray, x_min: float, *,
                     min_tail: int, n_boot: int = 0, seed: int = 0) -> ConvergedWindow:
    """The fit with an exponential cut-off of ``sizes`` from the lowest floor ``x_min ×
    CONVERGED_STEP^j`` (``j = 0, 1, …``) at which the fit of ``coarse`` (the same runs' sizes
    at ``COARSE_K δγ``) at the same floor differs from it by no more than the asymptotic σ of
    its τ: the lowest window whose τ the strain step moves by less than its statistical error.
    Floors are tried while both ``sizes`` and ``coarse`` keep ``min_tail`` sizes at or above
    them (``min_tail ≥ 10``). The returned fit has a percentile bootstrap interval at its
    fixed floor (``n_boot`` resamples; the floor's choice is not in it)."""
    from jamlab.analysis import fit_cutoff_power_law

    if not (validation.is_integer(min_tail) and min_tail >= 10):
        raise ValueError(f"min_tail must be an integer >= 10, got {min_tail!r}")
    if not (math.isfinite(x_min) and x_min > 0):
        raise ValueError(f"x_min must be finite and > 0, got {x_min!r}")
    tried = []
    floor = float(x_min)
    while (np.count_nonzero(sizes >= floor) >= min_tail
           and np.count_nonzero(coarse >= floor) >= min_tail):
        one = fit_cutoff_power_law(sizes, floor)
        two = fit_cutoff_power_law(coarse, floor)
        tried.append((floor, one.tau, two.tau, one.tau_stderr))
        if abs(two.tau - one.tau) <= one.tau_stderr:
            fit = fit_cutoff_power_law(sizes, floor, n_boot=n_boot, seed=seed) \
                if n_boot else one
            return ConvergedWindow(fit, two, tuple(tried))
        floor *= CONVERGED_STEP
    return ConvergedWindow(None, None, tuple(tried))


def cutoff_shape(sizes: np.ndarray, cut: Any) -> Any:
    """The profile likelihood over the cut-off's shape ``e^(−(S/S_c)^a)`` of ``sizes`` at the
    cut-off fit ``cut``'s ``x_min`` (:func:`jamlab.analysis.cutoff_shape_profile`, its default
    grid of ``a``), or None without that fit: how far τ moves when the exponential shape is not
    assumed."""
    from jamlab.analysis import cutoff_shape_profile

    return None if cut is None else cutoff_shape_profile(sizes, cut.x_min)


def tau_estimates(jamming: Any, unsat: Any, scale: Scale) -> dict[str, TauEstimate]:
    """:class:`TauEstimate` for each of :data:`TAU_LABELS`, from the ``jamming`` and ``unsat``
    run datasets; at a scale with fixed-pressure ensembles (``scale.pressures``) the
    constant-volume one at jamming also with the cut-off fit, as its τ(p) rows have it (its
    avalanches pool pressures over decades and their distribution is curved: docs/aqs.md,
    "Constant volume: whole samples measured"; the fit's bootstrap costs ≈ 100 CPU-s on 1000
    sizes, which the ``quick`` scale does not spend)."""
    sources = [("jamming", jamming, scale.jamming_n)] + [
        (repr(p), unsat, scale.unsat_n) for p in UNSAT_PHI]
    out = {}
    for label, ds, ns in sources:
        pairs = [(ds, n) for n in ns]
        est = tau_estimate(label, pairs, scale)
        out[label] = (with_cutoff(est, pairs, scale) if label == "jamming" and scale.pressures
                      else est)
    return out


def pressure_tau_estimates(runs: Any, scale: Scale) -> dict[float, TauEstimate]:
    """τ at each fixed pressure of the scale (runs ``pressure-<p>``, φ label ``"jamming"``:
    the packings of the jamming protocol brought to p; ``S = −ΔH``), pooled over
    ``scale.pressure_n``; empty for a scale without fixed-pressure ensembles."""
    from jamlab.reproduce.scales import pressure_run_name

    out = {}
    for p in scale.pressures:
        sources = [(runs[pressure_run_name(p)], n) for n in scale.pressure_n]
        out[p] = with_cutoff(tau_estimate("jamming", sources, scale), sources, scale)
    return out


@dataclass(frozen=True)
class PhiJEstimate:
    """φ_J over the finished jamming samples: mean, standard error, count, and mean per N."""

    mean: float
    sem: float
    n: int
    per_n: dict[int, float]


def phi_j_estimate(jamming: Any, scale: Scale) -> PhiJEstimate:
    """The φ_J rule of the module docstring on the ``jamming`` run dataset."""
    done = jamming.status.values == "done"
    phis = np.asarray(jamming.phi_actual.values)[done]
    mean = float(phis.mean()) if phis.size else math.nan
    sem = float(phis.std(ddof=1) / math.sqrt(phis.size)) if phis.size > 1 else math.nan
    per_n = {}
    for n in scale.jamming_n:
        mask = finished(jamming, "jamming", n)
        if mask.any():
            values = jamming.phi_actual.sel(phi="jamming", N=n).values
            per_n[n] = float(np.nanmean(np.where(mask, values, np.nan)))
    return PhiJEstimate(mean, sem, int(phis.size), per_n)


@dataclass(frozen=True)
class ModuliResult:
    """Moments of the shear modulus per label and N, and per label the slope fit of
    ``log⟨μ_1²⟩`` as ``(N, fit, largest δγ fitted)`` at the largest N (None without one);
    ``var_slopes`` the same for the within-sample variance of ``μ_1`` (``mu1_var``, the part of
    ``⟨μ_1²⟩`` the jumps make)."""

    moments: dict[str, dict[int, Any]]
    slopes: dict[str, tuple[int, Any, float] | None]
    var_slopes: dict[str, tuple[int, Any, float] | None]


def moduli(jamming: Any, unsat: Any, scale: Scale) -> ModuliResult:
    """The moduli rule of the module docstring at :data:`MODULI_LABELS`."""
    from jamlab.analysis import fit_log_slope, moduli_from_trace

    moments: dict[str, dict[int, Any]] = {}
    slopes: dict[str, tuple[int, Any, float] | None] = {}
    var_slopes: dict[str, tuple[int, Any, float] | None] = {}
    for label, ds, ns in (("jamming", jamming, scale.jamming_n), ("0.75", unsat, scale.unsat_n)):
        moments[label] = {}
        for n in ns:
            st = intensive_stress(ds, label, n)
            if st.shape[0] >= 2:
                # differences across an unjammed minimum are not elastic responses: left out
                moments[label][n] = moduli_from_trace(st, scale.dgamma, scale.moduli_lags,
                                                      jammed=jammed_flags(ds, label, n))
        slopes[label] = var_slopes[label] = None
        if moments[label]:
            n_big = max(moments[label])
            m = moments[label][n_big]
            sel = m.strain_step <= scale.moduli_fit_max_lag * scale.dgamma * (1 + 1e-9)
            for out, y, err in ((slopes, m.mu1_sq, m.mu1_sq_err),
                                (var_slopes, m.mu1_var, m.mu1_var_err)):
                if sel.sum() >= 2 and np.all(y[sel] > 0) and np.all(err[sel] > 0):
                    sf = fit_log_slope(m.strain_step[sel], y[sel], err[sel])
                    out[label] = (n_big, sf, scale.moduli_fit_max_lag * scale.dgamma)
    return ModuliResult(moments, slopes, var_slopes)


@dataclass(frozen=True)
class OneTrace:
    """One trace of the jamming ensemble against γ (one entry per minimum, row 0 the start):
    ``E/N`` (ε), ``Σ/L³`` (ε/σ³), the pressure (ε/σ³), the plastic flags of the steps that end
    there, which of them are counted as avalanches (the report's rule,
    :func:`jamlab.reproduce.ensembles.counted_steps`: plastic, ``ΔE < 0``, both minima jammed)
    and the ``jammed`` flag of each minimum (``None`` for runs without it)."""

    n: int
    sample: int
    phi_j: float
    gamma: np.ndarray
    energy_per_particle: np.ndarray
    stress: np.ndarray
    plastic: np.ndarray
    pressure: np.ndarray
    counted: np.ndarray
    jammed: np.ndarray | None


def one_trace(jamming: Any, scale: Scale) -> OneTrace | None:
    """The first finished sample of the largest jamming ensemble (None if there is none)."""
    n = max(scale.jamming_n)
    done = np.flatnonzero(finished(jamming, "jamming", n))
    if not done.size:
        return None
    i = int(done[0])
    sel = dict(phi="jamming", N=n, sample=i)
    length = float(jamming.box_length.sel(**sel))
    plastic = jamming.plastic.sel(**sel).values > 0.5
    flags = jammed_flags(jamming, "jamming", n)
    jammed = None if flags is None else flags[0]  # row 0: the first finished sample, i
    counted = np.zeros(plastic.shape, dtype=bool)
    counted[1:] = counted_steps(jamming, "jamming", n)[1][0]  # the report's rule, sample i
    return OneTrace(n=n, sample=i, phi_j=float(jamming.phi_actual.sel(**sel)),
                    gamma=jamming.gamma.sel(**sel).values,
                    energy_per_particle=jamming.energy.sel(**sel).values / n,
                    stress=jamming.shear_stress.sel(**sel).values / length**3,
                    plastic=plastic, pressure=jamming.pressure.sel(**sel).values,
                    counted=counted, jammed=jammed)


@dataclass(frozen=True)
class StressStrain:
    """The stress–strain ensemble: the strain grid and ``Σ/L³`` per finished sample."""

    gamma: np.ndarray
    stress: np.ndarray

    @property
    def samples(self) -> int:
        """Number of finished samples."""
        return int(self.stress.shape[0])


def stress_strain(ds: Any, scale: Scale) -> StressStrain | None:
    """The ``stress-strain`` run dataset at ``stress_phi`` (None without a finished sample)."""
    label = repr(float(scale.stress_phi))
    stress = intensive_stress(ds, label, scale.stress_n)
    if not stress.shape[0]:
        return None
    gamma = np.asarray(ds.gamma.sel(phi=label, N=scale.stress_n).values)[
        finished(ds, label, scale.stress_n)][0]
    return StressStrain(gamma, stress)
