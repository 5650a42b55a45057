"""Fixed-pressure AQS with checkpoints: an interrupted run resumed from its trace file equals the
uninterrupted run in every column (bit for bit), through the library and through ``jamlab shear
--pressure --save-every … --resume``."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from cli_helpers import jamlab, one_line_error
from jamlab.spheres import jam
from jamlab.spheres.aqs import resume_configuration, shear
from jamlab.spheres.io import write_packing
from jamlab.spheres.trace import FIXED_PRESSURE_COLUMNS, FIXED_PRESSURE_OPTIONAL, read_trace

P, DG, STEPS, EVERY = 1e-3, 1e-4, 60, 20


class Interrupt(Exception):
    pass


@pytest.fixture(scope="module")
def start():
    r = jam(32, 3, seed=5, p_target=1e-4)
    assert r.ok
    return r.packing


def _same(a, b) -> None:
    for name in ("gamma", "energy", "shear_stress", "pressure", "z", "z_nr", "max_force",
                 "iterations", "energy_jump", "stress_jump", "plastic", "jammed", "phi"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for name in FIXED_PRESSURE_COLUMNS + FIXED_PRESSURE_OPTIONAL:
        np.testing.assert_array_equal(a.fixed_pressure[name], b.fixed_pressure[name],
                                      err_msg=name)
    for key in ("n_plastic", "n_candidates", "n_candidates_continued", "n_candidates_held",
                "confirm",
                "plastic_threshold", "n_steps", "gamma_max", "input_box_length", "save_every"):
        assert a.attrs[key] == b.attrs[key], key


def test_resumed_run_equals_the_uninterrupted_one(start, tmp_path):
    whole = shear(start, DG, n_steps=STEPS, pressure=P, out=tmp_path / "a.h5", save_every=EVERY)
    assert whole.trace.attrs["n_candidates"] > 0  # the confirmation state is exercised

    def stop(n, total):
        if n == 2 * EVERY + 5:  # killed between the second save point and the end
            raise Interrupt

    with pytest.raises(Interrupt):
        shear(start, DG, n_steps=STEPS, pressure=P, out=tmp_path / "b.h5", save_every=EVERY,
              progress=stop)
    partial = read_trace(tmp_path / "b.h5")
    assert partial.n_steps == 2 * EVERY
    resumed = shear(resume_configuration(tmp_path / "b.h5", partial), DG, n_steps=STEPS,
                    pressure=P, previous=partial, out=tmp_path / "b.h5", save_every=EVERY)
    _same(whole.trace, resumed.trace)
    _same(read_trace(tmp_path / "a.h5"), read_trace(tmp_path / "b.h5"))
    np.testing.assert_array_equal(whole.packing.positions, resumed.packing.positions)


def test_a_trace_made_before_the_held_column_resumes(start, tmp_path):
    # a checkpoint written before 2026-12-03 has no fixed_pressure/held: it reads, and resumes
    # with zeros there (its candidates were judged by the rule before); the rows are the same
    def stop(n, total):
        if n == EVERY + 3:
            raise Interrupt

    with pytest.raises(Interrupt):
        shear(start, DG, n_steps=STEPS, pressure=P, out=tmp_path / "b.h5", save_every=EVERY,
              progress=stop)
    with h5py.File(tmp_path / "b.h5", "a") as h5:
        del h5["fixed_pressure/held"]
    partial = read_trace(tmp_path / "b.h5")
    assert "held" not in partial.fixed_pressure
    resumed = shear(resume_configuration(tmp_path / "b.h5", partial), DG, n_steps=STEPS,
                    pressure=P, previous=partial, out=tmp_path / "b.h5", save_every=EVERY)
    whole = shear(start, DG, n_steps=STEPS, pressure=P, save_every=EVERY,
                  out=tmp_path / "a.h5")
    np.testing.assert_array_equal(resumed.trace.energy, whole.trace.energy)
    held = resumed.trace.fixed_pressure["held"]
    assert held.shape == whole.trace.energy.shape and not np.any(held[: EVERY + 1])


def test_cli_resume_at_fixed_pressure(start, tmp_path):
    config = tmp_path / "c.h5"
    write_packing(config, start)
    args = ["--dgamma", DG, "--gamma-max", STEPS * DG, "--pressure", P, "--save-every", EVERY]
    r = jamlab("shear", config, *args, "--out", tmp_path / "whole.h5")
    assert r.returncode == 0, r.stderr

    def stop(n, total):
        if n == EVERY + 3:
            raise Interrupt

    with pytest.raises(Interrupt):
        shear(start, DG, n_steps=STEPS, pressure=P, out=tmp_path / "cut.h5", save_every=EVERY,
              progress=stop, source=str(config))
    r = jamlab("shear", config, *args, "--out", tmp_path / "cut.h5", "--resume")
    assert r.returncode == 0, r.stderr
    _same(read_trace(tmp_path / "whole.h5"), read_trace(tmp_path / "cut.h5"))
    # another pressure, or no --pressure, is refused with one line
    other = ["--dgamma", DG, "--gamma-max", STEPS * DG, "--pressure", 2 * P, "--save-every", EVERY]
    r = jamlab("shear", config, *other, "--out", tmp_path / "cut.h5", "--resume")
    assert r.returncode == 2 and "differs from the run being resumed" in r.stderr
    r = jamlab("shear", config, "--dgamma", DG, "--gamma-max", STEPS * DG, "--out",
               tmp_path / "cut.h5", "--resume")
    assert r.returncode == 2 and "at fixed pressure" in r.stderr


def test_cli_resume_keeps_the_confirmation_rule(start, tmp_path):
    config = tmp_path / "c.h5"
    write_packing(config, start)
    args = ["--dgamma", DG, "--gamma-max", STEPS * DG, "--pressure", P, "--save-every", EVERY]

    def stop(n, total):
        if n == EVERY + 3:
            raise Interrupt

    # a run with the rule of before (every candidate redone), interrupted
    with pytest.raises(Interrupt):
        shear(start, DG, n_steps=STEPS, pressure=P, out=tmp_path / "cut.h5", save_every=EVERY,
              progress=stop, source=str(config), confirm="chain")
    assert read_trace(tmp_path / "cut.h5").attrs["confirm"] == "chain"
    # resumed with the default rule: refused, one line naming the option
    r = jamlab("shear", config, *args, "--out", tmp_path / "cut.h5", "--resume")
    line = one_line_error(r)
    assert "--confirm located differs from the run being resumed (chain)" in line
    # with its own rule: the same as the uninterrupted run
    r = jamlab("shear", config, *args, "--confirm", "chain", "--out", tmp_path / "cut.h5",
               "--resume")
    assert r.returncode == 0, r.stderr
    whole = shear(start, DG, n_steps=STEPS, pressure=P, save_every=EVERY, confirm="chain",
                  out=tmp_path / "whole.h5")
    resumed = read_trace(tmp_path / "cut.h5")
    np.testing.assert_array_equal(resumed.plastic, whole.trace.plastic)
    np.testing.assert_array_equal(resumed.energy, whole.trace.energy)
    # --confirm is a fixed-pressure option, and has three values
    r = jamlab("shear", config, "--dgamma", DG, "--gamma-max", STEPS * DG, "--confirm", "chain",
               "--out", tmp_path / "x.h5")
    assert "--confirm applies to fixed-pressure runs" in one_line_error(r)
    r = jamlab("shear", config, *args, "--confirm", "bisect", "--out", tmp_path / "y.h5")
    assert "--confirm must be 'located', 'continued' or 'chain'" in one_line_error(r)


def test_cli_confirm_below(start, tmp_path):
    # --confirm-below reaches the run (attribute), 'inf' redoes every candidate; the stepping and
    # every column but the flags are the same; bad values are refused with one line
    config = tmp_path / "c.h5"
    write_packing(config, start)
    args = ["--dgamma", DG, "--gamma-max", 20 * DG, "--pressure", P]
    traces = {}
    for k in ("inf", "5"):
        r = jamlab("shear", config, *args, "--confirm-below", k, "--out", tmp_path / f"{k}.h5")
        assert r.returncode == 0, r.stderr
        traces[k] = read_trace(tmp_path / f"{k}.h5")
    assert traces["inf"].attrs["confirm_below"] == np.inf
    assert traces["5"].attrs["confirm_below"] == 5.0
    np.testing.assert_array_equal(traces["inf"].energy, traces["5"].energy)
    np.testing.assert_array_equal(traces["inf"].shear_stress, traces["5"].shear_stress)
    r = jamlab("shear", config, *args, "--confirm-below", "0.5", "--out", tmp_path / "x.h5")
    assert "--confirm-below must be >= 1" in one_line_error(r)
    r = jamlab("shear", config, "--dgamma", DG, "--gamma-max", 20 * DG, "--confirm-below", "2",
               "--out", tmp_path / "y.h5")
    assert "--confirm-below applies to fixed-pressure runs" in one_line_error(r)
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "y.h5").exists()
