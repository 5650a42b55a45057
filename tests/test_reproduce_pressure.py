"""The fixed-pressure part of ``reproduce`` (issue 18): the studies a scale with pressures runs,
and τ(p)'s counts re-derived here with h5py and numpy from a small real run."""

from __future__ import annotations

import glob
from dataclasses import replace

import h5py
import numpy as np
import pytest

from jamlab.analysis import cutoff_shape_profile, fit_cutoff_power_law
from jamlab.reproduce import SCALES
from jamlab.reproduce.ensembles import RunSet
from jamlab.reproduce.measurements import pressure_tau_estimates
from jamlab.reproduce.scales import Scale, pressure_run_name, studies
from jamlab.reproduce.table import parameters, pressure_tau_rows
from jamlab.runs import Execution, run_study


def test_medium_scale_studies():
    m = SCALES["medium"]
    st = studies(m)
    assert m.dgamma == 1e-5 and set(m.jamming_n) == {500, 1000}
    for p in (1e-2, 1e-3, 1e-4, 1e-5):
        s = st[pressure_run_name(p)]
        assert s.pressure == p and s.phi == ("jamming",) and s.dgamma == 1e-5
        assert set(s.n) <= {500, 1000}
    assert st["jamming"].pressure is None  # the paper's protocol stays at constant volume
    # the floppy steps of the constant-volume study by projection at medium and paper only;
    # the other studies never carry the choice (it is refused with a pressure)
    for name, scale in SCALES.items():
        want = "project" if name in ("medium", "paper") else "fire"
        assert {k: v.floppy for k, v in studies(scale).items()} == {
            k: (want if k == "jamming" else "fire") for k in studies(scale)}
        assert ("by projection" in parameters(scale, __import__("pathlib").Path("r"))[
            "avalanche ensembles"]) == (want == "project")
    # the samples of every paper-scale study are saved as they go, the others' not (their runs
    # exist: a checkpointed study is another study)
    for name, scale in SCALES.items():
        want = 100 if name == "paper" else 0
        assert {v.checkpoint_every for v in studies(scale).values()} == {want}
        assert ("saved every 100 steps" in parameters(scale, __import__("pathlib").Path("r"))[
            "avalanche ensembles"]) == (name == "paper")
    assert "h" in m.expected
    # every scale's projected cost is in the report header
    text = parameters(m, __import__("pathlib").Path("runs"))["projected cost of every scale"]
    assert all(name in text for name in SCALES)


def test_a_scale_with_an_unknown_floppy_choice_is_refused():
    with pytest.raises(ValueError, match="floppy must be"):
        replace(SCALES["tiny"], floppy="newton")


def test_quick_scale_holds_one_fixed_pressure_ensemble_in_the_papers_steps():
    """``quick``: its constant-volume ensembles step by 1e-4, its fixed-pressure one (N = 125,
    40 packings, p = 1e-5) by the paper's 1e-5 over γ ≤ 0.01; the header and the notes say so,
    with p N² (1e-5 · 125² = 0.156, inside the finite-size regime)."""
    from pathlib import Path

    from jamlab.reproduce.table import notes

    q = SCALES["quick"]
    st = studies(q)
    s = st[pressure_run_name(1e-5)]
    assert q.dgamma == 1e-4 and st["jamming"].dgamma == 1e-4
    assert (s.pressure, s.n, s.samples, s.dgamma, s.gamma_max) == (1e-5, (125,), 40, 1e-5, 0.01)
    text = parameters(q, Path("r"))["fixed-pressure ensembles"]
    assert "(1000 steps), δγ = 1e-05" in text and "N = 125, 40 samples" in text
    (note,) = [t for t in notes(q) if t.startswith("The fixed-pressure ensembles")]
    assert "p N² = 0.156 at p = 1e-05, N = 125" in note and "small box" in note
    big = replace(q, pressure_n=(1000,))
    (note,) = [t for t in notes(big) if t.startswith("The fixed-pressure ensembles")]
    assert "p N² = 10 at p = 1e-05, N = 1000" in note and "small box" not in note
    assert not any(t.startswith("The fixed-pressure") for t in notes(SCALES["tiny"]))


