"""``scripts/tau_window.py``'s band fits on sizes drawn from a known broken power law (exact
inverse-CDF sampling): the local slope in each regime, the bootstrap over samples against the
asymptotic error, and its refusals."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from tests.script_helpers import script_module

LOW, KNEE, HIGH = 1e-12, 1e-10, 1e-7  # density ∝ S^-1 on [LOW, KNEE], ∝ S^-1.5 on [KNEE, HIGH]
TAU_BELOW, TAU_ABOVE = 1.0, 1.5


def broken_power_law(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` sizes of the continuous density ``∝ S^-1`` below ``KNEE``, ``∝ KNEE^0.5 S^-1.5``
    above (continuous at the knee), on ``[LOW, HIGH]``: each piece's weight is its integral, and
    within a piece the inverse of its CDF."""
    w_below = np.log(KNEE / LOW)
    w_above = 2.0 * (1.0 - np.sqrt(KNEE / HIGH))  # ∫ KNEE^0.5 S^-1.5 dS from KNEE to HIGH, / KNEE^0
    below = rng.random(n) < w_below / (w_below + w_above)
    u = rng.random(n)
    s = np.empty(n)
    s[below] = LOW * (KNEE / LOW) ** u[below]
    # CDF on [KNEE, HIGH] ∝ 1 − sqrt(KNEE/S): S = KNEE / (1 − u (1 − sqrt(KNEE/HIGH)))²
    s[~below] = KNEE / (1.0 - u[~below] * (1.0 - np.sqrt(KNEE / HIGH))) ** 2
    return s


def test_bands_find_the_slope_of_each_regime():
    tw = script_module("tau_window")
    s = np.sort(broken_power_law(np.random.default_rng(1), 40_000))
    low, high, count, tau, err = tw.local_slope(s, 1.0, 1.0, 30)
    assert low[0] == s[0] and np.allclose(high / low, 10.0)
    for lo, hi, t, e in zip(low, high, tau, err, strict=True):
        if hi <= KNEE:
            assert abs(t - TAU_BELOW) < 4 * e, (lo, hi, t, e)
        elif lo >= KNEE:
            assert abs(t - TAU_ABOVE) < 4 * e, (lo, hi, t, e)
    # both regimes are sampled by some band that lies wholly inside them
    assert (high <= KNEE).sum() >= 1 and (low >= KNEE).sum() >= 1
    # the band count is the number of sizes inside it
    assert count[0] == ((s >= low[0]) & (s <= high[0])).sum()


def test_sparse_bands_are_left_out_not_the_end():
    # a sparse foot (3 sizes in the first decade) must not stop the scan before the dense part
    tw = script_module("tau_window")
    rng = np.random.default_rng(3)
    dense = KNEE * 10.0 ** rng.random(500)  # log-uniform on [KNEE, 10 KNEE]: τ = 1
    s = np.sort(np.concatenate([[1e-13, 2e-13, 5e-13], dense]))
    low, high, count, tau, err = tw.local_slope(s, 1.0, 1.0, 30)
    assert low[0] > 5e-13 and count.min() >= 30
    inside = (low >= KNEE * 0.999) & (high <= 10.001 * KNEE)
    assert inside.any() and np.all(np.abs(tau[inside] - 1.0) < 4 * err[inside])
    assert tw.local_slope(s[:3], 1.0, 1.0, 30) is None


def test_bootstrap_over_independent_samples_matches_the_asymptotic_error():
    tw = script_module("tau_window")
    rng = np.random.default_rng(2)
    per_sample = tuple(broken_power_law(rng, 300) for _ in range(40))
    s = np.sort(np.concatenate(per_sample))
    lo, hi = KNEE, 1e-8
    inside = s[(s >= lo) & (s <= hi)]
    fit = tw.fit_power_law(inside, x_min=lo, x_max=hi, min_tail=2)
    boot = tw.band_bootstrap(per_sample, lo, hi, 300)
    assert abs(fit.tau - TAU_ABOVE) < 4 * fit.tau_stderr
    # independent sizes: the spread over resampled samples is the asymptotic error (±25 %)
    assert 0.75 < boot / fit.tau_stderr < 1.25
    assert np.isnan(tw.band_bootstrap(per_sample, lo, hi, 0))


