"""``scripts/size_dependence.py``: τ of two sizes in one window, with packings as units —
checked on sizes drawn from known laws (independent avalanches, a shift of τ, packings that
differ), and its refusals (exit code 2) on real run directories."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from script_helpers import script_module

X_MIN = 1.0


@pytest.fixture(scope="module")
def sd():
    return script_module("size_dependence")


def _draw(rng, tau: float, s_c: float, m: int) -> np.ndarray:
    """``m`` sizes of ``S^−τ e^(−S/S_c)`` on ``S ≥ X_MIN`` (Pareto draws thinned by the cut-off)."""
    out = np.empty(0)
    while out.size < m:
        s = X_MIN * (1 - rng.random(4 * m)) ** (-1 / (tau - 1))
        out = np.concatenate([out, s[rng.random(s.size) < np.exp(-(s - X_MIN) / s_c)]])
    return out[:m]


def _packings(rng, taus, s_c: float, m: int) -> list[np.ndarray]:
    return [_draw(rng, t, s_c, m) for t in taus]


def test_independent_avalanches_give_the_asymptotic_error(sd):
    """Every avalanche independent (one law for all packings): the packing bootstrap's σ of Δτ
    is the asymptotic one, and the two sizes' τ are the law's."""
    rng = np.random.default_rng(1)
    groups = {500: _packings(rng, [1.5] * 40, 50.0, 60),
              1000: _packings(rng, [1.5] * 20, 100.0, 120)}
    r = sd.size_difference(groups, X_MIN, boot=400, seed=0)
    assert r.n == (500, 1000) and r.packings == (40, 20) and r.tails == (2400, 2400)
    assert abs(r.tau[0] - 1.5) < 4 * r.sigma[0] and abs(r.tau[1] - 1.5) < 4 * r.sigma[1]
    assert 0.8 < r.boot_sigma / np.hypot(*r.sigma) < 1.25
    assert abs(r.z_boot) < 4 and 0.0 < r.fraction_not_above < 1.0
    assert r.delta == r.tau[1] - r.tau[0]


def test_a_shift_of_tau_is_found(sd):
    rng = np.random.default_rng(2)
    groups = {250: _packings(rng, [1.3] * 30, 200.0, 100),
              500: _packings(rng, [1.7] * 30, 200.0, 100)}
    r = sd.size_difference(groups, X_MIN, boot=200, seed=0)
    assert abs(r.delta - 0.4) < 4 * r.boot_sigma and r.z_boot > 5
    assert r.fraction_not_above == 0.0


def test_packings_that_differ_widen_the_error(sd):
    """Each packing with its own τ (spread 0.25): the avalanches of one packing are not
    independent draws of the pooled law, and resampling packings shows it."""
    rng = np.random.default_rng(3)
    groups = {n: _packings(rng, rng.normal(1.6, 0.25, 20).clip(1.15, None), 100.0, 150)
              for n in (500, 1000)}
    r = sd.size_difference(groups, X_MIN, boot=300, seed=0)
    assert r.boot_sigma > 1.5 * np.hypot(*r.sigma)


def test_the_combined_scores_are_the_normal_and_chi2_ones(sd):
    chi2, p_chi2, s, p_s = sd.combined([1.0, -1.0, 2.0])
    assert chi2 == pytest.approx(6.0) and s == pytest.approx(2.0 / np.sqrt(3.0))
    # χ²_3 survival at 6 and the two-sided normal p at 2/√3, by their closed forms
    from math import erfc, exp, pi, sqrt

    assert p_chi2 == pytest.approx(erfc(sqrt(3.0)) + sqrt(2 * 6.0 / pi) * exp(-3.0), rel=1e-12)
    assert p_s == pytest.approx(erfc(2.0 / np.sqrt(3.0) / sqrt(2.0)), rel=1e-12)


def test_bad_groups_are_refused(sd):
    rng = np.random.default_rng(4)
    one = {500: _packings(rng, [1.5] * 3, 10.0, 20)}
    with pytest.raises(ValueError, match="need two sizes"):
        sd.size_difference(one, X_MIN, boot=10)
    two = {**one, 1000: [np.array([0.5, 0.7])]}
    with pytest.raises(ValueError, match="N = 1000: 0 sizes at or above"):
        sd.size_difference(two, X_MIN, boot=10)
    with pytest.raises(ValueError, match="--boot must be >= 2"):
        sd.size_difference({**one, 1000: one[500]}, X_MIN, boot=1)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    from jamlab.runs import Execution, Study, run_study

    root = tmp_path_factory.mktemp("sd_runs")
    out = {}
    for n in (16, 24):
        study = Study(phi=["jamming"], n=[n], samples=4, dgamma=1e-3, gamma_max=0.2, seed=5,
                      pressure=1e-3)
        run_study(study, root / f"n{n}", Execution(workers=0))
        out[n] = root / f"n{n}"
    return out


def _recount(path) -> np.ndarray:
    """Avalanche sizes −ΔH (plastic steps with ΔH < 0 between jammed minima) of a run, read
    with h5py."""
    sizes = [np.empty(0)]
    for f in sorted(path.glob("samples/*/*/*.h5")):
        with h5py.File(f, "r") as h5:
            de, pl = h5["trace/energy_jump"][1:], h5["trace/plastic"][1:].astype(bool)
            jm = h5["trace/jammed"][()]
        sizes.append(-de[pl & (de < 0) & jm[:-1] & jm[1:]])
    return np.concatenate(sizes)


def test_real_runs_and_refusals(sd, runs, tmp_path, capsys):
    # exit code 2, one line: not a run directory; one size only
    for argv in ([str(tmp_path)], [str(runs[16])], [str(runs[16]), str(runs[24]), "--boot", "1"]):
        with pytest.raises(SystemExit) as err:
            sd.main(argv)
        assert err.value.code == 2
    # two sizes: a row for p = 0.001 whose size counts are the h5py recount's in the window
    # (checked only where each size has the 10 sizes a fit needs)
    from jamlab.reproduce.measurements import avalanche_set
    from jamlab.runs import open_run

    counts = [sum(a.size for a in avalanche_set(open_run(runs[n]), "jamming", n).per_sample)
              for n in (16, 24)]
    assert counts == [_recount(runs[16]).size, _recount(runs[24]).size]
    try:
        code = sd.main([str(runs[16]), str(runs[24]), "--boot", "20"])
    except SystemExit as err:  # too few avalanches in the window at this tiny size
        assert err.value.code == 2
        assert "fewer than 10" in capsys.readouterr().err
        return
    assert code == 0
    out = capsys.readouterr().out
    assert "over 1 pressure(s)" in out
    row = next(line for line in out.splitlines() if line.startswith("| 0.001 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    x_min = float(cells[1])  # (printed to 3 digits: the counts are compared away from it)
    for cell, n in zip(cells[2:4], (16, 24), strict=True):
        k, tail = (int(v) for v in cell.split(":")[1].split(",")[:2])
        s = _recount(runs[n])
        assert k == len(list(runs[n].glob("samples/*/*/*.h5")))
        assert np.count_nonzero(s >= x_min * 1.001) <= tail <= np.count_nonzero(s >= x_min * 0.999)
