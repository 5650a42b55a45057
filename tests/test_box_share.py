"""``scripts/box_share.py``: the box's share ``c = ½ K ΔV²/V`` of each counted avalanche
recomputed from the sample files (h5py, the particles' own volume), ``K`` against an
independent fixed-box finite difference, and the refusals."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module


@pytest.fixture(scope="module")
def bs():
    return script_module("box_share")


def test_shares_equal_the_sample_files(bs, small_pressure_run):
    r = bs.run_shares(small_pressure_run, 0.05)
    assert r["n"] == 16 and r["K"] > 0
    sizes, shares = [], []
    for f in sorted(small_pressure_run.glob("samples/*/*/sample-*.h5")):
        with h5py.File(f) as h:
            t = {k: h[f"trace/{k}"][:] for k in ("energy_jump", "plastic", "jammed", "phi")}
        counted = (t["plastic"][1:] & t["jammed"][:-1] & t["jammed"][1:]
                   & (t["energy_jump"][1:] < 0))
        vol = 16 * math.pi / 6 / t["phi"]  # monodisperse, diameter 1
        sizes.append(-t["energy_jump"][1:][counted])
        shares.append(0.5 * r["K"] * np.diff(vol)[counted] ** 2 / vol[:-1][counted])
    sizes, shares = np.concatenate(sizes), np.concatenate(shares)
    assert sizes.size > 0
    np.testing.assert_array_equal(r["S"], sizes)
    np.testing.assert_allclose(r["c"], shares, rtol=1e-9)
    assert np.all(r["c"] > 0)  # the box moved at every counted step


def test_bulk_modulus_against_a_fixed_box_difference(bs, small_pressure_run):
    """K from enthalpy minima at p(1 ± 5 %) against −Δp/Δ ln V from two fixed-box FIRE minima
    of the packing at p, compressed and dilated affinely by ±1e-4 in L (another route)."""
    import jamlab.spheres as sp
    from jamlab.runs.load import prepared_packing
    from jamlab.spheres.barostat import minimize_enthalpy
    from jamlab.spheres.fire import minimize

    start = prepared_packing(sorted(small_pressure_run.glob("samples/*/*/sample-*.h5"))[0])
    k, p = bs.bulk_modulus(start, 1e-3, 0.05)
    assert p == pytest.approx(1e-3, rel=1e-8)
    at_p = minimize_enthalpy(start, 1e-3, ftol=1e-13, ptol=1e-9).packing
    eps, got = 1e-4, []
    for s in (1 - eps, 1 + eps):
        box = sp.Box(at_p.box.length * s, at_p.dim, 0.0)
        res = minimize(sp.Packing(at_p.positions * s, box), ftol=1e-13)
        assert res.converged
        got.append(sp.pressure(res.packing))
    k_fd = -(got[1] - got[0]) / (3 * math.log((1 + eps) / (1 - eps)))
    assert k == pytest.approx(k_fd, rel=0.05)


def test_summary_by_hand(bs):
    sizes = np.array([0.5, 2.0, 3.0, 5.0, 20.0])
    share = np.array([0.1, 0.2, 1.5, 0.5, 1.0])
    s = bs.summary(sizes, share, 2.5, 10.0, 1.0)
    assert s["band"]["count"] == 2 and s["below"]["count"] == 1
    assert s["band"]["median"] == pytest.approx(0.5 * (0.5 + 0.1))
    assert s["band"]["leave"] == 1  # 3.0 − 1.5 < 2.5; 5.0 − 0.5 stays
    assert s["below"]["median"] == pytest.approx(0.1)


@pytest.mark.parametrize("args", [["--band", "3e-8", "1e-8"], ["--floor", "0"], ["--dp", "0.7"]])
def test_bad_arguments_exit_2(bs, small_pressure_run, monkeypatch, args):
    assert exit_code(bs, [str(small_pressure_run), *args], monkeypatch) == 2


def test_not_a_run_directory_exits_2(bs, tmp_path, monkeypatch):
    assert exit_code(bs, [str(tmp_path)], monkeypatch) == 2