@pytest.mark.parametrize("argv", [
    ["a", "b", "--n", "250", "500", "1000"],
    ["a", "--band", "0"],
    ["a", "--fixed-band", "3e-9", "3e-11"],
    ["a", "--boot", "-1"],
    ["a", "--joint", "1e-10"],  # one run: no N to compare
    ["a", "b", "--n", "500", "500", "--joint", "1e-10"],  # the same N twice
    ["a", "b", "--n", "250", "500", "--joint", "0"],
    ["a", "b", "--n", "250", "500", "--joint-stretch", "0.5"],  # without --joint
    ["a", "b", "--n", "250", "500", "--joint", "1e-10", "--joint-stretch", "-1"],
    ["a", "--moments", "1e-10"],  # one run: no N to compare
    ["a", "b", "--n", "250", "500", "--moments", "0"],
    ["a", "b", "--n", "250", "500", "--moments-permutations", "9"],  # without --moments
])
def test_bad_arguments_exit_2(monkeypatch, argv):
    tw = script_module("tau_window")
    monkeypatch.setattr(sys, "argv", ["tau_window.py", *argv])
    with pytest.raises(SystemExit) as e:
        tw.main()
    assert e.value.code == 2


def test_total_strain_sums_the_finished_samples_only():
    """Three samples of a made-up run: two finished (one ended early, its rows after the end
    NaN), one failed; the strain is the finished ones' last γ less their first, by hand."""
    import xarray as xr

    tw = script_module("tau_window")
    gamma = np.array([[0.0, 0.1, 0.2, 0.3],
                      [0.05, 0.15, np.nan, np.nan],
                      [0.0, 0.1, 0.2, 0.3]])[None, None]
    status = np.array(["done", "done", "failed"])[None, None]
    ds = xr.Dataset(
        {"gamma": (("phi", "N", "sample", "step"), gamma),
         "status": (("phi", "N", "sample"), status)},
        coords={"phi": ["jamming"], "N": [64], "sample": [0, 1, 2], "step": [0, 1, 2, 3]})
    assert tw.total_strain(ds, 64) == pytest.approx(0.3 + 0.1, rel=1e-15)


def test_flag_threshold_is_the_one_the_runs_used(tmp_path):
    """The threshold recomputed from the stored traces equals the one each fixed-pressure
    sample recorded when it was sheared (``shear_plastic_threshold``); NaN at constant volume."""
    from jamlab.runs import Execution, Study, open_run, run_study

    tw = script_module("tau_window")
    study = Study(phi=["jamming"], n=[16], samples=3, dgamma=1e-3, gamma_max=2e-2, seed=4,
                  pressure=1e-3)
    run_study(study, tmp_path / "p", Execution(workers=0))
    ds = open_run(tmp_path / "p")
    recorded = ds.shear_plastic_threshold.sel(phi="jamming", N=16).values
    assert np.all(np.isfinite(recorded))
    assert tw.flag_threshold(ds, 16) == pytest.approx(float(np.median(recorded)), rel=1e-12)
    volume = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=4)
    run_study(volume, tmp_path / "v", Execution(workers=0))
    assert np.isnan(tw.flag_threshold(open_run(tmp_path / "v"), 16))


def cutoff_samples(rng, n_values, beta, per_sample=60, samples=8, tau=1.5, s_min=1e-10,
                   s_ref=1e-8):
    """Samples of sizes from ``S^-τ e^(-S/S*(N))`` on ``[s_min, ∞)``, ``S*(N) = s_ref
    (N/250)^β`` (jamlab's exact sampler of the model)."""
    from jamlab.analysis.cutoff_powerlaw import sample_cutoff_power_law

    return {n: [sample_cutoff_power_law(per_sample, tau, s_ref * (n / 250) ** beta, s_min, rng)
                for _ in range(samples)] for n in n_values}


