"""A step the Newton relaxer continued can still be a jump (``docs/aqs.md``, "Jumps Newton
continued through").

The fixture is a minimum of a finished study (``tests/data/continued/README.md``): three steps
after it the Newton relaxer solves the step's every inner problem from the previous minimum's
contact network (no FIRE), which the ``continued``/``located`` rules took to mean a kink, yet the
step crosses an instability and lands in its post-event minimum. The independent verdict is the
chain's: the same run with every candidate redone in 16 pieces (``confirm="chain"``,
``confirm_below=inf``), which finds one piece keeping most of the step's residual.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jamlab.spheres.io import read_packing
from jamlab.spheres.pressure_shear import shear_at_pressure

FIXTURE = Path(__file__).resolve().parents[1] / "data" / "continued" / "n250-p1e-3-step976.h5"
STEP = 3  # the step 976 → 979 of the study is the third after the fixture's minimum


@pytest.fixture(scope="module")
def runs():
    start = read_packing(FIXTURE)
    kw = dict(pressure=1e-3, n_steps=5)
    return {
        "default": shear_at_pressure(start, 1e-5, **kw),
        # deferred (the default): redone after the last step, so the rows are the same
        "chain": shear_at_pressure(start, 1e-5, confirm="chain", confirm_below=math.inf, **kw),
    }


def test_a_jump_newton_continued_through_is_plastic(runs):
    default, chain = runs["default"], runs["chain"]
    for k in ("enthalpy", "shear_stress", "box_length", "jammed"):
        np.testing.assert_array_equal(default[k], chain[k])
    h, s, g = default["enthalpy"], default["shear_stress"], default["gamma"]
    r = np.diff(h) - np.diff(g) * s[:-1] - 0.5 * np.diff(g) * np.diff(s)
    # the step is a candidate Newton continued (no FIRE), between jammed minima
    assert default.continued[STEP] and default["iterations"][STEP] == 0
    assert abs(r[STEP - 1]) > 100 * default.attrs["plastic_threshold"]
    assert default["jammed"][STEP - 1] and default["jammed"][STEP]
    # redone in 16 pieces it is a jump (the chain's verdict, computed independently of the
    # released-enthalpy bound that flags it in the default run)
    assert chain.confirmed[STEP]
    assert chain["plastic"][STEP] and default["plastic"][STEP]
    assert default.attrs["n_candidates_continued_sure"] == 1
    # every flag of the default run is the chain's
    np.testing.assert_array_equal(default["plastic"], chain["plastic"])


SMALL = Path(__file__).resolve().parents[1] / "data" / "continued" / "n500-p1e-3-step101.h5"


def largest_piece_residual(start, pieces: int) -> float:
    """The step ``δγ = 1e-5`` from ``start`` redone as a fixed-pressure run of ``pieces`` steps
    of ``δγ/pieces``: the largest ``|trapezoid residual|`` of its pieces."""
    c = shear_at_pressure(start, 1e-5 / pieces, pressure=1e-3, n_steps=pieces).columns
    h, s, g = c["enthalpy"], c["shear_stress"], c["gamma"]
    return float(np.max(np.abs(np.diff(h) - np.diff(g) * s[:-1] - 0.5 * np.diff(g) * np.diff(s))))


def test_a_small_jump_under_a_large_stress_drop_is_plastic():
    # tests/data/continued/README.md: the first step from the fixture releases ≈ 1.5e-10 ε in
    # one piece, a quarter of its residual; the chain's share called it a kink
    start = read_packing(SMALL)
    run = shear_at_pressure(start, 1e-5, pressure=1e-3, n_steps=30)
    h, s, g = run["enthalpy"], run["shear_stress"], run["gamma"]
    r1 = h[1] - h[0] - 1e-5 * s[0] - 0.5 * (g[1] - g[0]) * (s[1] - s[0])
    assert run["jammed"][0] and run["jammed"][1]
    assert abs(r1) > 10 * run.attrs["plastic_threshold"]
    # independent of the chain's code: the step redone as runs of 16 and 64 pieces; one piece
    # keeps the same residual at both lengths (a kink's would fall 4–16-fold), under |r|/4
    at16, at64 = largest_piece_residual(start, 16), largest_piece_residual(start, 64)
    assert at16 < 0.25 * abs(r1) and 0.9 < at64 / at16 < 1.2
    assert at64 > run.attrs["plastic_threshold"]
    # the chain calls it a kink; its largest piece redone in four holds ≈ the 64-piece residual
    assert not run.confirmed[1]
    assert run.held[1] == pytest.approx(at64, rel=0.05)
    assert run["plastic"][1]
    assert run.attrs["n_candidates_held"] >= 1