def test_a_scale_with_a_bad_fixed_pressure_step_is_refused():
    with pytest.raises(ValueError, match="pressure_dgamma"):
        replace(SCALES["tiny"], pressure_dgamma=-1e-5)
    with pytest.raises(ValueError, match="strain step"):
        replace(SCALES["tiny"], pressures=(1e-3,), pressure_n=(16,), pressure_samples=2,
                pressure_gamma_max=1e-3, pressure_dgamma=1e-3)
    assert replace(SCALES["tiny"], pressure_dgamma=0.0).pressure_step == SCALES["tiny"].dgamma


def test_a_scale_with_pressures_needs_their_sizes():
    with pytest.raises(ValueError, match="fixed-pressure"):
        replace(SCALES["tiny"], pressures=(1e-3,))


def test_pressure_tau_counts_from_a_small_run(tmp_path):
    scale: Scale = replace(
        SCALES["tiny"], pressures=(1e-3,), pressure_n=(16,), pressure_samples=2,
        pressure_gamma_max=0.2, min_tail=3,
    )
    name = pressure_run_name(1e-3)
    study = studies(scale)[name]
    run_study(study, tmp_path / name, Execution(workers=0))
    est = pressure_tau_estimates(RunSet(tmp_path), scale)[1e-3]
    sizes, steps, x_steps, p_start, paired = [], 0, 0, [], []
    for f in sorted(glob.glob(str(tmp_path / name / "samples" / "*" / "*" / "*.h5"))):
        with h5py.File(f, "r") as h5:
            t = {k: h5["trace"][k][()] for k in h5["trace"]}
        de, pl, jm = t["energy_jump"][1:], t["plastic"][1:].astype(bool), t["jammed"]
        ok = jm[:-1] & jm[1:]
        mask = pl & (de < 0) & ok
        sizes.append(-de[mask])
        # at 2 δγ, from the enthalpy and stress of every other minimum (the coarse check's
        # independent route): ΔE of minima 0, 2, 4, … with a plastic step and all minima jammed
        g, h, sig = t["gamma"][::2], t["energy"][::2], t["shear_stress"][::2]
        de2 = np.diff(h) - np.diff(g) * sig[:-1]
        pl2, ok2 = pl.reshape(-1, 2).any(1), ok.reshape(-1, 2).all(1)
        paired.append(-de2[pl2 & ok2 & (de2 < 0)])
        p_start.append(t["pressure"][:-1][mask])
        steps += de.size
        x_steps += int((~ok).sum())
        assert np.all(np.abs(t["pressure"] - 1e-3) <= 1e-9)  # at the target at every minimum
    sizes = np.concatenate(sizes)
    # the same avalanches at 2 δγ (steps paired), recounted here from every other minimum
    from jamlab.reproduce.ensembles import avalanche_set, coarse_avalanches
    from jamlab.reproduce.measurements import cutoff_coarse

    ds = RunSet(tmp_path)[name]
    one = coarse_avalanches(ds, "jamming", 16, 1)
    assert np.array_equal(one.sizes, avalanche_set(ds, "jamming", 16).sizes)
    two = np.concatenate(paired)
    assert two.size >= 10
    np.testing.assert_allclose(np.sort(coarse_avalanches(ds, "jamming", 16, 2).sizes),
                               np.sort(two), rtol=1e-9, atol=1e-15)
    x_min = 0.999 * float(two.min())  # all of them, whatever the rounding of either route
    low = fit_cutoff_power_law(sizes, x_min)
    assert cutoff_coarse("jamming", [(ds, 16)], low).tau == pytest.approx(
        fit_cutoff_power_law(two, x_min).tau, rel=1e-6)
    assert cutoff_coarse("jamming", [(ds, 16)], None) is None
    assert est.samples == 2 and est.steps == steps == 400
    assert est.n_avalanches == sizes.size and est.n_steps_excluded == x_steps
    assert est.jammed_known
    if sizes.size:
        assert est.pooled.counts.sum() == sizes.size
        p_all = np.concatenate(p_start)
        assert est.fit_pressures is not None
        assert est.fit_pressures[1] >= p_all.min() and est.fit_pressures[2] <= p_all.max()
    row = pressure_tau_rows({1e-3: est})[0]
    assert row.quantity.startswith("τ at fixed pressure p = 0.001")
    assert f"{sizes.size} avalanches" in row.samples
    assert f"excluded as unjammed: {x_steps} of {steps} steps" in row.samples
    # the second row: the fit with an exponential cut-off, on the same sizes
    cut_row = pressure_tau_rows({1e-3: est})[1]
    assert "exponential cut-off" in cut_row.quantity
    if sizes.size > 10:
        ref = fit_cutoff_power_law(sizes, min_tail=10, max_candidates=20,
                                   n_boot=scale.n_boot, seed=scale.seed)
        assert est.cutoff.tau == ref.tau and est.cutoff.x_min == ref.x_min
        # the third row: the profile over the cut-off's shape at that x_min, same sizes
        shape = cutoff_shape_profile(sizes, ref.x_min)
        assert est.cutoff_shape.taus == shape.taus
        assert est.cutoff_shape.logliks == shape.logliks
        if np.count_nonzero(two >= ref.x_min) >= 10:
            assert est.cutoff_coarse.tau == pytest.approx(
                fit_cutoff_power_law(two, ref.x_min).tau, rel=1e-6)
            assert "at 2 δγ" in cut_row.value_text
            # the δγ-converged floor, from the sizes recounted here at 1 and 2 δγ
            from jamlab.reproduce.measurements import converged_window

            w = converged_window(sizes, two, ref.x_min, min_tail=10, n_boot=scale.n_boot,
                                 seed=scale.seed)
            np.testing.assert_allclose(np.array(est.cutoff_converged.tried),
                                       np.array(w.tried), rtol=1e-6)
            if w.fit is not None:
                assert est.cutoff_converged.fit.tau == pytest.approx(w.fit.tau, rel=1e-6)
                assert "δγ-converged" in cut_row.value_text
        else:
            assert est.cutoff_coarse is None and "δγ" not in cut_row.value_text
        # the τ(p) figure's series are the rows' numbers, and the figure is drawn
        from jamlab.reproduce.figures import tau_pressure, tau_pressure_series

        ps, series = tau_pressure_series({1e-3: est})
        ks, conv, shape_free = series.values()
        assert ps == [1e-3]
        assert ks == ([ref.tau], [ref.tau - est.cutoff_sigma], [ref.tau + est.cutoff_sigma])
        assert shape_free == ([shape.tau_best], [shape.tau_low], [shape.tau_high])
        f = est.cutoff_converged.fit
        if f is not None:
            assert conv[0] == [f.tau] and conv[2] == [f.tau + f.tau_stderr]
        path = tau_pressure({1e-3: est}, tmp_path)
        assert path is not None and path.stat().st_size > 0
        assert tau_pressure({}, tmp_path) is None
        # Fig. 5 at fixed pressure: drawn with fixed-pressure rows only; its caption names the
        # flag's threshold at the scale's fixed-pressure step
        from jamlab.reproduce.figures import captions, fig5_pressure

        fig = fig5_pressure({1e-3: est}, scale, tmp_path)
        assert fig is not None and fig.name == "fig5_pressure.png" and fig.stat().st_size > 0
        assert fig5_pressure({}, scale, tmp_path) is None
        assert (f"0.1 δγ² = {0.1 * scale.pressure_step ** 2:.2g} ε"
                in captions(scale)["fig5_pressure"])
        # each N alone: one N has no per-N fits, and two sources of one N (here the same run
        # twice, as two realisations of N = 16 would be) are one N: their sizes pooled in the
        # fits and in the N's histogram (sizes and steps doubled), no per-N panel. The per-N
        # fits of two N with a repeated one: tests/test_medium_fraction.py. The figure's
        # second panel from given per-N fits.
        from jamlab.analysis import log_histogram
        from jamlab.reproduce.figures import tau_pressure_per_n
        from jamlab.reproduce.measurements import tau_estimate, with_cutoff

        assert est.cutoff_per_n is None and tau_pressure_per_n({1e-3: est}) == {}
        twice = tau_estimate("jamming", [(ds, 16), (ds, 16)], scale)
        assert list(twice.per_n) == [16] and twice.steps == 2 * steps
        assert twice.n_avalanches == 2 * sizes.size
        if sizes.size:
            h = log_histogram(np.concatenate([sizes, sizes]), scale.bins_per_decade,
                              n_total=2 * steps)
            assert twice.per_n[16].n_total == 2 * steps
            assert twice.per_n[16].counts.sum() == 2 * sizes.size
            assert np.array_equal(twice.per_n[16].counts, h.counts)
            assert np.array_equal(twice.per_n[16].edges, h.edges)
            np.testing.assert_allclose(twice.per_n[16].density, h.density, rtol=1e-12)
        two_sources = with_cutoff(twice, [(ds, 16), (ds, 16)], scale)
        doubled = fit_cutoff_power_law(np.concatenate([sizes, sizes]), min_tail=10,
                                       max_candidates=20)
        assert two_sources.cutoff.x_min == doubled.x_min
        assert two_sources.cutoff.tau == doubled.tau
        assert two_sources.cutoff_per_n is None
        alone = fit_cutoff_power_law(sizes, float(np.min(sizes)))
        per_n = tau_pressure_per_n({1e-3: replace(est, cutoff_per_n={16: alone, 32: None}),
                                    1e-4: replace(est, cutoff_per_n={32: alone})})
        assert list(per_n) == [f"N = {n} alone, the pooled KS window (± asymptotic σ)"
                               for n in (16, 32)]
        t16, t32 = per_n.values()
        assert t16[0][0] == alone.tau and np.isnan(t16[0][1])  # p = 1e-3 first, 1e-4 none
        assert np.isnan(t32[0][0]) and t32[0][1] == alone.tau
        assert t32[2][1] == alone.tau + alone.tau_stderr
        # the first panel's title names the N the rows pool, not "all N"
        from jamlab.reproduce.figures import tau_pressure_title

        one = {16: est.per_n[16]}
        assert tau_pressure_title({1e-3: replace(est, per_n=one)}) == "fixed-pressure AQS, N = 16"
        both = {16: est.per_n[16], 32: est.per_n[16]}
        assert (tau_pressure_title({1e-3: replace(est, per_n=both), 1e-4: replace(est, per_n=both)})
                == "fixed-pressure AQS, N = 16 + 32 pooled")
        assert (tau_pressure_title({1e-3: replace(est, per_n=both), 1e-4: replace(est, per_n=one)})
                == "fixed-pressure AQS, N = 16, 32 (not every N at every p)")
    else:
        assert est.cutoff is None and cut_row.value_text == "n/a"
        assert est.cutoff_shape is None
        assert pressure_tau_rows({1e-3: est})[2].value_text == "n/a"


