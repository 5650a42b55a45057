"""A fixed-pressure AQS step that does not converge is taken once more afresh
(:func:`jamlab.spheres.barostat.minimize_step`): compared with the direct call it must equal
(bit for bit) — :func:`minimize_enthalpy` from the sheared minimum with a fresh relaxer and no
guesses — and a converged step must be the plain call, untouched."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jamlab.spheres import jam
from jamlab.spheres.barostat import minimize_enthalpy, minimize_step
from jamlab.spheres.fire import MinimizeResult
from jamlab.spheres.newton_relax import NewtonRelaxer
from jamlab.spheres.potential import affine_shear
from jamlab.spheres.pressure_shear import RETRY_COUNT, shear_at_pressure

P, DG = 1e-4, 1e-4


@pytest.fixture(scope="module")
def parent():
    r = jam(32, 3, seed=3, p_target=1e-4)
    assert r.ok
    res = minimize_enthalpy(r.packing, P)
    assert res.converged
    return res.packing


class FailsUntilReset(NewtonRelaxer):
    """A relaxer whose every call fails (7 iterations, not converged) until it is reset."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self.failing = True
        self.failed_calls = 0

    def reset(self) -> None:
        self.failing = False
        super().reset()

    def __call__(self, packing, ftol=1e-12, max_iter=1_000_000, params=None, parent=None):
        if self.failing:
            self.failed_calls += 1
            return MinimizeResult(packing, math.nan, 1.0, 7, False, 0.0, ftol)
        return super().__call__(packing, ftol, max_iter, params, parent)


def _same_minimum(a, b) -> None:
    np.testing.assert_array_equal(a.packing.positions, b.packing.positions)
    assert a.packing.box.length == b.packing.box.length
    assert a.energy == b.energy and a.pressure == b.pressure


def test_a_converged_step_is_the_plain_call(parent):
    sheared = affine_shear(parent, DG)
    guess = parent.box.length * (1 + 1e-6)
    got, retries = minimize_step(sheared, parent, P, {"relax": NewtonRelaxer()}, guess, -1.5)
    want = minimize_enthalpy(sheared, P, length_guess=guess, slope_guess=-1.5, parent=parent,
                             relax=NewtonRelaxer())
    assert retries == 0 and got.converged
    _same_minimum(got, want)
    assert got.iterations == want.iterations and got.volume_steps == want.volume_steps


def test_a_failed_step_is_taken_afresh_without_guesses(parent):
    sheared = affine_shear(parent, DG)
    relax = FailsUntilReset()
    # guesses that would move the result at rounding level if they were used again
    guess = parent.box.length * (1 + 1e-4)
    got, retries = minimize_step(sheared, parent, P, {"relax": relax}, guess, -1.5)
    assert retries == 1 and relax.failed_calls == 1
    want = minimize_enthalpy(sheared, P, parent=parent, relax=NewtonRelaxer())
    assert got.converged and want.converged
    _same_minimum(got, want)
    assert got.iterations == want.iterations + 7
    assert got.volume_steps == want.volume_steps


def test_fire_without_guesses_is_not_retried_and_with_one_is(parent):
    sheared = affine_shear(parent, DG)
    kw = {"max_iter": 3}  # FIRE cannot converge in 3 iterations
    got, retries = minimize_step(sheared, parent, P, kw, None, None)
    want = minimize_enthalpy(sheared, P, parent=parent, **kw)
    assert retries == 0 and not got.converged
    _same_minimum(got, want)
    assert got.iterations == want.iterations
    guess = parent.box.length * (1 + 1e-4)
    first = minimize_enthalpy(sheared, P, length_guess=guess, parent=parent, **kw)
    got, retries = minimize_step(sheared, parent, P, kw, guess, None)
    assert retries == 1 and not got.converged
    _same_minimum(got, want)  # the second attempt is the call without the guess
    assert got.iterations == want.iterations + first.iterations


