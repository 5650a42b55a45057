"""Samples saved as they go (``Study.checkpoint_every``): an interrupted sample resumes from its
last save and ends identical, bit for bit, to the uninterrupted sample of the same study.

The interruption is an exception raised by the ``progress`` hook after a chosen step: the process
stops there as a killed worker would (what is on disk is what the saves wrote). The kill of a
whole ``jamlab run`` is in ``tests/cli/test_cli_runs.py``."""

import json

import numpy as np
import pytest
from runs_helpers import Stop, stop_after

from jamlab.runs import Execution, RunDir, Study, run_study, sample_seed
from jamlab.runs.physics import PREPARED, TIMES, TRACE, prepare_and_shear, resume_step
from jamlab.runs.results import SampleResult

pytest.importorskip("jamlab.spheres.packing")

EVERY = 5
# constant volume at phi = 0.8 and fixed pressure at jamming; 23 steps, with plastic steps
# between the saves (steps 2, 9, 10, 14, 20 and 13, 20, 23)
STUDIES = {
    "constant-volume": dict(phi=[0.8], n=[32], samples=1, dgamma=5e-3, gamma_max=0.115, seed=5),
    "fixed-pressure": dict(phi=["jamming"], n=[16], samples=1, dgamma=5e-3, gamma_max=0.115,
                           seed=4, pressure=1e-2),
}


def same(a: SampleResult, b: SampleResult) -> None:
    assert sorted(a.traces) == sorted(b.traces)
    for name in a.traces:
        x, y = np.asarray(a.traces[name]), np.asarray(b.traces[name])
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), name
    assert sorted(a.arrays) == sorted(b.arrays)
    for name in a.arrays:
        assert a.arrays[name].tobytes() == b.arrays[name].tobytes(), name
    assert sorted(a.attrs) == sorted(b.attrs)
    for k in a.attrs:  # bit for bit (NaN equal to itself: a jammed packing's phi_j)
        x, y = np.asarray(a.attrs[k]), np.asarray(b.attrs[k])
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), k


@pytest.fixture(scope="module", params=sorted(STUDIES))
def case(request, tmp_path_factory):
    """(study, key, seed, the uninterrupted sample)."""
    study = Study(**STUDIES[request.param], checkpoint_every=EVERY)
    key = study.keys()[0]
    seed = sample_seed(study.seed, key)
    whole = prepare_and_shear(study, key, seed, tmp_path_factory.mktemp("whole") / "ck")
    return study, key, seed, whole


@pytest.mark.parametrize("stop", [3, 12, 17])
def test_an_interrupted_sample_resumes_bit_for_bit(case, tmp_path, stop):
    study, key, seed, whole = case
    assert whole.resumed_from == -1 and int(np.sum(whole.traces["plastic"])) >= 3
    folder = tmp_path / "ck"
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed, folder, progress=stop_after(stop))
    saved = (stop // EVERY) * EVERY  # the last save before the interruption
    assert (folder / PREPARED).is_file()
    assert (folder / TRACE).is_file() == (saved > 0)
    times = json.loads((folder / TIMES).read_text())
    assert "prepared" in times and (saved == 0 or str(saved) in times)
    resumed = prepare_and_shear(study, key, seed, folder)
    assert resumed.resumed_from == saved
    same(resumed, whole)
    # the earlier invocation's time is counted: it is at least the preparation's
    assert resumed.earlier_cpu_seconds >= times["prepared"][1] > 0


def test_a_finished_but_unwritten_sample_is_not_computed_again(case, tmp_path):
    # the process ended after the shear's final save, before the driver wrote the sample
    study, key, seed, whole = case
    folder = tmp_path / "ck"
    prepare_and_shear(study, key, seed, folder)
    again = prepare_and_shear(study, key, seed, folder)
    steps = round(study.gamma_max / study.dgamma)
    assert again.resumed_from == steps
    times = json.loads((folder / TIMES).read_text())
    assert again.earlier_cpu_seconds == times[str(steps)][1] > times["prepared"][1]
    same(again, whole)


def test_a_damaged_or_foreign_checkpoint_is_replaced(case, tmp_path):
    study, key, seed, whole = case
    folder = tmp_path / "ck"
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed, folder, progress=stop_after(12))
    (folder / TRACE).write_bytes(b"not HDF5")
    redone = prepare_and_shear(study, key, seed, folder)
    assert redone.resumed_from == -1  # started afresh
    same(redone, whole)
    # another sample's checkpoint (another seed) is not resumed
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed + 1, folder, progress=stop_after(12))
    assert prepare_and_shear(study, key, seed, folder).resumed_from == -1


