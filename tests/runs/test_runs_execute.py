"""Execution: results do not depend on worker count, order or backend; loading into xarray."""

import os
import random
import subprocess
import sys

import numpy as np
import pytest

from jamlab.runs import Execution, RunDir, Study, open_run, read_sample, run_study, sample_seed
from jamlab.runs.execute import slurm_cluster_kwargs
from jamlab.runs.tasks import SampleFailure, SampleResult, run_sample, toy_task

STUDY = Study(phi=["jamming", 0.75], n=[8, 16], samples=3, dgamma=1e-3, gamma_max=4e-3, task="toy")


def test_worker_count_does_not_change_results(tmp_path, same_runs):
    run_study(STUDY, tmp_path / "w0", Execution(workers=0))
    run_study(STUDY, tmp_path / "w2", Execution(workers=2))
    same_runs(tmp_path / "w0", tmp_path / "w2")


def test_order_does_not_change_results(tmp_path):
    run_study(STUDY, tmp_path / "run", Execution(workers=0))
    rd = RunDir(tmp_path / "run")
    keys = STUDY.keys()
    random.Random(1).shuffle(keys)
    for key in keys:
        outcome = run_sample(STUDY, key, sample_seed(STUDY.seed, key))
        stored = read_sample(rd.sample_path(key))
        for name, values in outcome.traces.items():
            assert stored["trace"][name].tobytes() == np.asarray(values).tobytes()


def _partial(study, key, seed):
    """The toy task, except: index 2 at N=16 raises; index 1 at N=8 returns a trace one row
    short (not a whole sample of the study)."""
    if key.index == 2 and key.n == 16:
        raise RuntimeError("no")
    result = toy_task(study, key, seed)
    result.attrs["phi_actual"] = 0.7 + key.index
    if key.index == 1 and key.n == 8:
        result.traces = {k: v[:-1] for k, v in result.traces.items()}
    return result


def test_open_run_matches_the_files_and_fills_failures_with_nan(tmp_path):
    run = tmp_path / "run"
    summary = run_study(STUDY, run, Execution(workers=0), task=_partial)
    # a short trace is recorded as a failure (never written as a finished sample)
    assert summary.failed == 2 + 2 and summary.done == STUDY.n_samples - 4
    ds = open_run(run, fields=("gamma", "energy", "plastic"))
    rows = round(STUDY.gamma_max / STUDY.dgamma) + 1
    assert ds.sizes == {"phi": 2, "N": 2, "sample": 3, "step": rows}
    assert list(ds.phi.values) == ["jamming", "0.75"]
    rd = RunDir(run)
    for key in STUDY.keys():
        cell = ds.sel(phi=key.phi_label, N=key.n, sample=key.index)
        assert int(cell.seed) == sample_seed(STUDY.seed, key)
        if (key.index, key.n) in ((2, 16), (1, 8)):
            assert str(cell.status.values) == "failed"
            assert np.isnan(cell.energy.values).all() and int(cell.n_steps) == 0
            if key.n == 8:
                assert rd.read_failure(key)["error_type"] == "InvalidResult"
            continue
        stored = read_sample(rd.sample_path(key))
        assert int(cell.n_steps) == len(stored["trace"]["energy"]) == rows
        np.testing.assert_array_equal(cell.energy.values, stored["trace"]["energy"])
        np.testing.assert_array_equal(cell.plastic.values, stored["trace"]["plastic"])
        assert float(cell.phi_actual) == stored["attrs"]["phi_actual"]
    with pytest.raises(ValueError, match="unknown trace field"):
        open_run(run, fields=("energi",))


def test_run_sample_turns_exceptions_into_failures():
    key = STUDY.keys()[0]
    out = run_sample(STUDY, key, 1, task=_partial)
    assert isinstance(out, SampleResult)
    bad = run_sample(STUDY, STUDY.keys()[-1], 1, task=_partial)
    assert isinstance(bad, SampleFailure) and bad.error_type == "RuntimeError"
    assert "_partial" in bad.traceback
    assert toy_task(STUDY, key, 1).traces["energy"].tobytes() == (
        toy_task(STUDY, key, 1).traces["energy"].tobytes()
    )


