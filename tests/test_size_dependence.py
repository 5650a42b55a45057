"""``scripts/size_dependence.py`` on real run directories: its size counts against an h5py
recount, and its refusals (exit code 2). The statistics: tests/analysis/test_size_difference.py."""

from __future__ import annotations

import numpy as np
import pytest

from script_helpers import script_module
from trace_recount import finished_samples, recount, recount_sample


@pytest.fixture(scope="module")
def sd():
    return script_module("size_dependence")


@pytest.fixture(scope="module")
def runs(pressure_runs_by_size):
    return pressure_runs_by_size


def test_real_runs_and_refusals(sd, runs, tmp_path, capsys):
    # exit code 2, one line: not a run directory; one size only; bad --boot, --window, shapes
    two = [str(runs[16]), str(runs[24])]
    for argv in ([str(tmp_path)], [str(runs[16])], [*two, "--boot", "1"], [*two, "--window", "0"],
                 [*two, "--free-shapes", "--shape-grid", "0.5", "-1"]):
        with pytest.raises(SystemExit) as err:
            sd.main(argv)
        assert err.value.code == 2
    # two sizes: a row for p = 0.001 whose size counts are the h5py recount's in the window
    # (checked only where each size has the 10 sizes a fit needs)
    from jamlab.reproduce.measurements import avalanche_set
    from jamlab.runs import open_run

    counts = [sum(a.size for a in avalanche_set(open_run(runs[n]), "jamming", n).per_sample)
              for n in (16, 24)]
    assert counts == [recount(runs[16]).size, recount(runs[24]).size]
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
    for cell, n in zip(cells[2].split(";"), (16, 24), strict=True):
        assert int(cell.split(":")[0]) == n
        k, tail = (int(v) for v in cell.split(":")[1].split(",")[:2])
        s = recount(runs[n])
        assert k == len(finished_samples(runs[n]))
        assert np.count_nonzero(s >= x_min * 1.001) <= tail <= np.count_nonzero(s >= x_min * 0.999)


def test_the_report_rows_difference_is_the_packings(runs):
    """``with_cutoff`` of two sizes carries τ(24) − τ(16) in its window with the packings
    resampled, from the packings recounted here with h5py; its report row is judged against 0;
    without a bootstrap none is made."""
    from dataclasses import replace

    from jamlab.analysis import size_difference
    from jamlab.reproduce.measurements import tau_estimate, with_cutoff
    from jamlab.reproduce.scales import SCALES
    from jamlab.reproduce.table import pressure_tau_rows
    from jamlab.runs import open_run

    scale = replace(SCALES["medium"], n_boot=50)
    sources = [(open_run(runs[n]), n) for n in (16, 24)]
    est = with_cutoff(tau_estimate("jamming", sources, scale), sources, scale)
    per_file = {n: [recount_sample(f) for f in finished_samples(runs[n])]
                for n in (16, 24)}
    cut = est.cutoff
    assert cut is not None
    got = est.size_difference
    if min(np.count_nonzero(np.concatenate(v) >= cut.x_min) for v in per_file.values()) < 10:
        assert got is None  # (another machine's trajectories may leave too few in the window)
        return
    want = size_difference(per_file, cut.x_min, 50, scale.seed)
    assert got.n == (16, 24) and got.packings == want.packings and got.tails == want.tails
    assert got.tau == pytest.approx(want.tau) and got.boot_sigma == pytest.approx(want.boot_sigma)
    row = pressure_tau_rows({1e-3: est})[-1]
    assert row.quantity.startswith("τ(N = 24) − τ(N = 16) at fixed pressure p = 0.001")
    assert row.value == got.delta and row.error == got.boot_sigma
    assert row.verdicts[0].startswith("no size dependence: ")
    none = with_cutoff(est, sources, replace(scale, n_boot=0))
    assert none.size_difference is None and len(pressure_tau_rows({1e-3: none})) == 3


