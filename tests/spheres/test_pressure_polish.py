"""A fixed-pressure minimum as the trace records it (``barostat.polish_recorded``): the minimisers
accept ``max|F_i| < ftol`` on their own coordinates, the trace evaluates the force afresh from the
stored positions, and the two can differ at rounding level across ``ftol``. A minimum that reads
``≥ ftol`` is relaxed further, and a row that still reads ``≥ ftol`` is never called converged.
Checked against brute-force forces and pressure (``spheres_brute``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from spheres_brute import brute_force

import jamlab.spheres.pressure_shear as pressure_shear
from jamlab.spheres import jam
from jamlab.spheres.barostat import POLISH_COUNT, minimize_enthalpy, polish_recorded
from jamlab.spheres.fire import FireParameters

P, FTOL = 1e-4, 1e-12
KW = dict(ftol=FTOL, ptol=1e-6, max_iter=1_000_000, params=FireParameters(), relax=None)


def brute(packing):
    pk = packing.wrapped()
    return brute_force(pk.positions, pk.box.length, pk.strain)


def max_force(b) -> float:
    return float(np.sqrt((b["forces"] ** 2).sum(axis=1)).max())


@pytest.fixture(scope="module")
def minimum():
    r = jam(32, 3, seed=1, p_target=1e-4)
    assert r.ok
    res = minimize_enthalpy(r.packing, P, **KW)
    assert res.converged and max_force(brute(res.packing)) < FTOL
    return res


def nudged(res, force: float):
    """``res`` with one backbone particle moved so that its force reads ≈ ``force``, still
    claiming convergence (what a minimiser's rounding can leave, magnified)."""
    pk = res.packing
    b = brute(pk)
    i = int(np.argmax(np.abs(b["forces"]).sum(axis=1) > 0))  # a particle with contacts
    pos = pk.positions.copy()
    pos[i, 0] += force  # contact stiffness ≈ 1 (harmonic, D = 1): δF ≈ δx per contact
    moved = pk.with_positions(pos)
    assert max_force(brute(moved)) >= FTOL
    return replace(res, packing=moved, converged=True)


def test_a_minimum_reading_above_ftol_is_polished(minimum):
    bad = nudged(minimum, 3e-12)
    out, runs = polish_recorded(bad, KW)
    b = brute(out.packing)
    assert runs == 1 and out.converged
    assert max_force(b) < FTOL and out.max_force < FTOL
    v = out.packing.box.volume
    assert abs(b["pressure"] - P) <= out.tolerance
    assert out.pressure == pytest.approx(b["pressure"], rel=1e-10)
    assert out.enthalpy == pytest.approx(b["energy"] + P * v, rel=1e-12)
    assert out.iterations > minimum.iterations
    assert np.abs(out.packing.positions - bad.packing.positions).max() < 1e-9  # a polish only


def test_a_clean_or_failed_minimum_is_returned_as_it_is(minimum):
    out, runs = polish_recorded(minimum, KW)
    assert out is minimum and runs == 0
    failed = replace(nudged(minimum, 3e-12), converged=False)
    out, runs = polish_recorded(failed, KW)
    assert out is failed and runs == 0


def test_a_polish_that_cannot_finish_is_not_converged(minimum):
    out, runs = polish_recorded(nudged(minimum, 3e-12), {**KW, "max_iter": 0})
    assert runs == 1 and not out.converged  # FIRE did not converge: no second run
    assert max_force(brute(out.packing)) >= FTOL


def test_the_trace_counts_polishes_and_never_calls_a_row_above_ftol_converged(minimum,
                                                                               monkeypatch):
    """With the polish replaced by one that leaves every minimum nudged above ``ftol`` and
    claiming convergence, every row reads ``≥ ftol`` and none is converged; with the real one a
    short run records every row below ``ftol`` and counts its polishes."""
    run = pressure_shear.shear_at_pressure(minimum.packing, 1e-4, n_steps=3, pressure=P)
    assert np.all(run.columns["max_force"] < FTOL) and np.all(run.columns["converged"])
    assert run.attrs[POLISH_COUNT] >= 0 and run.n_not_converged == 0

    monkeypatch.setattr(pressure_shear, "polish_recorded",
                        lambda res, kw, max_force=None: (nudged(res, 3e-12), 1))
    run = pressure_shear.shear_at_pressure(minimum.packing, 1e-4, n_steps=3, pressure=P)
    c = run.columns
    assert np.all(c["max_force"] >= FTOL) and not np.any(c["converged"])
    assert run.n_not_converged == 4 and run.attrs[POLISH_COUNT] == 4


def test_the_callers_force_is_used(minimum):
    """``max_force`` given by the caller (the row's own evaluation) decides, as the evaluation
    made here would: a reading at or above ``ftol`` polishes, one below does not."""
    bad = nudged(minimum, 3e-12)
    a, runs_a = polish_recorded(bad, KW)
    b, runs_b = polish_recorded(bad, KW, max_force(brute(bad.packing)))
    assert runs_a == runs_b == 1 and a.max_force == b.max_force and b.converged
    out, runs = polish_recorded(minimum, KW, 0.5 * FTOL)
    assert out is minimum and runs == 0