def _synthetic_cutoff(tau: float, x_min: float, seed: int):
    """``(scale, sizes, fit)``: 400 synthetic sizes (``S_c = 1e-6``) through the tiny scale's
    cut-off rule with ``min_tail`` 30 and 10 bootstrap samples, checked to be the analysis
    function's fit called directly."""
    from jamlab.analysis import sample_cutoff_power_law
    from jamlab.reproduce.measurements import fit_tau_cutoff

    scale = replace(SCALES["tiny"], min_tail=30, n_boot=10)
    sizes = sample_cutoff_power_law(400, tau, 1e-6, x_min, np.random.default_rng(seed))
    cut = fit_tau_cutoff(sizes, scale)
    ref = fit_cutoff_power_law(sizes, min_tail=30, max_candidates=20, n_boot=10,
                               seed=scale.seed)
    assert (cut.tau, cut.x_min, cut.ci_low) == (ref.tau, ref.x_min, ref.ci_low)
    return scale, sizes, cut


def test_cutoff_tau_of_the_pressure_rows_is_the_analysis_fit():
    # synthetic sizes through the scale's rule: the same numbers as the analysis function called
    # directly, and a row that prints them
    from jamlab.reproduce.measurements import TauEstimate, fit_tau_cutoff, tau_sigma

    scale, sizes, cut = _synthetic_cutoff(1.4, 1e-8, 2)
    est = TauEstimate("jamming", None, float("nan"), sizes.size, 100, 2, {}, None,
                      cutoff=cut, cutoff_sigma=tau_sigma(cut))
    row = pressure_tau_rows({1e-4: est})[1]
    assert row.value == cut.tau and row.error == tau_sigma(cut)
    assert f"{cut.tau:.3f}" in row.value_text and "S_c = " in row.value_text
    assert fit_tau_cutoff(sizes[:30], scale) is None


