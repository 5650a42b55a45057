"""Where a fixed-pressure AQS step starts its box side (``volume_guess``): the rule by hand
arithmetic, the guess each step of a run received against the run's own rows, resume checks and
refusals."""

from __future__ import annotations

import numpy as np
import pytest

import jamlab.spheres.pressure_shear as ps
from jamlab.spheres import jam
from jamlab.spheres.barostat import box_side_guess

DG = 1e-4
P = 1e-4


def test_box_side_guess_by_hand():
    g, length, s = (0.0, DG), (10.0, 10.001), (2.0, 3.0)
    # r = h1 − h0 − δγ s0 − ½ δγ (s1 − s0): zero for h1 = h0 + δγ (s0 + s1)/2
    smooth = (1.0, 1.0 + DG * 2.5)
    jump = (1.0, 1.0 + DG * 2.5 - 2e-9)  # |r| = 2e-9 > 0.1 δγ² = 1e-9
    kink = (1.0, 1.0 + DG * 2.5 - 0.5e-9)  # |r| = 5e-10 ≤ 1e-9: not a candidate
    extrapolated = 2 * 10.001 - 10.0
    assert box_side_guess("elastic", g, smooth, s, length, 0.1) == extrapolated
    assert box_side_guess("elastic", g, kink, s, length, 0.1) == extrapolated
    assert box_side_guess("elastic", g, jump, s, length, 0.1) is None
    assert box_side_guess("always", g, jump, s, length, 0.1) == extrapolated
    assert box_side_guess("never", g, smooth, s, length, 0.1) is None
    with pytest.raises(ValueError, match="volume_guess must be"):
        box_side_guess("sometimes", g, smooth, s, length, 0.1)


@pytest.fixture(scope="module")
def packing():
    r = jam(128, 3, seed=2, p_target=1e-4)
    assert r.ok
    return r.packing


def guesses(monkeypatch, packing, rule: str, n_steps: int = 60):
    """The run (no confirmation: every minimisation is a step's) and the box side each step
    started from (``None``: the current side), recorded by a spy on ``minimize_step``."""
    seen = []
    real = ps.minimize_step

    def spy(sheared, parent, pressure, kw, length_guess, slope_guess):
        seen.append(length_guess)
        return real(sheared, parent, pressure, kw, length_guess, slope_guess)

    monkeypatch.setattr(ps, "minimize_step", spy)
    run = ps.shear_at_pressure(packing, DG, pressure=P, n_steps=n_steps, volume_guess=rule,
                               confirm_substeps=0)
    assert len(seen) == n_steps
    return run, seen


def test_each_step_starts_where_the_rule_says(monkeypatch, packing):
    run, seen = guesses(monkeypatch, packing, "elastic")
    h, s, g, length = (run[k] for k in ("enthalpy", "shear_stress", "gamma", "box_length"))
    assert seen[0] is None  # the first step has one minimum behind it
    candidates = 0
    for n in range(2, len(g)):
        step = g[n - 1] - g[n - 2]
        r = h[n - 1] - h[n - 2] - step * s[n - 2] - 0.5 * step * (s[n - 1] - s[n - 2])
        if abs(r) > ps.PLASTIC_FLOOR * step**2:  # the last step was a candidate jump
            candidates += 1
            assert seen[n - 1] is None, n
        else:
            assert seen[n - 1] == 2.0 * length[n - 1] - length[n - 2], n
    assert 0 < candidates < len(g) - 2  # both kinds of step occur
    assert run.attrs["volume_guess"] == "elastic"


@pytest.mark.parametrize("rule", ["always", "never"])
def test_the_other_rules(monkeypatch, packing, rule):
    run, seen = guesses(monkeypatch, packing, rule, n_steps=20)
    length = run["box_length"]
    expected = [None] + [None if rule == "never" else 2.0 * length[n - 1] - length[n - 2]
                         for n in range(2, 21)]
    assert seen == expected and run.attrs["volume_guess"] == rule


def test_the_default_is_elastic_and_resuming_with_another_rule_is_refused(packing):
    part = ps.shear_at_pressure(packing, DG, pressure=P, n_steps=3)
    assert part.attrs["volume_guess"] == "elastic"
    with pytest.raises(ValueError, match="volume_guess='never' differs"):
        ps.shear_at_pressure(part.packing, DG, pressure=P, n_steps=6, volume_guess="never",
                             previous=part.trace())
    legacy = part.trace()
    del legacy.attrs["volume_guess"]  # a trace made before the option: the rule "always"
    with pytest.raises(ValueError, match="differs from the run being resumed \\('always'\\)"):
        ps.shear_at_pressure(part.packing, DG, pressure=P, n_steps=6, previous=legacy)
    with pytest.raises(ValueError, match="volume_guess must be"):
        ps.shear_at_pressure(packing, DG, pressure=P, n_steps=2, volume_guess="sometimes")


def test_aqs_shear_passes_the_rule_and_refuses_it_at_constant_volume(packing):
    from jamlab.spheres import aqs

    t = aqs.shear(packing, DG, n_steps=2, pressure=P, volume_guess="never").trace
    assert t.attrs["volume_guess"] == "never"
    assert aqs.shear(packing, DG, n_steps=2, pressure=P).trace.attrs["volume_guess"] == "elastic"
    with pytest.raises(ValueError, match="volume_guess applies to fixed-pressure"):
        aqs.shear(packing, DG, n_steps=2, volume_guess="never")
    assert np.isfinite(t.energy).all()