def test_coarse_steps_table_and_refusals(sd, runs, capsys):
    """``--coarse 2``: the k = 1 row is the main table's τ, the k = 2 row is each size's sizes
    grouped two steps at a time (``coarse_avalanches``, whose per-sample sizes pooled are its
    sizes) fitted in the same window, the last row 2 τ(δγ) − τ(2 δγ); --coarse without 2 is
    refused (exit 2)."""
    from jamlab.analysis import fit_cutoff_power_law
    from jamlab.reproduce.ensembles import coarse_avalanches
    from jamlab.runs import open_run

    for argv in (["--coarse", "3"], ["--coarse", "1", "2"]):
        with pytest.raises(SystemExit) as err:
            sd.main([str(runs[16]), str(runs[24]), "--boot", "4", *argv])
        assert err.value.code == 2
    capsys.readouterr()
    two = {n: coarse_avalanches(open_run(runs[n]), "jamming", n, 2) for n in (16, 24)}
    for c in two.values():
        np.testing.assert_array_equal(np.concatenate(c.per_sample), c.sizes)
    try:
        sd.main([str(runs[16]), str(runs[24]), "--boot", "20", "--coarse", "2"])
    except SystemExit as err:  # too few avalanches in the window at this tiny size
        assert err.value.code == 2
        return
    out = capsys.readouterr().out.splitlines()
    x_min = float(next(ln for ln in out if ln.startswith("p = 0.001, the same window")).split()[6])
    rows = {ln.split("|")[1].strip(): ln for ln in out if ln.startswith("| 1 δγ")
            or ln.startswith("| 2 δγ") or ln.startswith("| δγ → 0")}
    main = next(ln for ln in out if ln.startswith("| 0.001 |"))
    tau1 = [float(c.split(",")[2].split("±")[0]) for c in main.split("|")[3].split(";")]
    got1 = [float(v) for v in rows["1 δγ"].split("|")[2:4]]
    got2 = [float(v) for v in rows["2 δγ"].split("|")[2:4]]
    assert got1 == tau1
    for n, g in zip((16, 24), got2, strict=True):
        want = fit_cutoff_power_law(two[n].sizes, x_min).tau  # x_min printed to 3 digits
        assert abs(g - want) < 0.02


def test_shapes_table_and_refusals(sd, runs, capsys):
    """``--shapes``: the a = 1 row is the main table's τ; each slope is numpy's weighted line
    (``polyfit`` with weights 1/σ) through ``cutoff_shape_profile``'s τ at that a; bad shapes are
    refused (exit 2)."""
    from jamlab.analysis import cutoff_shape_profile
    from jamlab.reproduce.measurements import avalanche_set
    from jamlab.runs import open_run

    for bad in (["0"], ["0.5", "0.5"], ["-1"]):
        with pytest.raises(SystemExit) as err:
            sd.main([str(runs[16]), str(runs[24]), "--boot", "4", "--shapes", *bad])
        assert err.value.code == 2
    capsys.readouterr()
    try:
        sd.main([str(runs[16]), str(runs[24]), "--boot", "10", "--shapes", "0.5", "1"])
    except SystemExit as err:  # too few avalanches in the window at this tiny size
        assert err.value.code == 2
        return
    out = capsys.readouterr().out.splitlines()
    main = next(ln for ln in out if ln.startswith("| 0.001 |"))
    tau1 = [float(c.split(",")[2].split("±")[0]) for c in main.split("|")[3].split(";")]
    rows = {ln.split("|")[1].strip(): ln.split("|") for ln in out
            if ln.startswith("| 0.5 |") or ln.startswith("| 1 |")}
    assert [float(v) for v in rows["1"][2:4]] == tau1
    x_min = float(next(ln for ln in out if "each size alone" in ln).split()[6].rstrip(","))
    sizes = {n: avalanche_set(open_run(runs[n]), "jamming", n).sizes for n in (16, 24)}
    for name, a in (("0.5", 0.5), ("1", 1.0)):
        prof = [cutoff_shape_profile(sizes[n], x_min, (a,)) for n in (16, 24)]
        tau = [p.taus[0] for p in prof]
        w = [1 / p.tau_stderrs[0] for p in prof]
        slope = np.polyfit(np.log([16, 24]), tau, 1, w=w)[0]
        got = float(rows[name][4].split("±")[0])
        assert abs(got - slope) < 0.002 + 0.01 * abs(slope)  # x_min printed to 3 digits