def test_execution_options_are_validated():
    with pytest.raises(ValueError, match="either --scheduler or --cluster"):
        Execution(scheduler="tcp://127.0.0.1:1", cluster="slurm")
    with pytest.raises(ValueError, match="tcp://"):
        Execution(scheduler="127.0.0.1:8786")
    with pytest.raises(ValueError, match="unknown cluster"):
        Execution(cluster="pbs")
    with pytest.raises(ValueError, match="workers"):
        Execution(workers=-1)
    with pytest.raises(ValueError, match="unknown slurm option"):
        Execution(cluster="slurm", slurm={"gpus": 1})


def test_slurm_options_map_to_jobqueue():
    kwargs, jobs = slurm_cluster_kwargs(
        {
            "jobs": 3,
            "cores": 8,
            "processes": 8,
            "memory": "16GiB",
            "queue": "short",
            "account": "proj",
            "job_extra_directives": ["--exclusive"],
        }  # fmt: skip
    )
    assert jobs == 3
    assert kwargs["cores"] == 8 and kwargs["processes"] == 8 and kwargs["memory"] == "16GiB"
    assert kwargs["queue"] == "short" and kwargs["account"] == "proj"
    from dask_jobqueue import SLURMCluster

    # the job script is built without a SLURM installation; nothing is submitted
    with SLURMCluster(**kwargs, scheduler_options={"host": "127.0.0.1"}) as cluster:
        script = cluster.job_script()
    for line in ("#SBATCH -p short", "#SBATCH -A proj", "#SBATCH --exclusive",
                 "export OMP_NUM_THREADS=1"):  # fmt: skip
        assert line in script


def _sleeper(study, key, seed):
    import time

    time.sleep(0.3)  # wall time, no CPU time
    return toy_task(study, key, seed)


def _spinner(study, key, seed):
    import time

    end = time.perf_counter() + 0.3
    while time.perf_counter() < end:  # CPU time ≈ wall time
        pass
    return toy_task(study, key, seed)


def test_a_sample_records_its_cpu_time_beside_its_wall_time(tmp_path):
    key = STUDY.keys()[0]
    slept = run_sample(STUDY, key, 1, task=_sleeper)
    spun = run_sample(STUDY, key, 1, task=_spinner)
    assert slept.seconds >= 0.3 and 0.0 <= slept.cpu_seconds < 0.15
    # (a shared machine may take the core away for part of the spin: a loose lower bound)
    assert spun.seconds >= 0.3 and 0.05 < spun.cpu_seconds <= spun.seconds + 0.01
    study = Study(phi=["jamming"], n=[8], samples=2, dgamma=1e-3, gamma_max=4e-3, task="toy")
    run_study(study, tmp_path / "r", Execution(workers=0), task=_sleeper)
    ds = open_run(tmp_path / "r")
    for k in study.keys():
        attrs = read_sample(RunDir(tmp_path / "r").sample_path(k))["attrs"]
        cell = ds.sel(phi=k.phi_label, N=k.n, sample=k.index)
        assert float(cell.cpu_seconds) == attrs["cpu_seconds"] < 0.15 < attrs["seconds"]


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity") or (os.cpu_count() or 1) < 2,
                    reason="needs CPU affinity and two CPUs")
def test_the_default_worker_count_is_the_cores_this_process_may_use():
    # pinned to one CPU (as a SLURM allocation or taskset does) on a machine with more: one
    # local process by default, not os.cpu_count() of them
    code = ("import os; os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}); "
            "from jamlab.runs import Execution; from jamlab.threads import usable_cores; "
            "print(os.cpu_count(), usable_cores(), Execution().describe(12), "
            "Execution(workers=3).describe(12), Execution(workers=3).describe(1), sep='|')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    machine, usable, default, three, one = out.stdout.strip().split("|")
    assert int(machine) >= 2 and int(usable) == 1
    assert default == "1 local process"
    # more than the usable cores: kept (the results do not depend on it), and said
    assert three == "3 local processes sharing 1 usable core"
    assert one == "1 local process"
