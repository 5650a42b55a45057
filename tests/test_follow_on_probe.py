"""``scripts/follow_on_probe.py``: the replay of a small fixed-pressure sample equals the stored
trace bit for bit; each step taken afresh from its start minimum releases what the run's step
did; a constant-volume run is refused."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module


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


def test_gaps_by_hand(fop):
    f = np.array
    assert fop.gaps(f([False, False, False])) == "none"
    assert fop.gaps(f([False, True, False])) == "one"
    assert fop.gaps(f([False, True, True, False])) == "adjacent"
    assert fop.gaps(f([True, False, True, False])) == "separated"


def pair_sample(tmp_path):
    """A sample with counted avalanches at consecutive steps (9 and 10; found by a search over
    seeds, and checked below)."""
    from jamlab.runs import Execution, Study, run_study

    out = tmp_path / "pair"
    study = Study(phi=["jamming"], n=[16], samples=1, dgamma=5e-3, gamma_max=0.15, seed=1,
                  pressure=1e-3)
    run_study(study, out, Execution(workers=0))
    return next(out.glob("samples/*/*/sample-*.h5"))


def test_fine_steps_of_one_substep_are_the_runs_steps(fop, tmp_path):
    from jamlab.analysis import classify_steps

    sample = pair_sample(tmp_path)
    study, stored, trace, minima = fop.replay(sample, n_steps=20, keep={3, 8})
    assert sorted(minima) == [3, 8] and trace.energy_jump.size == 21
    np.testing.assert_array_equal(trace.energy_jump[1:], stored["energy_jump"][1:21])
    counted = classify_steps(stored["energy_jump"][1:], stored["plastic"][1:],
                             jammed=stored["jammed"])
    assert counted[8] and counted[9] and not counted[3:5].any()  # steps 9, 10 avalanches
    for k in (3, 8):
        size, _ = fop.fine_steps(minima[k], study, 1)
        # two steps δγ from minimum k land where the run's steps k + 1 and k + 2 did (under the
        # rule "elastic" the start's history moves where the minimiser starts, not where it ends)
        np.testing.assert_allclose(size, -stored["energy_jump"][k + 1:k + 3],
                                   rtol=0, atol=1e-3 * study.dgamma**2)
        # (the flags of a two-step run are not the run's: its noise floor comes from two steps)


def pair_probe_lines(fop, tmp_path, monkeypatch, capsys, *options):
    """The script's output on the pair sample with ``options``, checked to replay the stored
    trace, and its lines about sample 0's pairs."""
    import sys

    sample = pair_sample(tmp_path)
    monkeypatch.setattr(sys, "argv", ["follow_on_probe.py", str(sample), *options])
    fop.main()
    out = capsys.readouterr().out
    assert "equal to the stored trace" in out and "DIFFERS" not in out
    return out, [x for x in out.splitlines() if x.startswith("  sample-00000.h5")]


def test_pairs_mode_probes_the_pair(fop, tmp_path, monkeypatch, capsys):
    out, lines = pair_probe_lines(fop, tmp_path, monkeypatch, capsys, "--pairs", "--above",
                                  "1e-300", "--substeps", "1")
    assert len(lines) == 1 and lines[0].split()[1] == "9"
    # with one substep per step the replay retakes the run's two steps: the same total −ΔH
    # (finer substeps may end elsewhere: the path of a jump depends on the driving)
    total, run = (float(v) for v in lines[0].split("|")[2].split("(")[0].split("against"))
    assert total == pytest.approx(run, rel=1e-3)
    assert "the pairs by how the replay's releases lie: " in out


def test_replay_of_a_checkpointed_run_restarts_where_the_run_did(fop, tmp_path):
    # checkpoints are restart points of the solver state (rounding-level changes): the replay
    # takes the study's, so it equals the stored trace bit for bit
    sample = one_sample(tmp_path, pressure=1e-3, checkpoint_every=7)
    _, stored, trace, _ = fop.replay(sample, keep=set())
    np.testing.assert_array_equal(trace.energy_jump[1:], stored["energy_jump"][1:])
    np.testing.assert_array_equal(trace.plastic, stored["plastic"])


def random_packing_at(n=12, length=5.0, strain=0.37, seed=3):
    from jamlab.spheres.box import Box
    from jamlab.spheres.state import Packing

    rng = np.random.default_rng(seed)
    return Packing(positions=rng.uniform(0, length, (n, 3)), box=Box(length, 3, strain))