def test_the_constant_volume_tau_has_a_cutoff_row_too():
    # the paper's protocol at jamming pools p over decades (docs/aqs.md): at a scale with
    # pressures its τ rows are the scale's rule and, below it, the cut-off fit of the same
    # sizes, printed as the analysis function gives it
    from jamlab.reproduce.measurements import TauEstimate, tau_sigma
    from jamlab.reproduce.table import TAU_TITLES, tau_data, tau_rows

    _, sizes, cut = _synthetic_cutoff(1.3, 1e-9, 5)
    est = {label: TauEstimate(label, None, float("nan"), 0, 10, 1, {}, None)
           for label in TAU_TITLES}
    est["jamming"] = TauEstimate("jamming", None, float("nan"), sizes.size, 100, 2, {}, None,
                                 cutoff=cut, cutoff_sigma=tau_sigma(cut), cutoff_made=True)
    rows = tau_rows(est)
    assert len(rows) == len(TAU_TITLES) + 2
    jam = [r for r in rows if "jamming" in r.quantity]
    assert jam[0].quantity.startswith("τ at jamming") and "cut-off" in jam[1].quantity
    assert "shape free" in jam[2].quantity and jam[2].value_text == "n/a"  # no profile made
    assert jam[1].value == cut.tau and jam[1].error == tau_sigma(cut)
    assert jam[1].samples == f"the same {sizes.size} avalanches"
    assert tau_data(est)["tau_jamming_cutoff"]["tau"] == cut.tau
    # with the profile over the cut-off's shape (with_cutoff makes it): a row of its own
    shape = cutoff_shape_profile(sizes, cut.x_min, stretches=(0.3, 0.5, 1.0, 1.5))
    est["jamming"] = replace(est["jamming"], cutoff_shape=shape)
    rows = tau_rows(est)
    row = [r for r in rows if "shape free" in r.quantity]
    assert len(row) == 1 and row[0].quantity.startswith("τ at jamming")
    assert row[0].value == shape.tau_best
    # its σ is the 95 % interval with a free over 2 × 1.96
    assert row[0].error == pytest.approx((shape.tau_high - shape.tau_low) / (2 * 1.959964))
    assert f"[{shape.tau_low:.3f}, {shape.tau_high:.3f}]" in row[0].value_text
    assert f"2Δlog L = {shape.lr_exponential:.1f}" in row[0].value_text
    data = tau_data(est)["tau_jamming_cutoff"]["shape"]
    assert (data["tau_low"], data["tau_high"], data["best_a"]) == (
        shape.tau_low, shape.tau_high, shape.best)


