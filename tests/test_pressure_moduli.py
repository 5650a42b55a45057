"""``scripts/pressure_moduli.py`` on real fixed-pressure run directories against an h5py recount
of their traces, with its refusals (exit code 2). The increment correlation it prints is the
library's (``tests/analysis/test_moduli.py``)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from script_helpers import script_module
from trace_recount import finished_samples


@pytest.fixture(scope="module")
def pm():
    return script_module("pressure_moduli")


def recount_moments(run, dgamma: float, lag: int) -> tuple[float, float, float, float, int,
                                                           int, float]:
    """From the sample files alone: ``⟨μ_1²⟩`` at ``lag`` (overlapping differences between
    jammed minima, ``σ = Σ/V`` with ``V = L³ φ_start / φ_row``), the plastic share of ``Σ ΔΣ²``,
    the fraction of unflagged steps whose stress falls and of those the fraction without FIRE
    iterations (all at lag 1), the packings, and the unflagged steps without FIRE iterations
    with the fraction of them whose stress falls."""
    per_sample, sq_all, sq_plastic, unflagged, falls, smooth = [], 0.0, 0.0, 0, 0, 0
    branch, branch_falls = 0, 0
    files = finished_samples(run)
    for f in files:
        with h5py.File(f, "r") as h5:
            sigma = h5["trace/shear_stress"][()] / (
                h5.attrs["box_length"] ** 3 * h5.attrs["phi_actual"] / h5["trace/phi"][()])
            jm = h5["trace/jammed"][()].astype(bool)
            pl = h5["trace/plastic"][()].astype(bool)
            fire = h5["trace/iterations"][()]
        vals = []
        for k in range(sigma.size - lag):
            if jm[k:k + lag + 1].all():
                vals.append(((sigma[k + lag] - sigma[k]) / (lag * dgamma)) ** 2)
        if vals:
            per_sample.append(np.mean(vals))
        for k in range(1, sigma.size):
            if jm[k - 1] and jm[k]:
                d = sigma[k] - sigma[k - 1]
                sq_all += d * d
                if pl[k]:
                    sq_plastic += d * d
                else:
                    unflagged += 1
                    falls += d < 0
                    smooth += d < 0 and fire[k] == 0
                    branch += fire[k] == 0
                    branch_falls += d < 0 and fire[k] == 0
    return (float(np.mean(per_sample)), sq_plastic / sq_all, falls / unflagged,
            smooth / falls if falls else float("nan"), len(files), branch,
            branch_falls / branch if branch else float("nan"))


def test_real_runs_against_a_recount_and_refusals(pm, pressure_runs_by_size, tmp_path, capsys):
    runs = pressure_runs_by_size
    two = [str(runs[16]), str(runs[24])]
    for argv in ([str(tmp_path)], [*two, "--lags", "1", "5", "2"],
                 [*two, "--fit-max-lag", "3"], [*two, "--lags", "1", "2", "--fit-max-lag", "1"],
                 [*two, "--lags", "1", "500"],  # 200 steps: a lag beyond the trace
                 [*two, "--figure", str(tmp_path / "f.txt")],
                 [*two, "--figure", str(runs[16] / "f.png")],
                 [*two, "--figure-branches", str(runs[24] / "f.png")]):
        with pytest.raises(SystemExit) as err:
            pm.main(argv)
        assert err.value.code == 2
    capsys.readouterr()
    figure = tmp_path / "moduli.png"
    branches = tmp_path / "branches.png"
    assert pm.main([*two, "--lags", "1", "2", "5", "--fit-max-lag", "5",
                    "--figure", str(figure), "--figure-branches", str(branches),
                    "--figure-parts", str(tmp_path / "parts.png")]) == 0
    assert figure.stat().st_size > 0 and branches.stat().st_size > 0
    assert (tmp_path / "parts.png").stat().st_size > 0
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if line.startswith("| 0.001 |")]
    rows = [line for line in lines if line.count("|") == 18]
    splits = [line for line in lines if line.count("|") == 12]
    assert len(rows) == 2 and len(splits) == 2
    for row, split in zip(rows, splits, strict=True):
        # the second table: ρ as in the first, and its four parts sum to it (to their rounding)
        rho = float(row.strip("|").split("|")[9])
        cells = [c.strip() for c in split.strip("|").split("|")]
        values = [float(c.split("±")[0]) for c in cells[3:8]]
        sds = [float(c.split("±")[1]) for c in cells[3:8]]
        assert int(cells[1]) == int(row.strip("|").split("|")[1]) and values[0] == rho
        assert sum(values[1:]) == pytest.approx(rho, abs=2.5e-3)
        assert all(sd >= 0 for sd in sds) and sds[0] > 0  # over resampled packings
        assert int(cells[8]) >= 0 and all(0 <= float(c) <= 1 for c in cells[9:11])
    for n, row in zip((16, 24), rows, strict=True):
        cells = [c.strip() for c in row.strip("|").split("|")]
        mu1_sq, share, falls, smooth, packings, branch, branch_falls = recount_moments(
            runs[n], 1e-3, 1)
        assert int(cells[1]) == n and int(cells[2]) == packings
        assert float(cells[4]) == pytest.approx(mu1_sq, rel=1e-3)
        assert float(cells[11]) == pytest.approx(share, abs=1e-3)
        assert float(cells[12]) == pytest.approx(falls, abs=1e-3)
        assert float(cells[13]) == pytest.approx(smooth, abs=1e-3, nan_ok=True)
        assert float(cells[14]) == pytest.approx(1e-3 * n * n)
        assert int(cells[15]) == branch
        assert float(cells[16]) == pytest.approx(branch_falls, abs=1e-3, nan_ok=True)
        mu1_sq_2 = recount_moments(runs[n], 1e-3, 2)[0]
        assert float(cells[7]) == pytest.approx(np.log2(mu1_sq_2 / mu1_sq), abs=2e-3)


def recount_coarse_rho(run, k: int) -> float:
    """ρ of the increments every ``k``-th row, by plain loops over the sample files: a coarse
    step ``K`` (rows ``(K−1)k → Kk``) counts when every fine minimum from row ``(K−2)k + 1`` (row
    0 for the first) to ``Kk`` is jammed; each sample's mean coarse increment removed."""
    num = sa = sb = 0.0
    for f in finished_samples(run):
        with h5py.File(f, "r") as h5:
            sigma = h5["trace/shear_stress"][()] / (
                h5.attrs["box_length"] ** 3 * h5.attrs["phi_actual"] / h5["trace/phi"][()])
            jm = h5["trace/jammed"][()].astype(bool)
        rows = (sigma.size - 1) // k
        ok = [bool(jm[max(0, (big - 2) * k + 1) if big > 1 else 0: big * k + 1].all())
              for big in range(1, rows + 1)]
        d = [sigma[big * k] - sigma[(big - 1) * k] for big in range(1, rows + 1)]
        mean = sum(x for x, o in zip(d, ok, strict=True) if o) / max(1, sum(ok))
        for i in range(rows - 1):
            if ok[i] and ok[i + 1]:
                a, b = d[i] - mean, d[i + 1] - mean
                num, sa, sb = num + a * b, sa + a * a, sb + b * b
    return num / np.sqrt(sa * sb)


def test_coarse_rows_against_a_recount(pm, pressure_runs_by_size, capsys):
    runs = pressure_runs_by_size
    assert pm.main([str(runs[24]), "--lags", "1", "2", "--fit-max-lag", "2",
                    "--coarse", "2", "3"]) == 0
    out = capsys.readouterr().out
    for k in (2, 3):
        (row,) = [line for line in out.splitlines() if line.startswith(f"| 0.001 | 24 | {k} × ")]
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert float(cells[3]) == pytest.approx(recount_coarse_rho(runs[24], k), abs=6e-4)
        assert sum(float(c) for c in cells[4:8]) == pytest.approx(float(cells[3]), abs=2.5e-3)
    with pytest.raises(SystemExit) as err:
        pm.main([str(runs[24]), "--coarse", "1"])
    assert err.value.code == 2
