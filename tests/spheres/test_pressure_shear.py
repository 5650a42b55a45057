"""Fixed-pressure AQS: the pressure at every one of 1000 steps, the trapezoid rule for the
enthalpy (not for the energy), and the recorded columns against independent recomputation."""

from __future__ import annotations

import numpy as np
import pytest
from spheres_brute import brute_force

from jamlab.spheres import jam
from jamlab.spheres.pressure_shear import PRESSURE_COLUMNS, shear_at_pressure
from jamlab.spheres.rigidity import is_jammed

P = 1e-3
DG = 1e-4


@pytest.fixture(scope="module")
def run():
    r = jam(32, 3, seed=1, p_target=1e-4)
    assert r.ok
    return shear_at_pressure(r.packing, DG, n_steps=1000, pressure=P)


def test_pressure_within_tolerance_at_every_step(run):
    c = run.columns
    assert len(c["gamma"]) == 1001
    n = 32
    tol = np.maximum(1e-6 * P, 10 * 1e-12 * n / c["box_length"] ** 3)
    assert np.all(np.abs(c["pressure"] - P) <= tol)
    assert np.all(c["converged"]) and run.n_not_converged == 0
    assert np.all(c["max_force"] < 1e-12)
    assert np.all(c["jammed"])
    np.testing.assert_allclose(c["gamma"], np.arange(1001) * DG + c["gamma"][0], rtol=0, atol=1e-15)
    # the volume moves (dilatancy) while p stays put
    assert np.ptp(c["phi"]) > 1e-4


def test_last_row_against_brute_force(run):
    c = run.columns
    pk = run.packing
    b = brute_force(pk.wrapped().positions, pk.box.length, pk.strain)
    assert c["energy"][-1] == pytest.approx(b["energy"], rel=1e-10)
    assert c["shear_stress"][-1] == pytest.approx(b["shear_stress"], rel=1e-9)
    assert c["pressure"][-1] == pytest.approx(b["pressure"], rel=1e-10)
    assert c["enthalpy"][-1] == pytest.approx(b["energy"] + P * pk.box.length**3, rel=1e-13)
    assert c["phi"][-1] == pytest.approx(32 * np.pi / 6 / pk.box.length**3, rel=1e-14)
    assert c["jammed"][-1] == is_jammed(pk).jammed


def test_trapezoid_rule_holds_for_the_enthalpy_not_the_energy(run):
    c = run.columns
    g, dg = c["gamma"], np.diff(c["gamma"])
    ds = np.diff(c["shear_stress"])
    # from the raw columns, not from the recorded jumps
    r_h = np.diff(c["enthalpy"]) - dg * c["shear_stress"][:-1] - 0.5 * dg * ds
    r_e = np.diff(c["energy"]) - dg * c["shear_stress"][:-1] - 0.5 * dg * ds
    np.testing.assert_allclose(
        c["enthalpy_jump"][1:] - 0.5 * dg * c["stress_jump"][1:], r_h, rtol=0, atol=1e-15
    )
    elastic = ~c["plastic"][1:]
    assert elastic.sum() > 900
    # elastic: O(δγ³) + noise (the bound 0.1 δγ² on |r| is the flag's own rule)
    assert np.median(np.abs(r_h[elastic])) < 1e-10
    # the energy alone misses p ΔV (dilatancy): its residual is orders of magnitude larger
    assert np.median(np.abs(r_e[elastic])) > 1e3 * np.median(np.abs(r_h[elastic]))
    # flagged steps drop below the branch
    pl = c["plastic"][1:]
    assert 1 <= pl.sum() <= run.attrs["n_candidates"]
    assert np.all(np.abs(r_h[pl]) > run.threshold)
    # a confirmed jump: its residual is its own enthalpy drop, r ≈ ΔH = −S (not a kink ~ δγ²)
    big = pl & (np.abs(r_h) > 100 * DG**2)
    assert big.any()
    np.testing.assert_allclose(r_h[big], c["enthalpy_jump"][1:][big], rtol=0.5)
    assert g.size == 1001


def test_trace_view_and_columns(run):
    t = run.trace()
    assert set(PRESSURE_COLUMNS) == set(run.columns)
    np.testing.assert_array_equal(t.energy, run.columns["enthalpy"])
    np.testing.assert_array_equal(t.plastic, run.columns["plastic"])
    assert t.attrs["energy_column"] == "enthalpy"
    assert t.attrs["protocol"] == "fixed-pressure"


def test_bad_input():
    r = jam(32, 3, seed=1, p_target=1e-4)
    with pytest.raises(ValueError, match="exactly one"):
        shear_at_pressure(r.packing, DG, pressure=P)
    with pytest.raises(ValueError, match="dgamma"):
        shear_at_pressure(r.packing, -DG, n_steps=3, pressure=P)
    with pytest.raises(ValueError, match="target pressure"):
        shear_at_pressure(r.packing, DG, n_steps=3, pressure=-1.0)