def test_joint_fit_likelihoods_are_of_the_sizes_themselves():
    """Both maximised log-likelihoods are recomputed from the model's density
    (``cutoff_power_law_logpdf``, summed over the sizes at the fitted parameters): the pooled
    fit's directly, the joint fit's N by N at ``S*(N)``; so their difference is a likelihood
    ratio of the same data in the same units."""
    from jamlab.analysis.cutoff_powerlaw import cutoff_power_law_logpdf

    tw = script_module("tau_window")
    data = cutoff_samples(np.random.default_rng(5), (250, 500, 1000), 1.0)
    floor = 2e-10
    j, c, lr = tw.joint_fits(data, floor, 20)
    sizes = {n: np.concatenate(v) for n, v in data.items()}
    pooled = np.concatenate(list(sizes.values()))
    pooled = pooled[pooled >= floor]
    assert c.loglik == pytest.approx(cutoff_power_law_logpdf(pooled, c.tau, c.x_c, floor).sum(),
                                     rel=1e-10)
    joint = sum(cutoff_power_law_logpdf(s[s >= floor], j.tau, float(j.cutoff(n)), floor).sum()
                for n, s in sizes.items())
    assert j.loglik == pytest.approx(joint, rel=1e-10)
    assert lr == pytest.approx(2.0 * (joint - c.loglik), rel=1e-8, abs=1e-6)


def test_joint_fit_tells_a_growing_cutoff_from_a_fixed_one():
    """β = 1 (the cut-off doubles with N; 1,200 sizes per N): the likelihood ratio is above χ²₁'s
    99.9 % point (10.8), β's interval excludes 0 and β is within 3σ of 1 (over ten other seeds
    the ratio was 12.5–56, the interval held 1 in nine). β = 0: the ratio stays below 10.8 (it
    is ≥ 0 up to the optimiser's tolerance, the models being nested; 0.0–3.0 over ten seeds)
    and β's interval holds 0."""
    tw = script_module("tau_window")
    grows = cutoff_samples(np.random.default_rng(6), (250, 500, 1000), 1.0, per_sample=150)
    j, _, lr = tw.joint_fits(grows, 1e-10, 100)
    assert lr > 10.8 and j.beta_ci95[0] > 0 and abs(j.beta - 1.0) < 3 * j.beta_err
    fixed = cutoff_samples(np.random.default_rng(7), (250, 500, 1000), 0.0, per_sample=150)
    j, _, lr = tw.joint_fits(fixed, 1e-10, 100)
    assert -1e-6 < lr < 10.8 and j.beta_ci95[0] < 0.0 < j.beta_ci95[1]


def test_joint_shape_free_interval_holds_tau_of_a_stretched_cutoff(capsys):
    """Sizes with a stretched cut-off ``e^(−(S/S*)^0.5)``, ``S* ∝ N``, τ = 1.5 (8 samples of 150
    per N): the exponential shape's joint τ is pulled up (1.59–1.63 over seeds 0–5), the
    profile prefers a < 1 and its shape-free interval holds 1.5 (in all of seeds 0–5, best
    a = 0.3–0.5 in five); the printed line is the interval of those fits."""
    from jamlab.analysis import fit_joint_scaling, joint_shape_free
    from jamlab.analysis.cutoff_powerlaw import sample_cutoff_power_law

    tw = script_module("tau_window")
    rng = np.random.default_rng(1)
    data = {n: [sample_cutoff_power_law(150, 1.5, 1e-8 * (n / 250), 1e-10, rng, stretch=0.5)
                for _ in range(8)] for n in (250, 500, 1000)}
    exponential = fit_joint_scaling(data, 1e-10, n_boot=30)
    fits = tw.stretch_table(data, 1e-10, [0.3, 0.5, 1.5], 30, exponential)
    assert sorted(fits) == [0.3, 0.5, 1.0, 1.5] and fits[1.0] is exponential
    free = joint_shape_free(fits)
    best, low, high = free.best, free.tau_low, free.tau_high
    assert best < 1.0 and fits[best].loglik == max(f.loglik for f in fits.values())
    assert low < 1.5 < high < exponential.tau + 2 * exponential.tau_err
    assert exponential.tau > 1.5 + exponential.tau_err  # the assumed shape biases τ
    assert low <= fits[best].tau <= high
    assert f"τ in [{low:.3f}, {high:.3f}] (95 %)" in capsys.readouterr().out


