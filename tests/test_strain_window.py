"""``scripts/strain_window.py``: the per-part statistics of a small fixed-pressure run, recomputed
from the sample files themselves (h5py, the SPEC's definitions), and its refusals."""

from __future__ import annotations

import sys

import h5py
import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module


@pytest.fixture(scope="module")
def small_run(small_pressure_run):
    return small_pressure_run


def direct(run, parts, floor):
    """μ, Δφ and the counts per part from the sample files: σ_xy = Σ/V with each row's volume
    V = N (π/6)/φ (monodisperse spheres of unit diameter), S = −ΔE of plastic steps with ΔE < 0
    between two jammed minima."""
    mus, dphis, counts = [], [], np.zeros(parts, dtype=int)
    for f in sorted(run.glob("samples/*/*/sample-*.h5")):
        with h5py.File(f) as h:
            t = {k: h[f"trace/{k}"][:] for k in ("shear_stress", "pressure", "phi",
                                                  "energy_jump", "plastic", "jammed")}
            n = int(h.attrs["n"])
        steps = t["energy_jump"].size - 1
        edges = np.linspace(0, steps, parts + 1).round().astype(int)
        mu = t["shear_stress"] * t["phi"] / (n * np.pi / 6) / t["pressure"]
        mus.append([mu[a:b + 1].mean() for a, b in zip(edges[:-1], edges[1:], strict=True)])
        dphis.append([t["phi"][b] - t["phi"][a] for a, b in zip(edges[:-1], edges[1:],
                                                                 strict=True)])
        s = -t["energy_jump"][1:]
        hit = t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:] & (s > 0) & (s >= floor)
        counts += [int(hit[a:b].sum()) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    return np.mean(mus, axis=0), np.mean(dphis, axis=0), counts


def test_parts_equal_the_sample_files(small_run):
    from jamlab.runs import open_run

    sw = script_module("strain_window")
    w = sw.window_parts(open_run(small_run), 16, 3, [0.0, 1e-6])
    assert w["samples"] == 3 and w["steps"] == 30
    for floor in (0.0, 1e-6):
        mu, dphi, counts = direct(small_run, 3, floor)
        assert w["counts"][floor].tolist() == counts.tolist()
    assert w["counts"][0.0].sum() > 0  # the run has avalanches to count
    np.testing.assert_allclose(w["mu"], mu, rtol=1e-12)
    np.testing.assert_allclose(w["dphi"], dphi, rtol=1e-12, atol=1e-18)
    assert np.all(np.isfinite(w["mu_err"]))


def test_uniform_chi2():
    sw = script_module("strain_window")
    chi2, p = sw.uniform_chi2(np.array([10, 10, 10]), np.array([0, 10, 20, 30]))
    assert chi2 == 0.0 and p == pytest.approx(1.0)
    # unequal parts: expected 20 · (10, 20) / 30
    chi2, _ = sw.uniform_chi2(np.array([10, 10]), np.array([0, 10, 30]))
    assert chi2 == pytest.approx((10 - 20 / 3) ** 2 / (20 / 3) + (10 - 40 / 3) ** 2 / (40 / 3))
    assert np.isnan(sw.uniform_chi2(np.array([0, 0]), np.array([0, 1, 2]))[0])


@pytest.mark.parametrize("argv", [
    ["a", "b", "--n", "250", "500", "1000"],
    ["a", "--parts", "0"],
    ["a", "--above", "0"],
])
def test_bad_arguments_exit_2(monkeypatch, argv):
    sw = script_module("strain_window")
    assert exit_code(sw, argv, monkeypatch) == 2


def test_part_sizes_and_fits(small_run):
    """The per-part sizes are the counted jumps of the sample files' own traces, and each part's
    fit is the library's fit of exactly those sizes."""
    from jamlab.analysis import fit_cutoff_power_law
    from jamlab.runs import open_run

    sw = script_module("strain_window")
    sizes = sw.part_sizes(open_run(small_run), 16, 2)
    by_part: list[list[float]] = [[], []]
    for f in sorted(small_run.glob("samples/*/*/sample-*.h5")):
        with h5py.File(f) as h:
            t = {k: h[f"trace/{k}"][:] for k in ("energy_jump", "plastic", "jammed")}
        steps = t["energy_jump"].size - 1
        edges = np.linspace(0, steps, 3).round().astype(int)
        s = -t["energy_jump"][1:]
        hit = t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:] & (s > 0)
        for k, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
            by_part[k] += s[a:b][hit[a:b]].tolist()
    for got, want in zip(sizes, by_part, strict=True):
        assert sorted(got.tolist()) == sorted(want)
    assert sum(s.size for s in sizes) > 0
    # the fits: on sizes drawn from a pure power law (the small run has too few for a fit)
    floor = 1e-10
    drawn = floor * np.random.default_rng(5).pareto(0.5, 400) + floor  # τ = 1.5
    fits = sw.part_fits([drawn, drawn[:3], drawn / 10], floor)
    ref = fit_cutoff_power_law(drawn, x_min=floor)
    assert fits[0] == (400, float(ref.tau), float(ref.tau_stderr), float(ref.x_c),
                       float(ref.x_c_stderr))
    assert abs(fits[0][1] - 1.5) < 4 * fits[0][2]  # the exponent drawn
    assert fits[1] is None  # three sizes are too few for a fit
    assert fits[2][0] == int(np.count_nonzero(drawn / 10 >= floor))  # only those at the floor


def test_fit_table_printed(small_run, monkeypatch, capsys):
    """``--fit-at``: one row per floor, one cell per part; the small run's parts are too small
    for a fit, and say so rather than print a number."""
    sw = script_module("strain_window")
    monkeypatch.setattr(sys, "argv", ["strain_window.py", str(small_run), "--n", "16",
                                      "--parts", "3", "--fit-at", "1e-12", "1e-10",
                                      "--fit-parts", "2"])
    sw.main()
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| 1e-")]
    assert [r.split("|")[1].strip() for r in rows] == ["1e-12", "1e-10"]
    for r in rows:
        cells = [c.strip() for c in r.strip("|").split("|")]
        assert cells[1:] == ["too few", "too few", "—", "—"]


@pytest.mark.parametrize("argv", [["a", "--fit-at", "0"], ["a", "--fit-parts", "0"]])
def test_bad_fit_arguments_exit_2(monkeypatch, argv):
    sw = script_module("strain_window")
    assert exit_code(sw, argv, monkeypatch) == 2


def test_part_differences():
    """τ difference over hypot of the σ; ln S_c difference over hypot of the relative σ."""
    sw = script_module("strain_window")
    first, last = (100, 1.5, 0.03, 1e-8, 2e-9), (120, 1.46, 0.04, 4e-8, 1.2e-8)
    d_tau, d_log = sw.part_differences(first, last)
    assert d_tau == f"+0.040 ({0.04 / 0.05:+.1f} σ)"
    assert d_log == f"{np.log(4):+.2f} ({np.log(4) / np.hypot(0.2, 0.3):+.1f} σ)"
    assert sw.part_differences(first, None) == ("—", "—")
    assert sw.part_differences(first, first) == ("—", "—")