def _cutoff_sample(rng: np.random.Generator, n: int, tau: float, x_c: float) -> np.ndarray:
    """``n`` draws of ``x^(−τ) e^(−x/x_c)`` on ``x ≥ 1``: Pareto draws thinned by the cut-off."""
    out: list[np.ndarray] = []
    while sum(a.size for a in out) < n:
        x = rng.pareto(tau - 1.0, 4 * n) + 1.0
        out.append(x[rng.random(x.size) < np.exp(-x / x_c)])
    return np.concatenate(out)[:n]


def test_converged_window_keeps_the_ks_window_when_the_step_changes_nothing():
    from jamlab.reproduce.measurements import converged_window

    s = _cutoff_sample(np.random.default_rng(3), 4000, 1.5, 1e3)
    w = converged_window(s, s.copy(), 1.0, min_tail=50)
    assert w.raised == 0 and len(w.tried) == 1
    ref = fit_cutoff_power_law(s, 1.0)
    assert w.fit.tau == ref.tau and w.coarse.tau == ref.tau and w.fit.x_min == 1.0


def test_converged_window_rises_above_a_foot_the_step_removed():
    from jamlab.reproduce.measurements import CONVERGED_STEP, converged_window

    s = _cutoff_sample(np.random.default_rng(4), 20000, 1.5, 1e3)
    foot = 10 ** 0.6  # the coarse step lost every size below it, kept every size above
    two = s[s >= foot]
    w = converged_window(s, two, 1.0, min_tail=50, n_boot=30, seed=1)
    floor = CONVERGED_STEP ** 3  # the first quarter-decade floor above the foot
    assert w.raised == 3 and w.fit.x_min == pytest.approx(floor, rel=1e-12)
    # the accepted window, refitted here: the same sizes above it in both, so no difference
    ref = fit_cutoff_power_law(s, w.fit.x_min)
    assert w.fit.tau == pytest.approx(ref.tau, rel=1e-12)
    assert w.coarse.tau == pytest.approx(ref.tau, rel=1e-12)
    assert w.fit.ci_low < ref.tau < w.fit.ci_high
    # every floor below it, refitted here, has the coarse fit more than one σ away
    for x, t, t2, se in w.tried[:-1]:
        one, other = fit_cutoff_power_law(s, x), fit_cutoff_power_law(two, x)
        assert (t, t2, se) == pytest.approx((one.tau, other.tau, one.tau_stderr), rel=1e-12)
        assert abs(other.tau - one.tau) > one.tau_stderr