def test_permuted_deals_whole_samples_and_keeps_each_n_count():
    tw = script_module("tau_window")
    data = {250: [np.full(3, 1.0), np.full(2, 2.0)], 500: [np.full(4, 3.0)],
            1000: [np.full(1, 4.0), np.full(5, 5.0), np.full(6, 6.0)]}
    out = tw.permuted(data, np.random.default_rng(0))
    assert {n: len(v) for n, v in out.items()} == {250: 2, 500: 1, 1000: 3}
    dealt = sorted(tuple(x.tolist()) for v in out.values() for x in v)
    assert dealt == sorted(tuple(x.tolist()) for v in data.values() for x in v)


def test_permutation_null_is_chi2_for_independent_sizes_and_wider_for_unlike_samples():
    """No N-dependence. Independent sizes, every sample alike: the permuted ratios follow χ²₁
    (median 0.45, 95 % point 3.84; with 60 permutations accepted in (0.1, 1) and (1.5, 8): over
    fifteen other seeds 0.18–0.61 and 2.0–6.3). Samples whose cut-offs differ (log-normal,
    σ = 2 in log S_c): the permuted median is above 1 and the 95 % point above 3.84 (nine seeds:
    1.2–6.2 and 5.0–19), so reading the ratio as χ²₁ would see an N-dependence that is not
    there."""
    tw = script_module("tau_window")
    from jamlab.analysis.cutoff_powerlaw import sample_cutoff_power_law

    rng = np.random.default_rng(11)
    alike = cutoff_samples(rng, (250, 500, 1000), 0.0, per_sample=40, samples=8)
    median, q95 = np.quantile(tw.permutation_test(alike, 1e-10, 60)[2], [0.5, 0.95])
    assert 0.1 < median < 1.0 and 1.5 < q95 < 8.0
    unlike = {n: [sample_cutoff_power_law(40, 1.5, 1e-8 * np.exp(2.0 * rng.standard_normal()),
                                          1e-10, rng) for _ in range(8)]
              for n in (250, 500, 1000)}
    median, q95 = np.quantile(tw.permutation_test(unlike, 1e-10, 60)[2], [0.5, 0.95])
    assert median > 1.0 and q95 > 3.84


def test_permutation_test_finds_a_cutoff_that_grows():
    tw = script_module("tau_window")
    grows = cutoff_samples(np.random.default_rng(6), (250, 500, 1000), 1.0, per_sample=150)
    lr, p_value, null = tw.permutation_test(grows, 1e-10, 40)
    assert p_value == 1 / 41 and lr > null.max()


def test_ks_permutation_holds_its_level_where_ks_2samp_does_not():
    """Two runs drawn alike, but each sample a cluster (100 sizes sharing a random cut-off,
    log-normal σ = 2): ks_2samp, which takes the sizes as independent, rejects at 5 % in about
    half of 60 repetitions (27–34 over three seeds); the test that deals whole samples in about
    5 % (1–2). Asserted: at least 20 and at most 8. Then a real difference (cut-offs 1e-9
    against 1e-7, independent sizes) is found."""
    from scipy import stats

    from jamlab.analysis.cutoff_powerlaw import sample_cutoff_power_law

    tw = script_module("tau_window")
    rng = np.random.default_rng(3)

    def run(centre):
        return [sample_cutoff_power_law(100, 1.5, centre * np.exp(2.0 * rng.standard_normal()),
                                        1e-10, rng) for _ in range(10)]

    naive = permuted = 0
    for _ in range(60):
        pair = {0: run(1e-8), 1: run(1e-8)}
        naive += stats.ks_2samp(np.concatenate(pair[0]), np.concatenate(pair[1])).pvalue < 0.05
        permuted += tw.ks_permutation(pair, 1e-10, 99)[1] < 0.05
    assert naive >= 20 and permuted <= 8
    differ = {0: [sample_cutoff_power_law(30, 1.5, 1e-9, 1e-10, rng) for _ in range(10)],
              1: [sample_cutoff_power_law(30, 1.5, 1e-7, 1e-10, rng) for _ in range(10)]}
    assert tw.ks_permutation(differ, 1e-10, 99)[1] <= 0.05


