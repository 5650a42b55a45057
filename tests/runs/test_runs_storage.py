"""Run directory: manifest, atomic sample files, corrupt/partial detection, failures, resume."""

import json
import os

import h5py
import numpy as np
import pytest

from jamlab.runs import Execution, RunDir, RunError, SampleFailed, Study, run_study
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