def test_without_checkpoint_every_nothing_is_written_and_the_sample_is_unchanged(tmp_path):
    study = Study(**STUDIES["constant-volume"])
    key = study.keys()[0]
    seed = sample_seed(study.seed, key)
    folder = tmp_path / "ck"
    plain = prepare_and_shear(study, key, seed)
    given = prepare_and_shear(study, key, seed, folder)
    assert not folder.exists() and given.resumed_from == -1
    same(given, plain)


def test_a_checkpoint_with_a_dangling_link_is_replaced(case, tmp_path):
    """The trace's stored configuration with its diameters a dangling link: a damaged checkpoint
    (removed, the sample starts afresh), not one without diameters resumed with D = 1."""
    import h5py

    study, key, seed, whole = case
    folder = tmp_path / "ck"
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed, folder, progress=stop_after(7))
    with h5py.File(folder / TRACE, "a") as h5:
        del h5["configuration/diameters"]
        h5["configuration/diameters"] = h5py.SoftLink("/nothere")
    redone = prepare_and_shear(study, key, seed, folder)
    assert redone.resumed_from == -1
    same(redone, whole)

def test_study_field():
    base = Study(**STUDIES["constant-volume"])
    assert base.checkpoint_every == 0 and "checkpoint_every" not in base.to_dict()
    study = Study(**{**base.to_dict(), "checkpoint_every": "50"})
    assert study.checkpoint_every == 50 and Study.from_dict(study.to_dict()) == study
    assert study.differences(base) == ["checkpoint_every: 50 != 0"]
    for bad in (-1, 1.5, "x", True, float("nan")):
        with pytest.raises(ValueError, match="checkpoint_every"):
            Study(**{**base.to_dict(), "checkpoint_every": bad})


def test_run_resumes_a_checkpointed_sample_and_removes_its_checkpoint(tmp_path, same_runs):
    study = Study(**STUDIES["constant-volume"], checkpoint_every=EVERY)
    run_study(study, tmp_path / "whole", Execution(workers=0))
    rd = RunDir.open(tmp_path / "part", study)
    with rd.lock():
        rd.start(study)  # the run's manifest, as its first invocation wrote it
    key = study.keys()[0]
    # ... whose sample was interrupted at step 12 (as a killed worker leaves it) ...
    with pytest.raises(Stop):
        prepare_and_shear(study, key, sample_seed(study.seed, key), rd.checkpoint_dir(key),
                          progress=stop_after(12))
    assert resume_step(rd, key, study) == 10
    # ... then the run: the sample resumes at step 10 and ends as the uninterrupted run's
    logged = []
    summary = run_study(study, rd.path, Execution(workers=0), log=logged.append)
    assert "1 with a checkpoint" in logged[0]
    assert summary.done == 1 and summary.resumed == 1
    assert not rd.checkpoint_dir(key).exists()
    same_runs(tmp_path / "whole", rd.path)
    # a resumed sample's times cover both invocations
    with __import__("h5py").File(rd.sample_path(key), "r") as h5:
        assert h5.attrs["cpu_seconds"] > 0