def test_a_part_of_the_strain_window(sd, runs, capsys):
    """``--steps FIRST LAST``: each packing's avalanches of those steps, against an h5py recount
    of the same steps; the whole window gives the main table unchanged, byte for byte; bad parts
    and ``--coarse`` with it are refused (exit 2)."""
    import argparse

    from jamlab.runs import open_run
    from trace_recount import recount_steps

    two = [str(runs[16]), str(runs[24])]
    for argv in (["--steps", "0", "5"], ["--steps", "5", "4"], ["--steps", "1", "201"],
                 ["--steps", "1", "5", "--coarse", "2"]):
        with pytest.raises(SystemExit) as err:
            sd.main([*two, "--boot", "4", *argv])
        assert err.value.code == 2
    capsys.readouterr()
    for n in (16, 24):
        ds = open_run(runs[n])
        files = finished_samples(runs[n])
        for first, last in ((1, 100), (101, 200), (37, 37)):
            got = sd.steps_part(argparse.ArgumentParser(), runs[n], ds, n, first, last)
            assert len(got) == len(files)
            for a, f in zip(got, files, strict=True):
                np.testing.assert_array_equal(a, recount_steps(f, first, last))
        whole = sd.steps_part(argparse.ArgumentParser(), runs[n], ds, n, 1, 200)
        for a, f in zip(whole, files, strict=True):
            np.testing.assert_array_equal(a, recount_sample(f))
    outs = []
    for extra in ([], ["--steps", "1", "200"]):
        try:
            sd.main([*two, "--boot", "20", *extra])
        except SystemExit as err:  # too few avalanches in the window at this tiny size
            assert err.value.code == 2
            return
        outs.append(capsys.readouterr().out)
    assert outs[1] == "AQS steps 1–200 of every packing only\n\n" + outs[0]


def test_dispersion_table(sd, runs, capsys):
    """``--dispersion``: per N, the packings' count, sizes in the window and the variance / mean
    of their counts, recounted here from the sample files with h5py and numpy."""
    try:
        sd.main([str(runs[16]), str(runs[24]), "--boot", "4", "--dispersion"])
    except SystemExit as err:  # too few avalanches in the window at this tiny size
        assert err.value.code == 2
        return
    out = capsys.readouterr().out.splitlines()
    head = next(ln for ln in out if ln.startswith("p = 0.001, the same window"))
    x_min = float(head.split()[6].rstrip(":"))
    start = out.index(head)
    rows = {int(ln.split("|")[1]): ln for ln in out[start:] if ln[:2] == "| " and
            ln.split("|")[1].strip().isdigit()}
    for n in (16, 24):
        cells = [c.strip() for c in rows[n].strip("|").split("|")]
        per = [recount_sample(f) for f in finished_samples(runs[n])]
        counts = np.array([np.count_nonzero(s >= x_min) for s in per], dtype=float)
        assert int(cells[1].split()[0]) == len(per)
        # x_min is printed to 3 digits: compare the counts away from it
        lo = sum(np.count_nonzero(s >= x_min * 1.001) for s in per if
                 np.count_nonzero(s >= x_min * 1.001) >= 2)
        hi = sum(np.count_nonzero(s >= x_min * 0.999) for s in per)
        assert lo <= int(cells[2]) <= hi
        mean, ratio = (float(v) for v in cells[5].split(",")[:2])
        if np.all(counts == np.array([np.count_nonzero(s >= x_min * 1.001) for s in per])):
            assert mean == pytest.approx(counts.mean(), abs=0.051)
            assert ratio == pytest.approx(counts.var(ddof=1) / counts.mean(), abs=0.0051)
