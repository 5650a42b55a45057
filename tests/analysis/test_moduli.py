"""Moduli moments on a compound Poisson stress process with known moments."""

import math

import numpy as np
import pytest

from jamlab.analysis import (
    CORRELATION_PARTS,
    event_neighbours,
    fit_log_slope,
    increment_correlation,
    increment_correlation_parts,
    moduli_from_stress_jumps,
    moduli_from_trace,
)

# Σ(γ) = G γ + Σ_{jumps at γ_k ≤ γ} s_k, jumps at rate LAM per unit strain, s = −Exp(SCALE):
# ⟨ΔΣ⟩ = (G + LAM E[s]) δγ,  ⟨ΔΣ²⟩ = ((G + LAM E[s]) δγ)² + LAM δγ E[s²]
G, LAM, SCALE = 3.0, 100.0, 0.02
MEAN_S, MEAN_S2 = -SCALE, 2 * SCALE**2


def mu1_exact():
    return G + LAM * MEAN_S


def mu1_sq_exact(dgamma):
    return mu1_exact() ** 2 + LAM * MEAN_S2 / np.asarray(dgamma)


def _traces(rng, samples, steps, dgamma0):
    strain = np.arange(steps + 1) * dgamma0
    stress = np.empty((samples, steps + 1))
    for i in range(samples):
        n_jumps = rng.poisson(LAM * strain[-1])
        where = rng.uniform(0, strain[-1], n_jumps)
        sizes = -rng.exponential(SCALE, n_jumps)
        order = np.argsort(where)
        cum = np.concatenate([[0.0], np.cumsum(sizes[order])])
        stress[i] = G * strain + cum[np.searchsorted(where[order], strain, side="right")]
    return stress