def test_joint_figure_is_drawn(tmp_path):
    tw = script_module("tau_window")
    data = cutoff_samples(np.random.default_rng(8), (250, 500), 1.0, per_sample=30, samples=4)
    tw.joint_figure(data, 1e-10, tw.joint_fits(data, 1e-10, 4), tmp_path / "f" / "joint.png")
    assert (tmp_path / "f" / "joint.png").stat().st_size > 10_000


def model_moment_ratio(tau: float, cutoff: float, floor: float) -> float:
    """``⟨S²⟩/⟨S⟩`` of the density ``∝ S^-τ e^(-S/S*)`` on ``[floor, ∞)``, from the upper
    incomplete gamma function: ``∫ S^(k-τ) e^(-S/S*) dS = S*^(k-τ+1) Γ(k-τ+1, floor/S*)``."""
    from scipy.special import gamma, gammaincc

    def moment(k):
        a = k - tau + 1.0
        return cutoff ** a * gamma(a) * gammaincc(a, floor / cutoff)

    return moment(2) / moment(1)


def test_moment_beta_is_the_slope_of_the_moment_ratios():
    """``S_c`` of each N is ``Σ S² / Σ S`` of its sizes ≥ the floor (recomputed here). Over 20
    seeds (8 samples of 150 sizes per N), for a cut-off that doubles with N, β averages within
    0.15 of the slope of the model's own moment ratios (exact, from the incomplete gamma
    function: 0.92, not 1, since the ratio is not yet proportional to S* at S*/floor = 33–133;
    the ratio of heavy-tailed sums is biased low, by ≈ 0.07 here), and for a fixed cut-off within
    0.15 of 0. The 95 % intervals hold the true slope in at least 80 % of the seeds (measured
    over 60 seeds: 93 % at β = 0, 88 % at 0.92 — a bootstrap over 8 samples under-covers, so
    the permutation p-value is the test to read)."""
    tw = script_module("tau_window")
    floor, ns = 3e-10, (250, 500, 1000)
    grows = cutoff_samples(np.random.default_rng(6), ns, 1.0, per_sample=150)
    m = tw.moment_beta(grows, floor, 200)
    for k, n in enumerate(ns):
        s = np.concatenate(grows[n])
        s = s[s >= floor]
        assert m.avalanches[k] == s.size
        assert m.cutoff[k] == pytest.approx(np.sum(s * s) / np.sum(s), rel=1e-12)
    exact = [model_moment_ratio(1.5, 1e-8 * n / 250, floor) for n in ns]
    slope = np.polyfit(np.log(ns), np.log(exact), 1)[0]
    assert 0.9 < slope < 0.95
    for beta, truth in ((1.0, slope), (0.0, 0.0)):
        fits = [tw.moment_beta(cutoff_samples(np.random.default_rng(300 + seed), ns, beta,
                                              per_sample=150), floor, 100)
                for seed in range(20)]
        assert abs(np.mean([f.beta for f in fits]) - truth) < 0.15
        assert np.mean([f.beta_ci95[0] < truth < f.beta_ci95[1] for f in fits]) >= 0.8


def test_moment_permutation_finds_a_cutoff_that_grows_and_not_one_that_does_not():
    tw = script_module("tau_window")
    grows = cutoff_samples(np.random.default_rng(6), (250, 500, 1000), 1.0, per_sample=150)
    beta, p_value, null = tw.moment_permutation(grows, 1e-10, 40)
    assert p_value == 1 / 41 and beta > null.max()
    fixed = cutoff_samples(np.random.default_rng(7), (250, 500, 1000), 0.0, per_sample=150)
    assert tw.moment_permutation(fixed, 1e-10, 40)[1] > 0.05
