"""Cross-check against a live LAMMPS (skipped when LAMMPS is not installed; see
``benchmarks/bench_engine.py`` for how it is found and the full comparison)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.spheres.fire import minimize

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_engine.py"


def _bench():
    spec = importlib.util.spec_from_file_location("bench_engine", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


bench = _bench() if BENCH.is_file() else None
LMP = bench.find_lammps() if bench else None
pytestmark = [
    pytest.mark.lammps,
    pytest.mark.skipif(LMP is None, reason="LAMMPS not installed (LAMMPS_BIN, /tmp/lmpvenv)"),
]


@pytest.mark.parametrize("strain", [0.0, 0.3, 1.3])
def test_energy_stress_pressure_match_lammps(tmp_path, strain):
    p = minimize(sp.random_packing(300, 3, 0.8, seed=4), ftol=1e-4).packing
    p = sp.affine_shear(p, strain)
    lm = bench.run_lammps(LMP, p, None, tmp_path)
    assert sp.energy(p) == pytest.approx(lm["energy"], rel=1e-12)
    assert sp.shear_stress(p) == pytest.approx(lm["shear_stress"], rel=1e-12)
    assert sp.pressure(p) == pytest.approx(lm["pressure"], rel=1e-12)


def test_same_minimum_after_small_kick(tmp_path):
    p = sp.affine_shear(sp.random_packing(300, 3, 0.8, seed=5), 0.3)
    lm = bench.run_lammps(LMP, p, 1e-13, tmp_path)
    q = lm["packing"]
    q = q.with_positions(q.positions + np.random.default_rng(1).normal(0, 1e-6, (q.n, 3)))
    r = minimize(q)
    assert r.converged
    assert r.energy == pytest.approx(lm["energy"], rel=1e-10)
