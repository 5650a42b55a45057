"""`jamlab run` and `jamlab status` end to end: SIGKILL + resume, real Dask cluster, bad input."""

import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
from runs_helpers import assert_same_runs, sample_files

from cli_helpers import jamlab, one_line_error

BIN = Path(sys.executable).parent
TASK = "toy"
STUDY_ARGS = ["--phi", "jamming", "0.8", "--n", "8", "12", "--dgamma", "1e-3", "--gamma-max",
              "4e-3", "--seed", "3", "--task", TASK]  # fmt: skip


def snapshot(root: Path):
    return {
        str(p.relative_to(root)): (p.stat().st_mtime_ns, p.read_bytes() if p.is_file() else None)
        for p in sorted(root.rglob("*"))
    }


def test_run_status_and_toml(tmp_path):
    r = jamlab("run", *STUDY_ARGS, "--samples", 2, "--out", tmp_path / "a", "--workers", 1)
    assert r.returncode == 0, r.stderr
    assert "8 samples written" in r.stderr
    assert len(sample_files(tmp_path / "a")) == 8
    r = jamlab("status", tmp_path / "a")
    assert r.returncode == 0
    rows = [line for line in r.stdout.splitlines()
            if line.startswith("│") and ("jamming" in line or "0.8" in line)]  # fmt: skip
    assert len(rows) == 4 and all(" 2 " in row for row in rows)
    (tmp_path / "s.toml").write_text(
        'phi = ["jamming", 0.8]\nn = [8, 12]\nsamples = 2\ndgamma = 1e-3\ngamma_max = 4e-3\n'
        f'seed = 3\ntask = "{TASK}"\nout = "b"\n[execution]\nworkers = 1\n'
    )
    r = jamlab("run", tmp_path / "s.toml", "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert_same_runs(tmp_path / "a", tmp_path / "b")
    # same study again from the flags: nothing to do
    r = jamlab("run", *STUDY_ARGS, "--samples", 2, "--out", tmp_path / "b", "--workers", 1)
    assert r.returncode == 0 and "0 samples written" in r.stderr and "8 already done" in r.stderr


@pytest.mark.slow
def test_bad_input_is_one_line_and_touches_nothing(tmp_path):
    run = tmp_path / "run"
    r = jamlab("run", *STUDY_ARGS, "--samples", 2, "--out", run, "--workers", 1, "--quiet")
    assert r.returncode == 0, r.stderr
    (tmp_path / "afile").write_text("x")
    before = snapshot(tmp_path)
    base = ["--samples", "2", "--out", run, "--workers", "1"]
    cases = {
        "phi": (["--phi", "jammed", "0.8"], "unknown phi 'jammed'"),
        "n": (["--n", "8", "-12"], "n must be an integer >= 2, got -12"),
        "samples": (["--samples", "-3"], "samples must be an integer in [1, 1000000], got -3"),
        "dgamma": (["--dgamma", "4e-3"], "dgamma must be smaller than gamma_max"),
        "mismatch": (["--seed", "4"], "different study (seed: 3 != 4"),
        "unwritable": (["--out", tmp_path / "afile" / "run"], "not a directory"),
        "scheduler": (["--scheduler", "nowhere"], "tcp://HOST:8786"),
        "checkpoint": (["--checkpoint-every", "-5"],
                       "checkpoint_every must be an integer in [0, 10000000]"),
    }
    for name, (extra, message) in cases.items():
        line = one_line_error(jamlab("run", *STUDY_ARGS, *base, *extra))
        assert message in line, (name, line)
    if os.geteuid() != 0:  # root writes anywhere: permissions cannot make a directory unwritable
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o555)
        try:
            line = one_line_error(jamlab("run", *STUDY_ARGS, *base, "--out", locked / "run"))
            assert "not writable" in line
        finally:
            locked.chmod(0o755)
        locked.rmdir()
    assert snapshot(tmp_path) == before
    one_line_error(jamlab("status", tmp_path / "afile"))


def _wait_for_a_sample(run: Path, proc, timeout=120.0):
    start = time.monotonic()
    while not sample_files(run):
        assert proc.poll() is None, "the run ended before writing a sample"
        assert time.monotonic() - start < timeout
        time.sleep(0.02)


