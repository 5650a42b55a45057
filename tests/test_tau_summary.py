"""``scripts/tau_summary.py``: the pooled packing resamples on sizes drawn from known laws, the
references an interval holds, and the script on real run directories against the library's fits
of an h5py recount, with its refusals (exit code 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from law_draws import cutoff_power_law
from script_helpers import script_module
from trace_recount import finished_samples, recount

X_MIN = 1.0


@pytest.fixture(scope="module")
def ts():
    return script_module("tau_summary")


def test_pooled_resamples_of_independent_avalanches_give_the_asymptotic_error(ts):
    """One law for every packing of two sizes: the stratified packing resamples' σ of the pooled
    τ is the asymptotic σ of the pooled fit; each packing with its own τ widens it."""
    from jamlab.analysis import fit_cutoff_power_law

    rng = np.random.default_rng(4)
    groups = {500: [cutoff_power_law(rng, 1.5, 80.0, 60, X_MIN) for _ in range(40)],
              1000: [cutoff_power_law(rng, 1.5, 80.0, 120, X_MIN) for _ in range(20)]}
    fit = fit_cutoff_power_law(np.concatenate([np.concatenate(g) for g in groups.values()]), X_MIN)
    sigma, used = ts.pooled_packing_sigma(groups, X_MIN, 300, 0)
    assert used == 300 and 0.8 < sigma / fit.tau_stderr < 1.25
    spread = {n: [cutoff_power_law(rng, t, 80.0, 60, X_MIN)
                  for t in rng.normal(1.6, 0.25, 30).clip(1.15, None)] for n in (500, 1000)}
    fit = fit_cutoff_power_law(np.concatenate([np.concatenate(g) for g in spread.values()]), X_MIN)
    assert ts.pooled_packing_sigma(spread, X_MIN, 300, 0)[0] > 1.5 * fit.tau_stderr
    # the same seed draws the same packings
    assert ts.pooled_packing_sigma(groups, X_MIN, 50, 7) == ts.pooled_packing_sigma(
        groups, X_MIN, 50, 7)


def test_which_references_an_interval_holds(ts):
    from jamlab.theory import tau_jamming

    assert ts.holds(0.9, 1.05) == "τ_UNSAT"
    assert ts.holds(tau_jamming() - 1e-9, 1.53) == "τ_J, 1.52"
    assert ts.holds(1.02, 1.40) == "none"


@pytest.fixture(scope="module")
def runs(pressure_runs_by_size):
    return pressure_runs_by_size


def test_real_runs_and_refusals(ts, runs, tmp_path, capsys):
    two = [str(runs[16]), str(runs[24])]
    # exit code 2, one line: not a run directory, bad --boot, shapes, figure name or place
    for argv in ([str(tmp_path)], [*two, "--boot", "1"], [*two, "--shape-grid", "0.5", "-1"],
                 [*two, "--figure", str(tmp_path / "f.txt")],
                 [*two, "--figure", str(runs[16] / "f.png")]):
        with pytest.raises(SystemExit) as err:
            ts.main(argv)
        assert err.value.code == 2
    capsys.readouterr()
    try:
        code = ts.main([*two, "--boot", "20", "--figure", str(tmp_path / "tau.png")])
    except SystemExit as err:  # too few avalanches in a window at this tiny size
        assert err.value.code == 2
        assert "p = 0.001" in capsys.readouterr().err
        return
    assert code == 0 and (tmp_path / "tau.png").stat().st_size > 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| 0.001 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == " + ".join(f"{n} ({len(finished_samples(runs[n]))})" for n in (16, 24))
    # the pooled exponential fit at the printed window, from an h5py recount of the traces
    from jamlab.analysis import fit_cutoff_power_law

    pooled = np.concatenate([recount(runs[16]), recount(runs[24])])
    x_min, tail = (float(v) for v in cells[2].split(","))
    near = pooled[np.argmin(np.abs(np.log(pooled / x_min)))]  # printed to 3 digits
    assert tail == np.count_nonzero(pooled >= near)
    fit = fit_cutoff_power_law(pooled, near)
    tau, rest = cells[3].split(" ± ")
    assert float(tau) == pytest.approx(fit.tau, abs=5e-4)
    assert float(rest.split(" / ")[0]) == pytest.approx(fit.tau_stderr, abs=5e-4)
    assert math.isfinite(float(rest.split(" / ")[1]))


def test_one_size_takes_its_own_shape_free_fit(ts, runs, capsys):
    """A pressure with one size: the shape-free column is ``cutoff_shape_profile`` of that size at
    the window, no likelihood ratio, no per-N table row."""
    from jamlab.analysis import cutoff_shape_profile

    try:
        assert ts.main([str(runs[24]), "--boot", "10"]) == 0
    except SystemExit as err:  # too few avalanches in a window at this tiny size
        assert err.value.code == 2
        return
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| 0.001 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[8] == "— (one size)"
    sizes = recount(runs[24])
    x_min = float(cells[2].split(",")[0])
    near = sizes[np.argmin(np.abs(np.log(sizes / x_min)))]
    prof = cutoff_shape_profile(sizes, near)
    best, interval = cells[5].split(", [")
    assert float(best) == pytest.approx(prof.tau_best, abs=5e-4)
    lo, hi = (float(v) for v in interval.split("]")[0].split(","))
    assert lo == pytest.approx(prof.tau_low, abs=5e-4) and hi == pytest.approx(prof.tau_high,
                                                                                abs=5e-4)
    assert sum(line.startswith("| 0.001 |") for line in out.splitlines()) == 1
    assert "τ per N, exponential" not in out