def test_nonaffine_of_an_affine_step_is_zero_and_finds_a_moved_particle(fop):
    from jamlab.spheres.barostat import rescale_box
    from jamlab.spheres.state import affine_shear

    before = random_packing_at()
    # the affine map of one fixed-pressure step, then positions wrapped into the new box
    after = rescale_box(affine_shear(before, 3e-2), before.box.length * 1.01).wrapped()
    assert not np.allclose(after.positions, before.positions)
    np.testing.assert_allclose(fop.nonaffine(before, after), 0.0, atol=1e-12)
    moved = np.array(after.positions)
    moved[4] += [1e-3, -2e-3, 5e-4]
    u = fop.nonaffine(before, after.with_positions(moved))
    np.testing.assert_allclose(u[4], [1e-3, -2e-3, 5e-4], atol=1e-12)
    np.testing.assert_allclose(np.delete(u, 4, axis=0), 0.0, atol=1e-12)


def test_field_measures_by_hand(fop):
    n = 10
    one = np.zeros((n, 3))
    one[2] = [0.0, 3.0, 4.0]
    other = np.zeros((n, 3))
    other[7] = [1.0, 0.0, 0.0]
    alike = np.ones((n, 3))
    assert fop.participation_ratio(one) == pytest.approx(1 / n)
    assert fop.participation_ratio(alike) == pytest.approx(1.0)
    assert fop.shared_weight(one, other) == 0.0
    assert fop.shared_weight(alike, 2 * alike) == pytest.approx(1.0)
    assert fop.shared_weight(one, alike) == pytest.approx(1 / n)  # min(1, 1/n) at particle 2
    assert fop.cosine(one, -one) == pytest.approx(-1.0) and fop.cosine(one, other) == 0.0
    assert fop.cosine(one + other, one) == pytest.approx(5.0 / np.sqrt(26.0))
    # the most-moving particles 2 and 7, placed across the y boundary of a sheared box
    at = random_packing_at(n=n, length=5.0, strain=0.1)
    pos = np.array(at.positions)
    pos[2] = [1.0, 0.2, 2.0]
    pos[7] = [1.0 + 0.1 * 5.0 + 0.3, 4.9, 2.0]  # the image of 7 below y = 0 is at x 1.3, y −0.1
    d = fop.centre_distance(one, other, at.with_positions(pos))
    assert d == pytest.approx(np.hypot(0.3, 0.3))


def test_elastic_before_skips_plastic_steps(fop):
    plastic = np.array([False, False, True, True, False, True, True])
    assert fop.elastic_before(plastic, 6) == 4
    assert fop.elastic_before(plastic, 4) == 1
    assert fop.elastic_before(np.array([False, True, True]), 2) == 0


def test_where_mode_measures_the_pair(fop, tmp_path, monkeypatch, capsys):
    out, lines = pair_probe_lines(fop, tmp_path, monkeypatch, capsys, "--where", "--above",
                                  "1e-300", "--lag-min", "3")
    lines = [x.split() for x in lines]
    assert len(lines) == 1 and lines[0][1:3] == ["9", "10"]
    shared, cos, dist = (float(v) for v in lines[0][7:10])
    assert 0.0 <= shared <= 1.0 and -1.0 <= cos <= 1.0 and dist >= 0.0
    # the elastic step's field is a small part of a plastic step's displacement
    assert float(lines[0][10]) < 0.5
    # the only events up to step 10 are the pair's: no far pair to compare with
    assert "0 ≥ 3 steps apart" in out and "shared weight: too few pairs" in out


def test_pairs_and_where_are_refused_together(fop, tmp_path, monkeypatch):
    sample = pair_sample(tmp_path)
    assert exit_code(fop, [str(sample), "--where", "--pairs"], monkeypatch) == 2


def test_a_sample_from_another_machine_is_named_when_the_replay_differs(fop, tmp_path):
    import json

    import h5py

    sample = one_sample(tmp_path, pressure=1e-3)
    assert fop.other_machine(sample) == ""
    assert fop.verdict(sample, True) == "equal to the stored trace"
    with h5py.File(sample, "r+") as h5:
        records = json.loads(h5.attrs["provenance"])
        records[0]["blas_cores"] = "libopenblas 0.3.15 Prescott"
        h5.attrs["provenance"] = json.dumps(records)
    text = fop.verdict(sample, False)
    assert text.startswith("DIFFERS from the stored trace (made on another machine or BLAS: ")
    assert "Prescott" in text


def test_event_field_leaves_the_rattlers_out(fop, tmp_path):
    from jamlab.spheres.contacts import remove_rattlers

    sample = pair_sample(tmp_path)
    _, stored, _, minima = fop.replay(sample, n_steps=10, keep=set(range(11)))
    e = fop.elastic_before(stored["plastic"], 9)
    u = fop.event_field(minima, 9, e)
    mask = np.logical_and.reduce([remove_rattlers(minima[k]).mask for k in (8, 9, e - 1, e)])
    assert np.all(u[~mask] == 0.0) and np.any(u[mask] != 0.0)
    np.testing.assert_array_equal(fop.backbone(minima, {8, 9, e - 1, e}), mask)
