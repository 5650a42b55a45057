"""The trace's ``jammed`` and ``phi`` columns (format version 2) and ``shear(pressure=P)``.

Every recorded minimum's flag is compared with the brute-force verdict of ``spheres_brute``
(every pair and image, rattlers removed from a work queue, the virial written out) on the
configuration saved at that step (``save_every=1``): on a jammed packing whose steps go through
the lean elastic path (backbone counts carried from the previous minimum), on a packing at
p = 1e-7 that unjams at the first step, and on a bidisperse packing with alpha = 5/2."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from spheres_brute import brute_jammed_state

from jamlab.spheres import jam, prepare
from jamlab.spheres.aqs import checkpoint_paths, shear
from jamlab.spheres.io import read_packing
from jamlab.spheres.trace import read_trace, read_trace_configuration


def flags_by_brute_force(out, n_steps, ftol=1e-12):
    _, snapshots = checkpoint_paths(out)
    flags = []
    for n in range(1, n_steps):
        flags.append(
            brute_jammed_state(read_packing(snapshots / f"step_{n:08d}.h5"), ftol)["jammed"]
        )
    last = read_packing(checkpoint_paths(out)[0])
    flags.append(brute_jammed_state(last, ftol)["jammed"])
    return np.array(flags)


def test_jammed_column_on_lean_steps(tmp_path):
    pk = prepare(64, 3, 0.66, 1).packing
    out = tmp_path / "t.h5"
    res = shear(pk, 1e-4, n_steps=12, save_every=1, out=out)
    tr = read_trace(out)
    assert tr.attrs["n_lean"] >= 6  # the lean path carries the backbone counts
    assert tr.jammed is not None and tr.jammed.dtype == bool
    np.testing.assert_array_equal(tr.jammed[1:], flags_by_brute_force(out, 12))
    assert brute_jammed_state(pk, 1e-12)["jammed"] == tr.jammed[0]
    assert tr.jammed.all()
    np.testing.assert_array_equal(tr.phi, np.full(13, pk.phi))
    np.testing.assert_array_equal(res.trace.jammed, tr.jammed)


def test_jammed_column_when_the_packing_unjams(tmp_path):
    # jam(32, 3, 3, p_target=1e-7) unjams at the first step of 1e-4 (measured)
    pk = jam(32, 3, 3, p_target=1e-7).packing
    out = tmp_path / "t.h5"
    shear(pk, 1e-4, n_steps=6, save_every=1, out=out, minimizer="fire", classify=False)
    tr = read_trace(out)
    expected = flags_by_brute_force(out, 6)
    np.testing.assert_array_equal(tr.jammed[1:], expected)
    assert tr.jammed[0] and not expected.any()
    assert tr.attrs["n_unjammed"] == 6


def test_jammed_column_with_a_pair_law(tmp_path):
    pk = prepare(48, 3, 0.72, 2, sizes="bidisperse", alpha=2.5).packing
    assert not pk.monodisperse and pk.alpha == 2.5
    out = tmp_path / "t.h5"
    shear(pk, 1e-4, n_steps=5, save_every=1, out=out)
    tr = read_trace(out)
    np.testing.assert_array_equal(tr.jammed[1:], flags_by_brute_force(out, 5))


def test_version_1_files_read_without_the_columns_and_resume(tmp_path):
    pk = prepare(32, 3, 0.7, 3).packing
    out = tmp_path / "t.h5"
    shear(pk, 1e-4, n_steps=4, out=out)
    with h5py.File(out, "r+") as h5:
        del h5["jammed"], h5["phi"]
        h5.attrs["format_version"] = 1
    old = read_trace(out)
    assert old.jammed is None and old.phi is None
    cfg = read_trace_configuration(out)
    start = type(pk)(cfg["positions"], pk.box.with_strain(cfg["strain"]), seed=pk.seed)
    more = shear(start, 1e-4, n_steps=7, previous=old)
    assert more.trace.n_steps == 7
    assert more.trace.jammed is None  # unknown for the first rows: no column, never a guess


def test_resumed_trace_has_the_whole_column(tmp_path):
    pk = prepare(32, 3, 0.7, 3).packing
    whole = shear(pk, 1e-4, n_steps=8).trace
    first = shear(pk, 1e-4, n_steps=4)
    more = shear(first.packing, 1e-4, n_steps=8, previous=first.trace).trace
    np.testing.assert_array_equal(more.jammed, whole.jammed)
    np.testing.assert_array_equal(more.gamma, whole.gamma)


def test_fixed_pressure_through_shear(tmp_path):
    pk = jam(32, 3, 1, p_target=1e-4).packing
    out = tmp_path / "p.h5"
    res = shear(pk, 1e-4, n_steps=20, pressure=1e-3, out=out)
    tr = read_trace(out)
    assert tr.attrs["protocol"] == "fixed-pressure"
    assert tr.attrs["energy_column"] == "enthalpy"
    tol = np.maximum(1e-6 * 1e-3, 10 * 1e-12 * 32 * tr.phi / (32 * np.pi / 6))
    assert np.all(np.abs(tr.pressure - 1e-3) <= tol)
    assert res.n_not_converged == 0 and np.all(tr.max_force < 1e-12)
    # phi(gamma) moves, and it is the phi of the saved last configuration
    assert np.ptp(tr.phi) > 0
    assert tr.phi[-1] == pytest.approx(read_packing(checkpoint_paths(out)[0]).phi, rel=1e-14)
    assert tr.jammed.all()
    assert brute_jammed_state(res.packing, 1e-12)["jammed"]
    # the energy column is the enthalpy H = E + p V of the final minimum
    from spheres_brute import brute_force

    b = brute_force(res.packing.wrapped().positions, res.packing.box.length, res.packing.strain)
    assert tr.energy[-1] == pytest.approx(b["energy"] + 1e-3 * res.packing.box.volume, rel=1e-12)


@pytest.mark.parametrize(
    "kw",
    [
        {"pressure": -1.0},
        {"pressure": float("nan")},
        {"pressure": 1e-3, "ptol": 0.0},
        {"pressure": 1e-3, "save_every": 0, "out": "x.h5"},
        {"pressure": 1e-3, "save_every": True, "out": "x.h5"},  # not read as 1
        {"pressure": 1e-3, "save_every": 2.0, "out": "x.h5"},
        {"pressure": 1e-3, "n_steps": 2.0},  # was a TypeError inside the run
        {"pressure": 1e-3, "n_steps": "2"},
        {"n_steps": 2.0},  # constant volume alike
        {"n_steps": True},
        {"pressure": 1e-3, "save_every": 2},  # checkpoints need an output file
    ],
)
def test_shear_bad_arguments(kw, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a relative out= accepted by mistake writes there, not here
    pk = prepare(16, 3, 0.7, 3).packing
    kw = {"n_steps": 2} | kw
    with pytest.raises(ValueError):
        shear(pk, 1e-4, **kw)


def test_numpy_integer_steps_at_fixed_pressure(tmp_path):
    """n_steps and save_every may be numpy integers at fixed pressure, as at constant volume: the
    driver accepted them and the fixed-pressure stepper refused them ("n_steps must be an
    integer"). The same run as with Python ints."""
    pk = prepare(16, 3, 0.7, 3).packing
    runs = [shear(pk, 1e-4, n_steps=steps, pressure=1e-3, save_every=every, out=tmp_path / name)
            for steps, every, name in ((4, 2, "a.h5"), (np.int64(4), np.int64(2), "b.h5"))]
    a, b = (r.trace for r in runs)
    assert a.n_steps == b.n_steps == 4
    np.testing.assert_array_equal(a.energy, b.energy)
    np.testing.assert_array_equal(a.phi, b.phi)