def test_status_reports_the_checkpoint_verdict_the_run_acts_on(tmp_path, same_runs, capsys):
    """`jamlab status` said "at step 5 of 23" of a checkpoint whose trace's configuration has a
    dangling link or whose prepared.h5 is unreadable (it read the trace's rows only), while
    `jamlab run` found it unusable and started the sample afresh. Both now use one verdict
    (jamlab.runs.physics.checkpoint_step): status says the sample will be redone, and the run
    does exactly that (not resumed, equal to the uninterrupted run); a sound checkpoint is
    reported at its step and resumed from it."""
    import h5py

    from jamlab.cli import main

    study = Study(**STUDIES["constant-volume"], checkpoint_every=EVERY)
    run_study(study, tmp_path / "whole", Execution(workers=0))
    key = study.keys()[0]

    def dangling(folder):
        with h5py.File(folder / TRACE, "a") as h5:
            del h5["configuration/diameters"]
            h5["configuration/diameters"] = h5py.SoftLink("/nothere")

    def unreadable(folder):
        (folder / PREPARED).write_bytes(b"not HDF5")

    redone = "damaged or not this sample's, will be redone from the start"
    for name, damage, line, resumed in (("sound", None, "at step 5 of 23", 1),
                                        ("dangling", dangling, redone, 0),
                                        ("unreadable", unreadable, redone, 0)):
        rd = RunDir.open(tmp_path / name, study)
        with rd.lock():
            rd.start(study)
        with pytest.raises(Stop):
            prepare_and_shear(study, key, sample_seed(study.seed, key), rd.checkpoint_dir(key),
                              progress=stop_after(7))
        if damage is not None:
            damage(rd.checkpoint_dir(key))
        capsys.readouterr()
        with pytest.raises(SystemExit) as exc:
            main(["status", str(rd.path)])
        assert exc.value.code in (0, None)
        out = capsys.readouterr().out
        said = [ln for ln in out.splitlines() if ln.startswith("checkpoint ")]
        assert said == [f"checkpoint phi=0.8 N=32 sample=0: {line}"], (name, out)
        logged = []
        summary = run_study(study, rd.path, Execution(workers=0), log=logged.append)
        assert (summary.done, summary.resumed) == (1, resumed), name
        # the run's first line counts the checkpoint as it then acts on it
        counted = ("1 with a checkpoint)" if resumed else
                   "0 with a checkpoint, 1 with a damaged checkpoint (redone from the start)")
        assert counted in logged[0], (name, logged[0])
        same_runs(tmp_path / "whole", rd.path)


def test_a_written_samples_leftover_checkpoint_is_removed(tmp_path):
    study = Study(**STUDIES["constant-volume"], checkpoint_every=EVERY)
    run_study(study, tmp_path / "r", Execution(workers=0))
    rd = RunDir(tmp_path / "r")
    key = study.keys()[0]
    leftover = rd.checkpoint_dir(key)
    leftover.mkdir(parents=True)
    (leftover / PREPARED).write_bytes(b"x")
    summary = run_study(study, rd.path, Execution(workers=0))
    assert summary.skipped == 1 and not leftover.exists()


def test_a_saved_failure_is_not_resumed_but_sheared_again_from_the_prepared_packing(
    case, tmp_path
):
    """A sample whose saved trace holds a step that did not converge (here: one row's max|F|
    set to 1 in the file after a whole checkpointed run) was recorded as failed; retried, it is
    sheared again from ``prepared.h5`` — the same bits as the uninterrupted sample — instead of
    being read back (which at fixed pressure raised the same failure again)."""
    import h5py

    from jamlab.runs.physics import failed_steps
    from jamlab.spheres.trace import read_trace

    study, key, seed, whole = case
    folder = tmp_path / "ck"
    prepare_and_shear(study, key, seed, folder)
    assert failed_steps(read_trace(folder / TRACE), study.force_tol) == 0
    with h5py.File(folder / TRACE, "r+") as h5:
        h5["max_force"][7] = 1.0
    assert failed_steps(read_trace(folder / TRACE), study.force_tol) == 1
    again = prepare_and_shear(study, key, seed, folder)
    assert again.resumed_from == 0  # from the prepared packing, not the saved trace
    same(again, whole)
    assert failed_steps(read_trace(folder / TRACE), study.force_tol) == 0  # saved anew
    # a retry interrupted after its first save keeps no times of the failed shear's later saves
    with h5py.File(folder / TRACE, "r+") as h5:
        h5["max_force"][7] = 1.0
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed, folder, progress=stop_after(EVERY + 2))
    assert sorted(json.loads((folder / TIMES).read_text())) == sorted(["prepared", str(EVERY)])