@pytest.mark.slow
def test_sigkill_then_resume_equals_an_uninterrupted_run(tmp_path):
    rng = random.Random(int(os.environ.get("JAMLAB_TEST_SEED", "20170214")))
    args = [*STUDY_ARGS, "--samples", "6", "--workers", "2", "--quiet"]
    ref, run = tmp_path / "ref", tmp_path / "run"
    assert jamlab("run", *args, "--out", ref).returncode == 0
    total = len(sample_files(ref))
    env = {**os.environ, "JAMLAB_TOY_DELAY": "0.15"}  # slow samples: the kill lands mid-run
    for attempt in range(2):
        proc = subprocess.Popen(
            [sys.executable, "-m", "jamlab", "run", *args, "--out", str(run)],
            env=env, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        )  # fmt: skip
        try:
            _wait_for_a_sample(run, proc)
            time.sleep(rng.uniform(0.0, 0.8))
        finally:
            os.killpg(proc.pid, signal.SIGKILL)  # the driver and its worker processes
            proc.wait(timeout=30)
        assert proc.returncode == -signal.SIGKILL
        done = sample_files(run)
        assert 0 < len(done) < total, f"kill {attempt} did not land mid-run"
        for path in done.values():  # never an unreadable sample file
            with h5py.File(path, "r") as h5:
                assert h5.attrs["complete"]
    r = jamlab("run", *args, "--out", run)
    assert r.returncode == 0, r.stderr
    assert not list(run.rglob("*.tmp"))
    assert_same_runs(ref, run)