def test_converged_window_says_when_no_floor_is_converged():
    from jamlab.reproduce.measurements import CONVERGED_STEP, converged_window

    rng = np.random.default_rng(5)
    s = _cutoff_sample(rng, 3000, 1.5, 1e3)
    two = _cutoff_sample(rng, 3000, 2.5, 1e3)  # another law at every floor
    w = converged_window(s, two, 1.0, min_tail=100)
    assert w.fit is None and w.coarse is None and w.raised == -1
    floors = CONVERGED_STEP ** np.arange(len(w.tried) + 1)
    # tried while both keep 100 sizes, and no further
    for x in floors[:-1]:
        assert np.count_nonzero(s >= x) >= 100 and np.count_nonzero(two >= x) >= 100
    last = floors[-1]
    assert np.count_nonzero(s >= last) < 100 or np.count_nonzero(two >= last) < 100
    from jamlab.reproduce.table import converged_text

    assert converged_text(w).startswith("no floor with enough sizes")


def test_converged_window_refuses_bad_arguments():
    from jamlab.reproduce.measurements import converged_window

    s = np.geomspace(1.0, 10.0, 100)
    with pytest.raises(ValueError, match="min_tail"):
        converged_window(s, s, 1.0, min_tail=5)
    with pytest.raises(ValueError, match="x_min"):
        converged_window(s, s, 0.0, min_tail=10)