@pytest.mark.parametrize("overlapping", [True, False])
def test_trace_subsampling_matches_compound_poisson(overlapping):
    rng = np.random.default_rng(61)
    dgamma0 = 1e-4
    stress = _traces(rng, samples=400, steps=2000, dgamma0=dgamma0)
    lags = np.array([1, 2, 5, 10, 30, 100, 300])
    mom = moduli_from_trace(stress, dgamma0, lags, overlapping=overlapping)
    np.testing.assert_allclose(mom.strain_step, lags * dgamma0)
    assert np.all(np.abs(mom.mu1 - mu1_exact()) < 4 * mom.mu1_err)
    assert np.all(np.abs(mom.mu1_sq - mu1_sq_exact(mom.strain_step)) < 4 * mom.mu1_sq_err)
    expected_counts = 2001 - lags if overlapping else -(-(2001 - lags) // lags)
    np.testing.assert_array_equal(mom.n_differences, expected_counts)
    small = lags <= 10
    fit = fit_log_slope(mom.strain_step[small], mom.mu1_sq[small], mom.mu1_sq_err[small])
    exact = fit_log_slope(
        mom.strain_step[small], mu1_sq_exact(mom.strain_step[small]), mom.mu1_sq_err[small]
    )
    assert abs(exact.slope + 1) < 0.02  # −1 below the crossover λE[s²]/(G + λE[s])² = 0.08
    assert abs(fit.slope - exact.slope) < 4 * fit.slope_err


def test_separate_runs_match_compound_poisson():
    rng = np.random.default_rng(62)
    steps = np.array([1e-4, 1e-3, 1e-2])
    runs = []
    for dg in steps:
        counts = rng.poisson(LAM * dg, size=(300, 200))
        # sum of k Exp(SCALE) is Gamma(k, SCALE) (zero when k = 0)
        jump_sum = np.where(counts > 0, rng.gamma(np.maximum(counts, 1), SCALE), 0.0)
        runs.append(G * dg - jump_sum)
    mom = moduli_from_stress_jumps(runs, steps)
    assert mom.n_samples == 300 and not mom.overlapping
    assert np.all(np.abs(mom.mu1 - mu1_exact()) < 4 * mom.mu1_err)
    assert np.all(np.abs(mom.mu1_sq - mu1_sq_exact(steps)) < 4 * mom.mu1_sq_err)


def test_log_slope_against_numpy_polyfit(rng):
    x = np.geomspace(1e-5, 1e-2, 8)
    y = 3.0 * x**-1.0 * np.exp(rng.normal(0, 0.05, x.size))
    y_err = 0.05 * y * rng.uniform(0.5, 1.5, x.size)
    fit = fit_log_slope(x, y, y_err)
    coef, cov = np.polyfit(np.log(x), np.log(y), 1, w=y / y_err, cov="unscaled")
    assert fit.slope == pytest.approx(coef[0], rel=1e-10)
    assert fit.intercept == pytest.approx(coef[1], rel=1e-10)
    assert fit.slope_err == pytest.approx(np.sqrt(cov[0, 0]), rel=1e-10)
    assert fit.intercept_err == pytest.approx(np.sqrt(cov[1, 1]), rel=1e-10)
    assert fit.dof == 6


def test_errors():
    with pytest.raises(ValueError, match="lags"):
        moduli_from_trace(np.zeros((2, 5)), 1e-3, [5])
    with pytest.raises(ValueError, match="strain_step"):
        moduli_from_trace(np.zeros((2, 5)), 0.0, [1])
    with pytest.raises(ValueError, match="same number of samples"):
        moduli_from_stress_jumps([np.zeros((2, 3)), np.zeros((3, 3))], [1e-3, 2e-3])
    with pytest.raises(ValueError, match="positive"):
        fit_log_slope([1.0, 2.0], [1.0, -1.0], [0.1, 0.1])


@pytest.mark.parametrize("overlapping", [True, False])
def test_unjammed_minima_are_left_out_as_a_loop_would(overlapping: bool) -> None:
    """``jammed=``: against a plain loop over samples and differences (a difference is used when
    every minimum it spans is jammed; a sample with none at a lag is left out of that lag)."""
    rng = np.random.default_rng(7)
    stress = rng.normal(size=(5, 40)).cumsum(axis=1)
    jammed = rng.random((5, 40)) > 0.08
    jammed[3] = False  # a sample that is never jammed: no differences at all
    dgamma0, lags = 1e-3, [1, 2, 5]
    mom = moduli_from_trace(stress, dgamma0, lags, overlapping=overlapping, jammed=jammed)
    for k, m in enumerate(lags):
        per1, per2, dropped = [], [], 0
        for s in range(stress.shape[0]):
            starts = range(0, stress.shape[1] - m, 1 if overlapping else m)
            used = []
            for n in starts:
                if all(jammed[s, n : n + m + 1]):
                    used.append((stress[s, n + m] - stress[s, n]) / (m * dgamma0))
                else:
                    dropped += 1
            if used:
                per1.append(np.mean(used))
                per2.append(np.mean(np.square(used)))
        assert mom.mu1[k] == pytest.approx(np.mean(per1), rel=1e-12)
        assert mom.mu1_sq[k] == pytest.approx(np.mean(per2), rel=1e-12)
        assert mom.mu1_err[k] == pytest.approx(np.std(per1, ddof=1) / np.sqrt(len(per1)), rel=1e-10)
        assert mom.n_excluded[k] == dropped
    # all jammed: the same numbers as without flags
    plain = moduli_from_trace(stress, dgamma0, lags, overlapping=overlapping)
    every = moduli_from_trace(stress, dgamma0, lags, overlapping=overlapping,
                              jammed=np.ones_like(jammed))
    np.testing.assert_array_equal(plain.mu1_sq, every.mu1_sq)
    assert plain.n_excluded is None and list(every.n_excluded) == [0, 0, 0]


@pytest.mark.parametrize("overlapping, unjammed", [(True, 0.0), (True, 0.03), (False, 0.0)])
def test_within_sample_variance_is_the_jump_part(overlapping, unjammed):
    """mu1_var = λ E[s²] / δγ exactly for independent increments, whatever the spread of G
    between samples and even at lags near the trace's length, where the sum of squares about
    each sample's own mean needs the overlap correction; ⟨μ_1²⟩ holds the spread besides."""
    rng = np.random.default_rng(63)
    dgamma0, steps, samples, spread = 1e-4, 100, 3000, 6.0
    stress = _traces(rng, samples=samples, steps=steps, dgamma0=dgamma0)
    stress += rng.normal(0.0, spread, samples)[:, None] * (np.arange(steps + 1) * dgamma0)
    jammed = rng.random(stress.shape) >= unjammed
    lags = np.array([1, 5, 20, 50])
    mom = moduli_from_trace(stress, dgamma0, lags, overlapping=overlapping,
                            jammed=jammed if unjammed else None)
    exact = LAM * MEAN_S2 / mom.strain_step
    assert np.all(np.abs(mom.mu1_var - exact) < 4 * mom.mu1_var_err)
    # the spread of G between samples (spread² = 36, twice mu1_var at the largest lag) is in
    # ⟨μ_1²⟩ besides ⟨μ_1⟩², not in mu1_var (which would have shown it: 4σ < spread²)
    assert np.all(mom.mu1_sq - mom.mu1**2 - mom.mu1_var > 0.5 * spread**2)
    assert 4 * mom.mu1_var_err[-1] < spread**2
    if overlapping and not unjammed:
        # without the correction (divisor: the count less one) the largest lag is biased low
        m = 50
        d = (stress[:, m:] - stress[:, :-m]) / (m * dgamma0)
        naive = d.var(axis=1, ddof=1).mean()
        assert naive < exact[-1] - 6 * mom.mu1_var_err[-1]


def test_within_sample_variance_of_separate_runs():
    rng = np.random.default_rng(64)
    steps = np.array([1e-4, 1e-3])
    runs = [np.diff(_traces(rng, samples=300, steps=50, dgamma0=dg), axis=1) for dg in steps]
    mom = moduli_from_stress_jumps(runs, steps)
    assert np.all(np.abs(mom.mu1_var - LAM * MEAN_S2 / steps) < 4 * mom.mu1_var_err)


def ma1_stress(rng, theta: float, samples: int, steps: int) -> np.ndarray:
    """Stress traces whose increments are ``e_k + θ e_{k−1}`` (``e`` standard normal, a loading
    drift 0.3 per step): lag-1 correlation ``θ/(1 + θ²)``, none beyond."""
    e = rng.standard_normal((samples, steps + 1))
    d = 0.3 + e[:, 1:] + theta * e[:, :-1]
    return np.concatenate([np.zeros((samples, 1)), np.cumsum(d, axis=1)], axis=1)


@pytest.mark.parametrize("theta", [-0.5, 0.0, 0.4])
def test_increment_correlation_of_a_moving_average(theta):
    """``ρ = θ/(1 + θ²)`` within 5 σ (σ ≈ 1/√pairs), also with minima left unjammed (the pairs
    across them are dropped, not bridged)."""
    rng = np.random.default_rng(11)
    stress = ma1_stress(rng, theta, 200, 500)
    jammed = np.ones(stress.shape, bool)
    expected = theta / (1 + theta**2)
    assert increment_correlation(stress, jammed) == pytest.approx(expected, abs=5 / 300)
    jammed[rng.random(stress.shape) < 0.05] = False
    assert increment_correlation(stress, jammed) == pytest.approx(expected, abs=5 / 270)
    # a step across an unjammed minimum, made huge, changes nothing
    k = np.flatnonzero(~jammed[0, 1:-1])[0] + 1
    spiked = stress.copy()
    spiked[0, k:] += 1e6
    assert increment_correlation(spiked, jammed) == pytest.approx(
        increment_correlation(stress, jammed), abs=1e-12)


def test_increment_correlation_refuses_bad_input():
    with pytest.raises(ValueError, match="jammed has shape"):
        increment_correlation(np.zeros((2, 5)), np.ones((2, 4), bool))
    with pytest.raises(ValueError):
        increment_correlation(np.array([[0.0, 1.0, np.nan, 2.0]]))
    assert np.isnan(increment_correlation(np.array([[0.0, 1.0]])))  # one step: no pair


def test_local_slope_is_minus_one_plus_log2_of_one_plus_rho():
    """The identity the table prints beside the measured local slope: on increments with lag-1
    correlation ρ, ``⟨μ_1²⟩`` at lags 1 and 2 (``moduli_from_trace``) has local slope
    ``−1 + log₂(1 + ρ)`` up to the squared mean increment."""
    rng = np.random.default_rng(3)
    for theta in (-0.6, -0.2, 0.3, 0.8):
        stress = ma1_stress(rng, theta, 100, 2000) - 0.3 * np.arange(2001)  # no drift
        jammed = np.ones(stress.shape, bool)
        m = moduli_from_trace(stress, 1e-5, (1, 2), jammed=jammed)
        local = np.log2(m.mu1_sq[1] / m.mu1_sq[0])
        rho = increment_correlation(stress, jammed)
        assert local == pytest.approx(-1 + np.log2(1 + rho), abs=0.01)
        assert abs(local + 1) > 0.1  # and it is far from −1 for these θ


def _loop_parts(stress, plastic, jammed):
    """The parts of ρ counted pair by pair in plain Python (the reference)."""
    sums, sq_a, sq_b = dict.fromkeys(CORRELATION_PARTS, 0.0), 0.0, 0.0
    for s, pl, jm in zip(stress, plastic, jammed, strict=True):
        steps = [k for k in range(1, len(s)) if jm[k] and jm[k - 1]]
        mean = sum(s[k] - s[k - 1] for k in steps) / len(steps)
        for k in range(1, len(s) - 1):
            if k in steps and k + 1 in steps:
                a, b = s[k] - s[k - 1] - mean, s[k + 1] - s[k] - mean
                kind = {(False, False): "smooth", (False, True): "before",
                        (True, False): "after", (True, True): "events"}[(bool(pl[k]),
                                                                         bool(pl[k + 1]))]
                sums[kind] += a * b
                sq_a += a * a
                sq_b += b * b
    return {k: v / math.sqrt(sq_a * sq_b) for k, v in sums.items()}


def test_correlation_parts_are_a_recount_and_sum_to_rho():
    rng = np.random.default_rng(5)
    stress = ma1_stress(rng, 0.3, 6, 80)
    plastic = rng.random(stress.shape) < 0.2
    jammed = rng.random(stress.shape) > 0.05
    parts = increment_correlation_parts(stress, plastic, jammed)
    expected = _loop_parts(stress, plastic, jammed)
    assert set(parts) == set(CORRELATION_PARTS)
    for k in CORRELATION_PARTS:
        assert parts[k] == pytest.approx(expected[k], rel=1e-12, abs=1e-15)
    assert sum(parts.values()) == pytest.approx(increment_correlation(stress, jammed), abs=1e-12)
    with pytest.raises(ValueError, match="plastic has shape"):
        increment_correlation_parts(stress, plastic[:, 1:], jammed)


def test_event_neighbours_find_a_planted_softening_and_stiffening():
    """Loading by 1 per step, an event (−20) every 10th step, the step before it 0.25 and the
    one after 2: among a sample's 180 unflagged increments (20 × 0.25, 140 × 1, 20 × 2) those
    rank at mid-rank 10/180 and 170/180, and the parts of ρ put the negative covariance next to
    the events."""
    rows = []
    for shift in range(4):
        d = np.ones(200)
        ev = np.arange(5 + shift, 199, 10)
        d[ev], d[ev - 1], d[ev + 1] = -20.0, 0.25, 2.0
        rows.append(np.concatenate([[0.0], np.cumsum(d)]))
    stress = np.array(rows)
    plastic = np.zeros(stress.shape, bool)
    for i, shift in enumerate(range(4)):
        plastic[i, np.arange(5 + shift, 199, 10) + 1] = True  # row k flags the step k − 1 → k
    before, after, count = event_neighbours(stress, plastic)
    assert before == pytest.approx(10 / 180) and after == pytest.approx(170 / 180)
    assert count == 4 * 20
    parts = increment_correlation_parts(stress, plastic)
    assert parts["before"] < 0 and parts["after"] < 0 and parts["events"] == 0
    # without events, nothing to report
    assert np.isnan(event_neighbours(stress, np.zeros(stress.shape, bool))[0])
