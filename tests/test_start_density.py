"""``scripts/start_density.py``: a run's packings read as the trace holds them (φ of the first
and last rows straight from the sample files, sizes as the report counts them), the rank
correlations against a hand computation, the halves' split against a count by hand, and bad
arguments exit with code 2."""

from __future__ import annotations

import glob

import h5py
import numpy as np
import pytest
from scipy import stats
from tests.script_helpers import exit_code, script_module


@pytest.fixture(scope="module")
def sd():
    return script_module("start_density")


def _ranks(x):
    # average ranks of ties, by hand
    x = np.asarray(x, dtype=float)
    r = np.empty(x.size)
    for i, v in enumerate(x):
        r[i] = np.sum(x < v) + (np.sum(x == v) + 1) / 2.0
    return r


def test_rank_correlations_against_pearson_of_ranks(sd):
    phi0 = np.array([0.638, 0.640, 0.639, 0.637, 0.641, 0.6395])
    sizes = (np.array([1e-6, 3e-6]), np.array([]), np.array([2e-7]), np.array([5e-6, 1e-7]),
             np.array([4e-7]), np.array([2e-6, 2e-6]))
    p = sd.Packings(phi0, phi0 + np.array([3e-4, -1e-4, 0.0, 9e-4, -2e-4, 1e-4]), sizes)
    s = sd.summary(p, 1e-6)
    assert s["smax"].tolist() == [3e-6, 0.0, 2e-7, 5e-6, 4e-7, 2e-6]
    assert s["count"].tolist() == [2, 0, 0, 1, 0, 2]
    for key, y in (("smax", s["smax"]), ("total", s["total"]), ("count", s["count"]),
                   ("dphi", p.phi_end - p.phi_start)):
        rho = np.corrcoef(_ranks(phi0), _ranks(y))[0, 1]
        assert s[f"rho_{key}"][0] == pytest.approx(rho, abs=1e-12)


def test_halves_count_by_hand_and_binomial(sd):
    phi0 = np.array([0.64, 0.62, 0.63, 0.65, 0.61, 0.66, 0.635])  # 7: the 3 loosest are a half
    count = np.array([1, 4, 0, 2, 3, 0, 5])
    loose, dense, pval = sd.halves(phi0, count)
    assert (loose, dense) == (4 + 0 + 3, 1 + 2 + 0 + 5)
    assert pval == pytest.approx(stats.binomtest(7, 15, 3 / 7).pvalue)
    assert sd.halves(phi0, np.zeros(7, dtype=int)) == (0, 0, 1.0)


def test_reads_first_and_last_phi_and_the_counted_sizes(sd, small_pressure_run):
    from jamlab.reproduce.ensembles import avalanche_set
    from jamlab.runs import open_run

    p = sd.read_run(small_pressure_run, 16)
    files = sorted(glob.glob(str(small_pressure_run / "samples" / "*" / "*" / "*.h5")))
    first, last = [], []
    for f in files:
        with h5py.File(f) as h:
            phi = h["trace"]["phi"][:]
            first.append(phi[0])
            last.append(phi[-1])
    assert p.phi_start.tolist() == first and p.phi_end.tolist() == last
    want = avalanche_set(open_run(small_pressure_run), "jamming", 16).per_sample
    assert len(p.sizes) == len(want) == 3
    assert all(np.array_equal(a, b) for a, b in zip(p.sizes, want, strict=True))


@pytest.mark.parametrize("argv", [
    ["RUN", "RUN", "--n", "16", "16", "16"],
    ["RUN", "--n", "16", "--above", "0"],
    ["RUN", "--n", "16", "--largest", "-1"],
    ["RUN", "--n", "32"],
    ["missing-run-dir", "--n", "16"],
])
def test_bad_arguments_exit_2(sd, small_pressure_run, monkeypatch, argv):
    argv = [str(small_pressure_run) if x == "RUN" else x for x in argv]
    assert exit_code(sd, argv, monkeypatch) == 2