def test_pressure_moduli_from_a_small_run(tmp_path):
    """The fixed-pressure moduli part on a real run (N = 16, p = 1e-3, 3 packings, the scale's
    fixed-pressure step 5e-4 where its constant-volume one is 1e-3): ``⟨μ_1²⟩`` at the two
    smallest lags, the local slope and the lag-1 increment correlation against a plain recount
    of the sample files (h5py, the intensive stress from each row's own φ, the step from the
    rows' strain), and the report's row and data."""
    import math

    from jamlab.reproduce.moduli_table import pressure_moduli_data, pressure_moduli_rows
    from jamlab.reproduce.pressure_moduli import pressure_moduli

    scale: Scale = replace(
        SCALES["tiny"], pressures=(1e-3,), pressure_n=(16,), pressure_samples=3,
        pressure_gamma_max=0.025, pressure_dgamma=5e-4,
    )
    assert scale.dgamma == 1e-3 and scale.pressure_step == 5e-4
    name = pressure_run_name(1e-3)
    run_study(studies(scale)[name], tmp_path / name, Execution(workers=0))
    e = pressure_moduli(RunSet(tmp_path), scale)[1e-3]
    per_lag = {1: [], 2: []}
    num = sa = sb = 0.0
    for f in sorted(glob.glob(str(tmp_path / name / "samples" / "*" / "*" / "*.h5"))):
        with h5py.File(f, "r") as h5:
            sigma = h5["trace/shear_stress"][()] * h5["trace/phi"][()] / (
                h5.attrs["box_length"] ** 3 * h5.attrs["phi_actual"])
            jm = h5["trace/jammed"][()].astype(bool)
            gamma = h5["trace/gamma"][()]
        assert gamma.size == 51
        step = (gamma[-1] - gamma[0]) / (gamma.size - 1)
        for lag in per_lag:
            vals = [((sigma[k + lag] - sigma[k]) / (lag * step)) ** 2
                    for k in range(sigma.size - lag) if jm[k:k + lag + 1].all()]
            per_lag[lag].append(sum(vals) / len(vals))
        d = [sigma[k] - sigma[k - 1] for k in range(1, sigma.size)]
        ok = [bool(jm[k - 1] and jm[k]) for k in range(1, sigma.size)]
        mean = sum(x for x, o in zip(d, ok, strict=True) if o) / sum(ok)
        for k in range(len(d) - 1):
            if ok[k] and ok[k + 1]:
                a, b = d[k] - mean, d[k + 1] - mean
                num, sa, sb = num + a * b, sa + a * a, sb + b * b
    mu1 = [sum(v) / len(v) for v in per_lag.values()]
    assert e.n == 16 and e.moments.n_samples == 3
    np.testing.assert_allclose(e.moments.mu1_sq[:2], mu1, rtol=1e-9)
    assert e.local_slope == pytest.approx(math.log2(mu1[1] / mu1[0]), rel=1e-9)
    assert e.correlation == pytest.approx(num / math.sqrt(sa * sb), rel=1e-9)
    assert sum(e.correlation_parts.values()) == pytest.approx(e.correlation, abs=1e-12)
    assert step == pytest.approx(5e-4, rel=1e-9)
    assert e.slope is not None and e.fit_max == pytest.approx(10 * 5e-4)
    (row,) = pressure_moduli_rows({1e-3: e})
    assert row.quantity == "slope of log⟨μ_1²⟩ vs log δγ at fixed pressure p = 0.001"
    assert row.value == e.slope.slope and f"ρ = {e.correlation:+.3f}" in row.value_text
    near = e.correlation_parts["before"] + e.correlation_parts["after"]
    assert f"of which {near:+.3f} from the pairs next to an event" in row.value_text
    assert row.samples == "3 samples" and len(row.verdicts) == 2
    data = pressure_moduli_data({1e-3: e})["0.001"]
    assert data["n"] == 16 and data["slope"]["slope"] == e.slope.slope
    assert data["correlation_parts"] == e.correlation_parts
    # a scale without pressures has no such rows
    assert pressure_moduli(RunSet(tmp_path), SCALES["tiny"]) == {}