def test_shear_counts_the_retried_step_and_records_its_afresh_minimum(parent, monkeypatch):
    """One call of the run's relaxer (the third step's first) fails until reset: the run goes
    on converged, counts one retry, and that step's minimum is the afresh one from the step
    before's."""
    import jamlab.spheres.pressure_shear as S

    calls = {"n": 0}

    class FailsOnce(NewtonRelaxer):
        def __call__(self, packing, ftol=1e-12, max_iter=1_000_000, params=None, parent=None):
            calls["n"] += 1
            if calls["n"] == calls.get("fail_at", -1):
                return MinimizeResult(packing, math.nan, 1.0, 7, False, 0.0, ftol)
            return super().__call__(packing, ftol, max_iter, params, parent)

    seen: dict = {}

    def observer(n, packing):
        seen[n] = packing
        if n == 2:
            seen["calls"] = calls["n"]

    monkeypatch.setattr(S, "NewtonRelaxer", FailsOnce)
    plain = shear_at_pressure(parent, DG, n_steps=4, pressure=P, observer=observer)
    assert plain.attrs[RETRY_COUNT] == 0 and plain.n_not_converged == 0
    start = seen[2]
    calls.update(n=0, fail_at=seen["calls"] + 1)  # the first call of step 3
    run = shear_at_pressure(parent, DG, n_steps=4, pressure=P, observer=observer)
    assert run.attrs[RETRY_COUNT] == 1 and run.n_not_converged == 0
    for k in ("enthalpy", "box_length", "iterations"):  # the steps before are the plain run's
        np.testing.assert_array_equal(run[k][:3], plain[k][:3])
    want = minimize_enthalpy(affine_shear(start, parent.strain + 3 * DG - start.strain), P,
                             parent=start, relax=NewtonRelaxer())
    assert want.converged
    np.testing.assert_array_equal(seen[3].positions, want.packing.positions)
    assert seen[3].box.length == want.packing.box.length
    assert run["iterations"][3] >= want.iterations + 7


def test_a_run_resumed_across_a_retried_step_equals_the_uninterrupted_one(parent, monkeypatch,
                                                                          tmp_path):
    """Checkpoints every 2 steps; each run's relaxer fails its first call at step 4's strain
    (once per relaxer: the retry's reset does not re-arm it). Interrupted at step 3 and resumed
    from the save at step 2, the run retries step 4 as the uninterrupted one did: every column
    and the counters bit for bit."""
    import jamlab.spheres.pressure_shear as S
    from jamlab.spheres.aqs import resume_configuration, shear
    from jamlab.spheres.trace import FIXED_PRESSURE_COLUMNS, read_trace

    target = parent.strain + 4 * DG

    class FailsAtStep4(NewtonRelaxer):
        def __post_init__(self) -> None:
            super().__post_init__()
            self.spent = False

        def __call__(self, packing, ftol=1e-12, max_iter=1_000_000, params=None, parent=None):
            if not self.spent and abs(packing.strain - target) < 1e-3 * DG:
                self.spent = True
                return MinimizeResult(packing, math.nan, 1.0, 7, False, 0.0, ftol)
            return super().__call__(packing, ftol, max_iter, params, parent)

    class Interrupt(Exception):
        pass

    def stop(n, total):
        if n == 3:
            raise Interrupt

    monkeypatch.setattr(S, "NewtonRelaxer", FailsAtStep4)
    kw = dict(n_steps=6, pressure=P, save_every=2)
    whole = shear(parent, DG, out=tmp_path / "a.h5", **kw)
    assert whole.trace.attrs[RETRY_COUNT] == 1 and whole.trace.attrs["n_not_converged"] == 0
    with pytest.raises(Interrupt):
        shear(parent, DG, out=tmp_path / "b.h5", progress=stop, **kw)
    partial = read_trace(tmp_path / "b.h5")
    assert partial.n_steps == 2 and partial.attrs[RETRY_COUNT] == 0
    resumed = shear(resume_configuration(tmp_path / "b.h5", partial), DG, previous=partial,
                    out=tmp_path / "b.h5", **kw)
    a, b = whole.trace, resumed.trace
    assert b.attrs[RETRY_COUNT] == 1
    for name in ("gamma", "energy", "shear_stress", "pressure", "max_force", "iterations",
                 "energy_jump", "plastic", "jammed", "phi"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for name in FIXED_PRESSURE_COLUMNS:
        np.testing.assert_array_equal(a.fixed_pressure[name], b.fixed_pressure[name])
    np.testing.assert_array_equal(whole.packing.positions, resumed.packing.positions)
