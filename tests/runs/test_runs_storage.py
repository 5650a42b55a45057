"""Run directory: manifest, atomic sample files, corrupt/partial detection, failures, resume."""

import json
import os

import h5py
import numpy as np
import pytest

from jamlab.provenance import machine
from jamlab.runs import (
    Execution,
    RunDir,
    RunError,
    SampleFailed,
    SampleFailure,
    Study,
    open_run,
    run_study,
    sample_seed,
)
from jamlab.runs.storage import CHECKPOINT_TRACE
from jamlab.runs.tasks import toy_task

STUDY = Study(phi=["jamming", 0.8], n=[8, 12], samples=3, dgamma=1e-3, gamma_max=5e-3, task="toy")
IN_PROCESS = Execution(workers=0)


def test_manifest_records_the_study(tmp_path):
    run_study(STUDY, tmp_path / "run", IN_PROCESS)
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert Study.from_dict(manifest["study"]) == STUDY
    assert manifest["master_seed"] == STUDY.seed
    assert manifest["format"] == "jamlab-run"
    for field in ("jamlab_version", "created", "seed_derivation"):
        assert manifest[field]
    assert RunDir(tmp_path / "run").study() == STUDY


def test_resume_redoes_corrupt_partial_and_leftover_files(tmp_path, same_runs):
    ref, run = tmp_path / "ref", tmp_path / "run"
    run_study(STUDY, ref, IN_PROCESS)
    run_study(STUDY, run, IN_PROCESS)
    rd = RunDir(run)
    keys = STUDY.keys()
    # truncated file, garbage bytes, a file without its completion marker, a missing file
    p0 = rd.sample_path(keys[0])
    p0.write_bytes(p0.read_bytes()[: p0.stat().st_size // 2])
    rd.sample_path(keys[1]).write_bytes(b"not hdf5 at all")
    with h5py.File(rd.sample_path(keys[2]), "a") as h5:
        del h5.attrs["complete"]
    rd.sample_path(keys[3]).unlink()
    # another sample's file in the wrong place
    os.replace(rd.sample_path(keys[5]), rd.sample_path(keys[4]))
    leftover = rd.sample_path(keys[6]).with_name(".sample-00000.h5.abc.tmp")
    leftover.write_bytes(b"half a file")
    states = rd.scan(STUDY)
    assert [states[k] for k in keys[:6]] == [
        "corrupt", "corrupt", "corrupt", "pending", "corrupt", "pending"
    ]  # fmt: skip
    summary = run_study(STUDY, run, IN_PROCESS)
    assert summary.done == 6 and summary.skipped == len(keys) - 6
    assert summary.removed_temporaries == 1 and not leftover.exists()
    assert set(rd.scan(STUDY).values()) == {"done"}
    same_runs(ref, run)


@pytest.mark.parametrize("member", ["trace/gamma", "packing"])
def test_a_sample_with_a_dangling_link_is_damaged(tmp_path, member):
    """A member of a sample file that is a soft link to nothing: the run counts the sample
    corrupt (redone on resume), and the sample readers call the file damaged instead of raising
    h5py's KeyError (read_sample took a dangling ``packing`` group for none at all)."""
    from jamlab.runs import prepared_packing, read_sample

    study = Study(phi=[0.8], n=[8], samples=1, dgamma=1e-3, gamma_max=2e-3, task="toy")
    run_study(study, tmp_path / "run", IN_PROCESS)
    rd = RunDir(tmp_path / "run")
    key = study.keys()[0]
    path = rd.sample_path(key)
    with h5py.File(path, "a") as h5:
        del h5[member]
        h5[member] = h5py.SoftLink("/nothere")
    assert rd.state(key, study) == "corrupt"
    for read in (read_sample, prepared_packing):
        with pytest.raises(ValueError, match=f"damaged file {path}: /{member} is a link to"):
            read(path)

def _flaky(study, key, seed):
    if key.index == 1:
        raise SampleFailed("minimisation did not converge (test)")
    if key.index == 2 and key.n == 8:
        raise ZeroDivisionError("boom")
    return toy_task(study, key, seed)


def test_failures_are_recorded_and_retried(tmp_path, same_runs):
    run = tmp_path / "run"
    summary = run_study(STUDY, run, IN_PROCESS, task=_flaky)
    n_fail = 2 * 2 + 2  # index 1 in every (φ, N) cell, index 2 at N=8
    assert summary.failed == n_fail and summary.done == STUDY.n_samples - n_fail
    rd = RunDir(run)
    failed = [k for k, s in rd.scan(STUDY).items() if s == "failed"]
    assert len(failed) == n_fail
    info = rd.read_failure(failed[0])
    assert info["error_type"] in ("SampleFailed", "ZeroDivisionError") and info["traceback"]
    # --skip-failed leaves them; the default retries them (here with a task that works)
    assert run_study(STUDY, run, IN_PROCESS, retry_failed=False).done == 0
    summary = run_study(STUDY, run, IN_PROCESS)
    assert summary.done == n_fail and summary.failed == 0
    assert not list(run.rglob("*.failed.json"))
    run_study(STUDY, tmp_path / "ref", IN_PROCESS)
    same_runs(tmp_path / "ref", run)
    # ... and each retried sample keeps its failure: what, and on which machine
    for key in failed:
        assert rd.retried_path(key).is_file()
        (past,) = rd.failures(key)
        expected = "SampleFailed" if key.index == 1 else "ZeroDivisionError"
        assert past["error_type"] == expected and past["index"] == key.index
        assert past["machine"]["cpu"] == machine()["cpu"] and past["trace"] is None
    assert len(list(run.rglob("*.retried.json"))) == n_fail
    counts = open_run(run).failures
    for key in STUDY.keys():
        assert int(counts.sel(phi=key.phi_label, N=key.n, sample=key.index)) == (key in failed)


def test_every_failure_and_its_trace_are_kept_until_and_after_a_retry_finishes(tmp_path):
    """A failure record keeps the earlier failures (oldest first) and a copy of the checkpoint's
    trace at each failure; a retry that finishes the sample turns the record into
    ``.retried.json`` and the trace into ``.retried.h5`` (nothing about a failure is erased)."""
    rd = RunDir.open(tmp_path / "run", STUDY)
    with rd.lock():
        rd.start(STUDY)
    key = STUDY.keys()[0]
    seed = sample_seed(STUDY.seed, key)
    saved = rd.checkpoint_dir(key) / CHECKPOINT_TRACE
    saved.parent.mkdir(parents=True)
    for n, cpu in enumerate(("cpu A", "cpu B"), start=1):
        saved.write_bytes(f"trace at failure {n}".encode())
        rd.write_failure(key, SampleFailure("SampleFailed", f"failure {n}", "tb", 1.0,
                                            machine={"cpu": cpu}), seed)
        assert rd.state(key) == "failed"
        record = rd.read_failure(key)
        assert record["message"] == f"failure {n}" and record["machine"] == {"cpu": cpu}
        assert [r["message"] for r in record.get("earlier", [])] == [f"failure {k}"
                                                                     for k in range(1, n)]
        assert record["trace"] == rd.failure_trace_path(key).name
        assert all(r["trace"] is None for r in record.get("earlier", []))  # the copy replaced
        assert rd.failure_trace_path(key).read_bytes() == f"trace at failure {n}".encode()
    # a failure with no checkpoint trace names none (the copy of the earlier one stays)
    saved.unlink()
    rd.write_failure(key, SampleFailure("ZeroDivisionError", "failure 3", "tb"), seed)
    assert rd.read_failure(key)["trace"] is None and rd.read_failure(key)["machine"] is None
    assert [r["message"] for r in rd.failures(key)] == ["failure 1", "failure 2", "failure 3"]
    rd.write_sample(key, toy_task(STUDY, key, seed), seed, STUDY)
    assert rd.state(key) == "done"
    assert not rd.failure_path(key).exists() and not rd.failure_trace_path(key).exists()
    kept = json.loads(rd.retried_path(key).read_text())["failures"]
    assert [r["message"] for r in kept] == ["failure 1", "failure 2", "failure 3"]
    assert all("earlier" not in r for r in kept)
    # the kept trace is failure 2's (the last with a checkpoint), and only its record names it
    assert [r["trace"] for r in kept] == [None, "sample-00000.retried.h5", None]
    assert (rd.retried_path(key).parent / kept[1]["trace"]).read_bytes() == b"trace at failure 2"
    # a later failure and retry of the same sample add to the kept list
    rd.write_failure(key, SampleFailure("SampleFailed", "failure 4", "tb"), seed)
    rd.write_sample(key, toy_task(STUDY, key, seed), seed, STUDY)
    assert [r["message"] for r in rd.failures(key)] == [f"failure {k}" for k in range(1, 5)]


def test_refusals_touch_nothing(tmp_path):
    run = tmp_path / "run"
    run_study(STUDY, run, IN_PROCESS)
    before = {p: (p.stat().st_mtime_ns, p.read_bytes()) for p in run.rglob("*") if p.is_file()}
    other = Study(**{**STUDY.to_dict(), "dgamma": 2e-3})
    with pytest.raises(RunError, match="different study.*dgamma"):
        run_study(other, run, IN_PROCESS)
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "x.txt").write_text("mine")
    with pytest.raises(RunError, match="not empty"):
        run_study(STUDY, tmp_path / "junk", IN_PROCESS)
    (tmp_path / "file").write_text("x")
    with pytest.raises(RunError, match="not a directory"):
        run_study(STUDY, tmp_path / "file" / "run", IN_PROCESS)
    after = {p: (p.stat().st_mtime_ns, p.read_bytes()) for p in run.rglob("*") if p.is_file()}
    assert before == after
    assert (tmp_path / "junk" / "x.txt").read_text() == "mine"


def test_a_second_driver_is_refused(tmp_path):
    run_study(STUDY, tmp_path / "run", IN_PROCESS)
    with RunDir(tmp_path / "run").lock(), pytest.raises(RunError, match="another jamlab"):
        run_study(STUDY, tmp_path / "run", IN_PROCESS)


def test_sample_file_layout(tmp_path):
    run_study(STUDY, tmp_path / "run", IN_PROCESS)
    key = STUDY.keys()[-1]
    path = tmp_path / "run" / "samples" / "phi=0.8" / "N=12" / "sample-00002.h5"
    assert RunDir(tmp_path / "run").sample_path(key) == path
    expected = toy_task(STUDY, key, int(h5py.File(path, "r").attrs["seed"]))
    with h5py.File(path, "r") as h5:
        assert h5.attrs["complete"] and h5.attrs["phi"] == "0.8"
        assert (h5.attrs["n"], h5.attrs["index"]) == (12, 2)
        for name, values in expected.traces.items():
            np.testing.assert_array_equal(h5["trace"][name][()], values)
        np.testing.assert_array_equal(h5["packing/positions"][()], expected.arrays["positions"])
