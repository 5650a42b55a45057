"""``scripts/project_cost.py``: the power-law fit and the CPU-hour sum, against hand arithmetic."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "project_cost.py"


@pytest.fixture(scope="module")
def pc():
    spec = importlib.util.spec_from_file_location("project_cost", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_power_law_recovers_an_exact_law(pc):
    a, b = pc.power_law([250, 500, 1000], [2e-6 * n**1.5 for n in (250, 500, 1000)])
    assert a == pytest.approx(2e-6, rel=1e-10) and b == pytest.approx(1.5, rel=1e-12)
    assert pc.power_law([100], [0.3]) == pytest.approx((0.003, 1.0))


def test_projection_by_hand(pc):
    # step time 1 ms × (N/250)^2, jam 2 s × N/250, to-pressure 1 s × N/250, at N = 250 and 500
    res = []
    for n in (250, 500):
        k = n / 250
        res.append({
            "N": n, "jam_s": 2.0 * k, "to_pressure_s": 1.0 * k,
            "constant_volume": {"x": {"ms_per_step": 1.0 * k**2}},
            "fixed_pressure": {"y": {"ms_per_step": 3.0 * k**2}},
        })
    rows = pc.project({"results": res, "pressure": 1e-4}, [1000, 2000], samples=10, steps=100)
    cv = next(r for r in rows if r["code"] == "x")
    fp = next(r for r in rows if r["code"] == "y")
    # N = 1000: k = 4 -> sample = 8 s + 100 × 16 ms = 9.6 s; N = 2000: k = 8 -> 16 + 6.4 = 22.4 s
    assert cv["sample_s_1000"] == pytest.approx(9.6, rel=1e-9)
    assert cv["cpu_h"] == pytest.approx(10 * (9.6 + 22.4) / 3600, rel=1e-9)
    assert cv["exponent"] == pytest.approx(2.0) and cv["extrapolated"]
    # fixed pressure: prep 3 s × k, steps 3 ms × k²: N = 1000 -> 12 + 4.8; N = 2000 -> 24 + 19.2
    assert fp["sample_s_1000"] == pytest.approx(16.8, rel=1e-9)
    assert fp["cpu_h"] == pytest.approx(10 * (16.8 + 43.2) / 3600, rel=1e-9)
