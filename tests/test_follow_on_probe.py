"""``scripts/follow_on_probe.py``: the replay of a small fixed-pressure sample equals the stored
trace bit for bit; each step taken afresh from its start minimum releases what the run's step
did; a constant-volume run is refused."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module


@pytest.fixture(scope="module")
def fop():
    return script_module("follow_on_probe")


def one_sample(tmp_path, **extra):
    from jamlab.runs import Execution, Study, run_study

    out = tmp_path / "run"
    study = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-2, seed=4,
                  **extra)
    run_study(study, out, Execution(workers=0))
    return next(out.glob("samples/*/*/sample-*.h5"))


def test_replay_equals_the_stored_sample_and_fresh_elastic_steps_release_nothing(fop,
                                                                                 tmp_path):
    sample = one_sample(tmp_path, pressure=1e-3)
    study, stored, trace, minima = fop.replay(sample)
    np.testing.assert_array_equal(trace.energy_jump[1:], stored["energy_jump"][1:])
    np.testing.assert_array_equal(trace.plastic, stored["plastic"])
    assert sorted(minima) == list(range(31)) and trace.attrs["volume_guess"] == "elastic"
    r = trace.energy_jump[1:] - 0.5 * study.dgamma * trace.stress_jump[1:]
    assert trace.plastic.any()  # a jump among the steps checked
    # every step k → k + 1 taken afresh from minimum k releases what the run's step did: under
    # the rule "elastic" the box-side guess of a step is its branch's own dilatancy (and none
    # after a jump), so the history changes where the minimiser starts, not where it ends
    for k in range(1, 30):
        assert fop.fresh_release(minima[k], study) == pytest.approx(
            -r[k], abs=1e-3 * study.dgamma**2), k


def test_a_constant_volume_run_is_refused(fop, tmp_path):
    with pytest.raises(ValueError, match="not a fixed-pressure run"):
        fop.replay(one_sample(tmp_path, task="toy"))