@pytest.mark.slow
def test_sigkill_mid_sample_then_resume_from_its_checkpoint(tmp_path):
    # one physics sample saved every 50 of its 2000 steps; the run is killed once the first
    # saves are on disk, and the same command resumes the sample from its last save
    args = ["--phi", "0.8", "--n", "64", "--samples", "1", "--dgamma", "1e-4", "--gamma-max",
            "0.2", "--seed", "2", "--checkpoint-every", "50", "--workers", "1"]  # fmt: skip
    ref, run = tmp_path / "ref", tmp_path / "run"
    assert jamlab("run", *args, "--quiet", "--out", ref).returncode == 0
    assert not (ref / "checkpoints").exists()  # removed with the sample written
    proc = subprocess.Popen(
        [sys.executable, "-m", "jamlab", "run", *args, "--quiet", "--out", str(run)],
        start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )  # fmt: skip
    trace = run / "checkpoints" / "phi=0.8" / "N=64" / "sample-00000" / "trace.h5"
    start = time.monotonic()
    try:
        while not trace.is_file():
            assert proc.poll() is None, "the run ended before its first save"
            assert time.monotonic() - start < 120
            time.sleep(0.01)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    assert not sample_files(run), "the kill did not land mid-sample"
    r = jamlab("status", run)
    assert r.returncode == 0 and "checkpoint phi=0.8 N=64 sample=0: at step " in r.stdout
    r = jamlab("run", *args, "--out", run)
    assert r.returncode == 0, r.stderr
    assert "1 with a checkpoint" in r.stderr and "(1 resumed from a checkpoint)" in r.stderr
    assert not (run / "checkpoints").exists()
    assert_same_runs(ref, run)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_cluster(tmp_path):
    """A real ``dask scheduler`` and two single-threaded ``dask worker`` processes on loopback."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = []
    logs = tmp_path / "dask-logs"
    logs.mkdir()
    try:
        procs.append(subprocess.Popen(
            [str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
             "--no-dashboard"],
            stdout=subprocess.DEVNULL, stderr=open(logs / "scheduler.log", "w"),
        ))  # fmt: skip
        for i in range(2):
            procs.append(subprocess.Popen(
                [str(BIN / "dask"), "worker", address, "--nthreads", "1", "--nworkers", "1",
                 "--host", "127.0.0.1", "--no-dashboard", "--local-directory",
                 str(tmp_path / f"w{i}")],
                stdout=subprocess.DEVNULL, stderr=open(logs / f"worker{i}.log", "w"),
            ))  # fmt: skip
        from distributed import Client

        deadline = time.monotonic() + 60
        while True:
            try:
                with Client(address, timeout="5s") as client:
                    client.wait_for_workers(2, timeout=60)
                    break
            except OSError:
                assert time.monotonic() < deadline, (logs / "scheduler.log").read_text()
                time.sleep(0.5)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def _physics_available() -> bool:
    try:
        from jamlab.spheres import packing
    except ImportError:
        return False
    return hasattr(packing, "jam") and hasattr(packing, "prepare")


@pytest.mark.slow
def test_dask_scheduler_gives_the_local_results(tmp_path, dask_cluster):
    # the real sample (prepare + shear) when it is available, else the toy task
    if _physics_available():
        args = ["--phi", "jamming", "0.8", "--n", "16", "--dgamma", "1e-3", "--gamma-max",
                "3e-3", "--seed", "3", "--samples", "2", "--quiet"]  # fmt: skip
    else:
        args = [*STUDY_ARGS, "--samples", "3", "--quiet"]
    local, remote = tmp_path / "local", tmp_path / "dask"
    r = jamlab("run", *args, "--out", local, "--workers", "2")
    assert r.returncode in (0, 1), r.stderr  # 1: some sample failed (recorded, compared below)
    r = jamlab("run", *args, "--out", remote, "--scheduler", dask_cluster)
    assert r.returncode in (0, 1), r.stderr  # 1: some sample failed (recorded, compared below)
    assert_same_runs(local, remote)
    # the workers really ran them: each sample file records the sample's own seed, no sharing
    shutil.rmtree(remote / "samples" / "phi=0.8")
    r = jamlab("run", *args, "--out", remote, "--scheduler", dask_cluster)
    assert r.returncode in (0, 1), r.stderr  # 1: some sample failed (recorded, compared below)
    assert_same_runs(local, remote)
    failed = sorted(p.relative_to(local) for p in local.rglob("*.failed.json"))
    assert failed == sorted(p.relative_to(remote) for p in remote.rglob("*.failed.json"))


def _fails_at_index_1(study, key, seed):
    from jamlab.runs import SampleFailed

    if key.index == 1:
        raise SampleFailed("did not converge (test)")
    from jamlab.runs.tasks import toy_task

    return toy_task(study, key, seed)


def test_status_names_failures_and_the_samples_a_retry_finished(tmp_path):
    from jamlab.provenance import machine
    from jamlab.runs import Execution, Study, run_study

    study = Study(phi=["jamming"], n=[8], samples=2, dgamma=1e-3, gamma_max=4e-3, task="toy")
    run = tmp_path / "run"
    for _ in range(2):  # failed twice
        run_study(study, run, Execution(workers=0), task=_fails_at_index_1)
    r = jamlab("status", run, "--failures")
    assert r.returncode == 0, r.stderr
    (line,) = [x for x in r.stdout.splitlines() if x.startswith("phi=jamming N=8 sample=1")]
    assert "(failed 2 times): SampleFailed: did not converge (test) (" in line
    assert machine()["cpu"] in line
    run_study(study, run, Execution(workers=0))  # the retry finishes it
    r = jamlab("status", run)
    (line,) = [x for x in r.stdout.splitlines() if x.startswith("phi=jamming N=8 sample=1")]
    assert line.startswith("phi=jamming N=8 sample=1: done on a retry after 2 failure(s); "
                           "SampleFailed: did not converge (test)")
    assert not [x for x in r.stdout.splitlines() if x.startswith("phi=jamming N=8 sample=0")]


def test_status_says_which_rule_made_the_plastic_flags(tmp_path):
    # the committed N = 250, p = 1e-4 study was made before the rule that flags jumps the
    # Newton relaxer continued through: its samples lack the attribute that rule writes
    committed = Path(__file__).resolve().parents[2] / "data" / "runs" / "n250-p1e-4-vg"
    with h5py.File(sorted(committed.glob("samples/*/*/sample-*.h5"))[0], "r") as h5:
        assert "shear_n_candidates_continued_sure" not in h5.attrs
    r = jamlab("status", committed)
    assert r.returncode == 0, r.stderr
    assert "plastic flags: 40 of 40 finished samples by the rule before 2026-12-02" in r.stdout
    # a fixed-pressure run made now records how many such jumps it flagged; status sums them
    out = tmp_path / "fp"
    r = jamlab("run", "--phi", "jamming", "--n", 16, "--samples", 2, "--dgamma", 5e-3,
               "--gamma-max", 0.05, "--seed", 4, "--pressure", 1e-2, "--out", out,
               "--workers", 1)
    assert r.returncode == 0, r.stderr
    added = held = 0
    for path in sample_files(out):
        with h5py.File(out / path, "r") as h5:
            added += int(h5.attrs["shear_n_candidates_continued_sure"])
            held += int(h5.attrs["shear_n_candidates_held"])
    r = jamlab("status", out)
    assert (f"plastic flags: the current rule; {added} candidate(s) the Newton relaxer continued "
            f"flagged plastic for the enthalpy they surely released, {held} whose residual a "
            "piece held when redone smaller") in " ".join(r.stdout.split())
    assert "by the rule before" not in r.stdout
    # a sample made by the rule of 2026-12-02 (no shear_n_candidates_held) is named as such
    first = out / sorted(sample_files(out))[0]
    with h5py.File(first, "a") as h5:
        del h5.attrs["shear_n_candidates_held"]
    r = jamlab("status", out)
    assert "plastic flags: 1 of 2 finished samples by the rule before 2026-12-03" in r.stdout
    assert "the current rule" not in r.stdout
    # constant volume has no such rule
    r = jamlab("run", *STUDY_ARGS, "--samples", 1, "--out", tmp_path / "cv", "--workers", 1)
    assert r.returncode == 0, r.stderr
    assert "plastic flags" not in jamlab("status", tmp_path / "cv").stdout
