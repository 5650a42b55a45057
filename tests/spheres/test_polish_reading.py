"""A fixed-box minimum converged as a reader sees it (``fire.polish_reading``, used by ``relax``
and so by ``prepare``, ``jam`` and the compression curve, and by ``jam_at_pressure`` through
``barostat.polish_recorded``): FIRE accepts ``max|F_i| < ftol`` with its own neighbour list, a
reader evaluates the stored packing afresh, and the two can differ at rounding level across
``ftol``. The rounding is magnified here by nudging one particle of a converged minimum; every
reading is checked against brute-force forces (``spheres_brute``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from spheres_brute import brute_force

import jamlab.spheres.barostat as barostat
import jamlab.spheres.relax as relax_module
from jamlab.spheres import jam
from jamlab.spheres.fire import POLISH_RUNS, minimize, polish_reading
from jamlab.spheres.packing import jam_at_pressure, prepare
from jamlab.spheres.relax import JAM_FIRE, relax

FTOL = 1e-12


def brute_max_force(packing) -> float:
    pk = packing.wrapped()
    f = brute_force(pk.positions, pk.box.length, pk.strain)["forces"]
    return float(np.sqrt((f**2).sum(axis=1)).max())


def nudge(packing, force: float):
    """``packing`` with one particle that has contacts moved by ``force`` along x (harmonic,
    D = 1: the force on it moves by about as much per contact)."""
    pk = packing.wrapped()
    f = brute_force(pk.positions, pk.box.length, pk.strain)["forces"]
    i = int(np.argmax(np.abs(f).sum(axis=1) > 0))
    pos = packing.positions.copy()
    pos[i, 0] += force
    moved = packing.with_positions(pos)
    assert brute_max_force(moved) >= FTOL
    return moved


@pytest.fixture(scope="module")
def minimum():
    r = jam(32, 3, seed=1, p_target=1e-4)
    assert r.ok
    res = minimize(r.packing, FTOL, params=JAM_FIRE)
    assert res.converged and brute_max_force(res.packing) < FTOL
    return res


def claimed(res, force: float):
    """``res`` nudged to read ≈ ``force`` while still claiming convergence."""
    return replace(res, packing=nudge(res.packing, force), converged=True)


def test_a_minimum_reading_above_ftol_is_polished(minimum):
    bad = claimed(minimum, 3e-12)
    out, ev, runs = polish_reading(bad, brute_max_force(bad.packing), params=JAM_FIRE)
    assert runs == 1 and out.converged and out.ftol == FTOL
    assert brute_max_force(out.packing) < FTOL
    assert out.max_force == ev.max_force and out.max_force == pytest.approx(
        brute_max_force(out.packing), rel=1e-6, abs=1e-15)
    assert out.iterations > bad.iterations
    assert np.abs(out.packing.positions - bad.packing.positions).max() < 1e-9  # a polish only


def test_a_clean_or_unconverged_minimum_is_returned_as_it_is(minimum):
    out, ev, runs = polish_reading(minimum, brute_max_force(minimum.packing))
    assert out is minimum and ev is None and runs == 0
    failed = replace(claimed(minimum, 3e-12), converged=False)
    out, ev, runs = polish_reading(failed, brute_max_force(failed.packing))
    assert out is failed and ev is None and runs == 0


def test_a_polish_that_cannot_finish_or_is_refused_is_not_converged(minimum):
    bad = claimed(minimum, 3e-12)
    out, _, runs = polish_reading(bad, brute_max_force(bad.packing), max_iter=0)
    assert runs == 1 and not out.converged  # FIRE did not converge: no second run
    assert out.max_force >= FTOL and brute_max_force(out.packing) >= FTOL
    out, ev, runs = polish_reading(bad, brute_max_force(bad.packing), accept=lambda e: False)
    assert runs == 1 and not out.converged and ev.max_force < FTOL
    assert POLISH_RUNS >= 1


def test_relax_returns_a_minimum_that_reads_converged(minimum, monkeypatch):
    """``relax`` with a FIRE whose first answer reads above ``ftol`` afresh."""
    calls = []

    def lying_minimize(packing, ftol, max_iter, params):
        res = minimize(packing, ftol=ftol, max_iter=max_iter, params=params)
        calls.append(ftol)
        return claimed(res, 3e-12) if len(calls) == 1 else res

    monkeypatch.setattr(relax_module, "minimize", lying_minimize)
    r = relax(minimum.packing, FTOL)
    assert r.converged and r.max_force < FTOL
    assert brute_max_force(r.packing) < FTOL
    assert calls == [FTOL]  # the polish is fire.minimize's own, at ftol/2


def test_prepare_and_jam_at_pressure_read_converged(monkeypatch):
    """The packings ``prepare`` and ``jam_at_pressure`` return read ``< ftol`` by brute force,
    also when the minimiser's last answer read above it."""
    u = prepare(32, 3, 0.8, seed=2)
    assert u.ok and brute_max_force(u.packing) < FTOL
    real = barostat.minimize_enthalpy

    def lying(packing, pressure, **kw):
        res = real(packing, pressure, **kw)
        return replace(res, packing=nudge(res.packing, 3e-12), converged=True)

    monkeypatch.setattr(barostat, "minimize_enthalpy", lying)
    r = jam_at_pressure(32, 3, seed=1, pressure=1e-4)
    assert r.ok and r.converged
    assert brute_max_force(r.packing) < FTOL


def test_the_minimize_command_writes_a_minimum_that_reads_converged(minimum, tmp_path,
                                                                    monkeypatch):
    """``jamlab minimize`` (in process) with a FIRE whose first answer reads above ``ftol``."""
    import h5py

    import jamlab.spheres.fire as fire
    from jamlab.cli import main
    from jamlab.spheres.io import read_packing, write_packing

    real, calls = fire.minimize, []

    def lying(packing, ftol=FTOL, max_iter=1_000_000, params=None, **kw):
        res = real(packing, ftol, max_iter, params, **kw)
        calls.append(ftol)
        return claimed(res, 3e-12) if len(calls) == 1 else res

    monkeypatch.setattr(fire, "minimize", lying)
    start = write_packing(tmp_path / "start.h5", minimum.packing)
    out = tmp_path / "out.h5"
    with pytest.raises(SystemExit) as done:
        main(["minimize", str(start), "--out", str(out)])
    assert done.value.code in (0, None)
    assert calls == [FTOL, FTOL / 2]  # the lie, then the polish
    assert brute_max_force(read_packing(out)) < FTOL
    with h5py.File(out) as h5:
        assert h5.attrs["minimize_converged"] == 1 and h5.attrs["minimize_max_force"] < FTOL
