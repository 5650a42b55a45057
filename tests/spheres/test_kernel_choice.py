"""The machine's choice between the branchy and the branch-free force kernel
(:mod:`jamlab.spheres.kernel_choice`): the threshold rule on hand-made timing tables, the
environment override, and — what makes a per-machine choice admissible — FIRE's result does not
depend on it, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.spheres import kernel_choice as KC
from jamlab.spheres.fire import minimize


@pytest.fixture
def fresh(monkeypatch):
    """A process without a choice yet (restored afterwards)."""
    monkeypatch.setattr(KC, "_CALIBRATION", None)
    return monkeypatch


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        # branchy faster on 7k and 14k, branch-free from 27k on: midpoint of 14k and 27k
        ([(7000, 1.0, 1.3), (14000, 2.0, 2.6), (27000, 6.0, 4.2), (55000, 15.0, 9.0)],
         int(np.sqrt(14000 * 27000))),
        # the earlier machine: branch-free faster from the shortest list measured
        ([(9000, 1.3, 1.0), (18000, 3.0, 2.0)], 6000),
        # never faster: never taken
        ([(7000, 1.0, 1.3), (55000, 10.0, 11.0)], KC.NEVER),
        # faster on one middle size only (noise), not on the longest: never
        ([(7000, 1.0, 1.3), (14000, 2.0, 1.5), (27000, 4.0, 4.1)], KC.NEVER),
        # a win inside the margin does not count; order of the rows does not matter
        ([(27000, 6.0, 4.0), (14000, 2.0, 1.97), (7000, 1.0, 1.3)], int(np.sqrt(14000 * 27000))),
        ([], KC.NEVER),
    ],
)
def test_threshold_rule(table, expected):
    assert KC.choose_threshold(table) == expected


def test_environment_override(fresh):
    fresh.setenv(KC.ENV, "branchy")
    assert KC.threshold_for(10**6) == KC.NEVER
    fresh.setattr(KC, "_CALIBRATION", None)
    fresh.setenv(KC.ENV, "branch-free")
    assert KC.threshold_for(10**6) == KC.CALIBRATE_ABOVE
    assert KC.threshold_for(KC.CALIBRATE_ABOVE) == KC.NEVER  # short lists: never measured
    fresh.setattr(KC, "_CALIBRATION", None)
    fresh.setenv(KC.ENV, "fastest")
    with pytest.raises(ValueError, match="JAMLAB_FORCE_KERNEL"):
        KC.threshold_for(10**6)
    with pytest.raises(ValueError, match="fixed kernel choice"):
        KC.fixed("auto")
    KC.use(KC.fixed("branchy"))  # what a benchmark timing both kernels does
    assert KC.threshold_for(10**6) == KC.NEVER


def test_lists_without_a_branch_free_twin_do_not_calibrate(fresh):
    """Short lists, 2D lists and non-harmonic laws always take the branchy kernel."""
    fresh.setattr(KC, "calibrate", lambda *a, **k: pytest.fail("calibrated needlessly"))
    fresh.delenv(KC.ENV, raising=False)
    assert KC.threshold_for(KC.CALIBRATE_ABOVE) == KC.NEVER
    assert KC.threshold_for(10**6, dim=2) == KC.NEVER
    assert KC.threshold_for(10**6, dim=3, alpha=2.5) == KC.NEVER


def test_calibration_measures_both_kernels():
    cal = KC.calibrate(sizes=(2800, 4000), rounds=1)
    pairs = [p for p, _, _ in cal.table]
    assert pairs == sorted(pairs) and pairs[0] > KC.CALIBRATE_ABOVE  # the lists the rule needs
    assert all(np.isfinite(t) and t > 0 for _, *ts in cal.table for t in ts)
    assert cal.threshold == KC.choose_threshold(cal.table)
    assert "branch-free force kernel" in cal.describe()


def test_fire_result_does_not_depend_on_the_choice(fresh):
    """The same FIRE run with every list on the branchy kernel and with every long list on the
    branch-free one: the same iterations, energy and positions, bit for bit."""
    pk = sp.random_packing(1600, 3, 0.70, 3)  # ≈ 7k pairs at skin 0.2: above CALIBRATE_ABOVE
    out = {}
    for mode in ("branchy", "branch-free"):
        fresh.setattr(KC, "_CALIBRATION", None)
        fresh.setenv(KC.ENV, mode)
        nl = sp.NeighborList(pk)
        assert nl.nbr.size > KC.CALIBRATE_ABOVE
        out[mode] = minimize(pk, ftol=1e-6, max_iter=400, neighbors=nl)
    a, b = out["branchy"], out["branch-free"]
    assert a.iterations == b.iterations and a.energy == b.energy
    assert np.array_equal(a.packing.positions, b.packing.positions)


def test_command_line_refuses_a_bad_environment_value_before_any_work(monkeypatch, capsys):
    from jamlab.cli import main

    monkeypatch.setenv(KC.ENV, "fastest")
    with pytest.raises(SystemExit) as exc:
        main(["theory", "--help"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jamlab: error: JAMLAB_FORCE_KERNEL must be")
