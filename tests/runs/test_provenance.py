"""Where a sample ran (``jamlab.provenance``, ``jamlab.runs.origin``): each sample file records
its invocations' machine and libraries, a resumed sample every invocation, and ``jamlab
status`` groups a run's samples by machine. The records are checked against the sources read
independently here (``/proc/cpuinfo``, the packages' own ``__version__``, ``git`` run from the
repository's root), the status lines against the files read with h5py."""

from __future__ import annotations

import json
import platform
import shutil
import subprocess
from pathlib import Path

import h5py
import numba
import numpy as np
import pytest
import scipy
from runs_helpers import Stop, stop_after

from cli_helpers import jamlab
from jamlab import provenance
from jamlab.runs import Execution, RunDir, Study, run_study, sample_seed
from jamlab.runs.origin import machine_census, sample_provenance
from jamlab.runs.physics import PROVENANCE, TRACE, prepare_and_shear

ROOT = Path(__file__).resolve().parents[2]
TOY = Study(phi=["jamming", 0.75], n=[8, 16], samples=2, dgamma=1e-3, gamma_max=4e-3, task="toy")
# a small fixed-pressure sample saved every 5 of its 23 steps (as in test_runs_checkpoint.py)
SAVED = dict(phi=["jamming"], n=[16], samples=1, dgamma=5e-3, gamma_max=0.115, seed=4,
             pressure=1e-2, checkpoint_every=5)


def test_the_machine_record_against_its_sources():
    record = provenance.machine()
    models = [line.split(":", 1)[1].strip() for line in
              Path("/proc/cpuinfo").read_text().splitlines()
              if line.lower().startswith("model name")] if Path("/proc/cpuinfo").exists() else []
    if models:
        assert record["cpu"] == models[0]
    assert record["numpy"] == np.__version__
    assert record["scipy"] == scipy.__version__
    assert record["numba"] == numba.__version__
    assert record["python"] == platform.python_version()
    assert record["llvm_cpu"]  # LLVM always names the host CPU
    # the record is the process's: the same dict each time, a copy the caller may change
    again = provenance.machine()
    again["cpu"] = "changed"
    assert provenance.machine() == record


def test_the_commit_is_the_checkouts_and_says_when_the_package_differs():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                          text=True, check=False)
    if head.returncode != 0:  # e.g. a checkout owned by another user ("dubious ownership")
        assert provenance.commit() == ""
        return
    head = head.stdout.strip()
    changed = subprocess.run(["git", "diff", "HEAD", "--name-only", "--", "src/jamlab"],
                             cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
    assert provenance.commit() == head + ("+dirty" if changed else "")


def test_the_machine_key_ignores_host_os_and_commit_and_nothing_else():
    record = provenance.segment(3)
    assert record["resumed_from"] == 3 and record["host"] == platform.node()
    key = provenance.machine_key(record)
    for name, value in (("host", "elsewhere"), ("jamlab_commit", "0" * 40), ("os", "other"),
                        ("resumed_from", -1), ("h5py", "0.0")):
        assert provenance.machine_key({**record, name: value}) == key, name
    for name in provenance.KEY_FIELDS:
        assert provenance.machine_key({**record, name: "other"}) != key, name


def test_continued_records():
    here = provenance.segment
    assert provenance.continued(None, -1) == [here(-1)]
    assert provenance.continued([here(-1)], -1) == [here(-1)]  # afresh: earlier ones dropped
    earlier = [{**here(-1), "cpu": "elsewhere"}]
    assert provenance.continued(json.dumps(earlier), 30) == [*earlier, here(30)]
    for unknown in (None, "not JSON", "{}", "[1, 2]", "[]", b"\xff"):
        assert provenance.continued(unknown, 30) == [provenance.UNRECORDED, here(30)], unknown


def test_every_sample_of_a_run_records_where_it_ran(tmp_path):
    run_study(TOY, tmp_path / "run", Execution(workers=0))
    rd = RunDir(tmp_path / "run")
    for key in TOY.keys():
        with h5py.File(rd.sample_path(key), "r") as h5:
            records = json.loads(h5.attrs["provenance"])
        assert records == [provenance.segment(-1)]
    census = machine_census(rd, TOY)
    assert list(census.samples.values()) == [TOY.keys()]
    assert not census.mixed and not census.unrecorded and not census.partly_unknown


def test_a_resumed_sample_records_each_invocation(tmp_path):
    study = Study(**SAVED)
    key = study.keys()[0]
    seed = sample_seed(study.seed, key)
    folder = tmp_path / "ck"
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed, folder, progress=stop_after(12))
    assert json.loads((folder / PROVENANCE).read_text()) == [provenance.segment(-1)]
    # the first invocation ran on another machine: its record says so
    other = {**provenance.segment(-1), "cpu": "another CPU", "llvm_cpu": "znver9"}
    (folder / PROVENANCE).write_text(json.dumps([other]))
    with pytest.raises(Stop):
        prepare_and_shear(study, key, seed, folder, progress=stop_after(17))
    resumed = prepare_and_shear(study, key, seed, folder)
    assert resumed.resumed_from == 15
    assert resumed.provenance == [other, provenance.segment(10), provenance.segment(15)]
    # the shear's own trace keeps its invocations too (it knows nothing of the edit above)
    with h5py.File(folder / TRACE, "r") as h5:
        in_trace = json.loads(h5.attrs["provenance"])
    assert in_trace == [provenance.segment(-1), provenance.segment(10), provenance.segment(15)]
    # a checkpoint from before the records: its earlier invocations are unknown, and said so
    (folder / PROVENANCE).unlink()
    again = prepare_and_shear(study, key, seed, folder)  # finished and saved: read back
    assert again.provenance == [provenance.UNRECORDED, provenance.segment(23)]
    # starting afresh forgets the earlier records (a damaged checkpoint is replaced)
    shutil.rmtree(folder)
    assert prepare_and_shear(study, key, seed, folder).provenance == [provenance.segment(-1)]


def test_status_names_machines_and_the_samples_that_ran_on_several(tmp_path):
    run = tmp_path / "run"
    run_study(TOY, run, Execution(workers=0))
    rd = RunDir(run)
    keys = TOY.keys()
    here = provenance.segment(-1)
    elsewhere = {**here, "cpu": "another CPU", "numpy": "1.0"}
    edits = {keys[0]: [elsewhere, {**here, "resumed_from": 500}],  # resumed here
             keys[1]: [elsewhere],  # ran elsewhere
             keys[2]: [dict(provenance.UNRECORDED), {**here, "resumed_from": 200}],  # too old
             keys[3]: None}  # written before the records
    for key, records in edits.items():
        with h5py.File(rd.sample_path(key), "r+") as h5:
            if records is None:
                del h5.attrs["provenance"]
            else:
                h5.attrs["provenance"] = json.dumps(records)
    # the census, from the files read back
    census = machine_census(rd, TOY)
    assert [sample_provenance(rd, k) for k in keys[:2]] == [edits[keys[0]], edits[keys[1]]]
    assert census.mixed == [keys[0]] and census.partly_unknown == [keys[2]]
    assert census.unrecorded == [keys[3]]
    here_key, other_key = provenance.machine_key(here), provenance.machine_key(elsewhere)
    assert census.samples[other_key] == keys[:2]
    assert census.samples[here_key] == [keys[0], keys[2], *keys[4:]]
    # and what jamlab status prints of it
    r = jamlab("status", run)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert "machines: 2 recorded" in r.stdout
    counts = sorted(int(line.split(",")[1].split()[0]) for line in lines
                    if line.strip().startswith("machine "))
    assert counts == sorted([len(keys) - 2, 2])
    mixed = [line for line in lines if "ran on more than one machine (1)" in line]
    assert mixed and f"sample {keys[0].index}" in mixed[0] and f"N={keys[0].n}" in mixed[0]
    assert any("earlier machine unknown (1)" in line for line in lines)
    assert any("1 finished samples record no machine" in line for line in lines)


def test_prepared_and_minimised_packings_record_where_they_were_computed(tmp_path):
    """`jamlab prepare` and `jamlab minimize` compute their packings: the files say where
    (one record, started afresh); `jamlab shear` writes its trace's records (one invocation)."""
    prepared, minimised, trace = tmp_path / "p.h5", tmp_path / "m.h5", tmp_path / "t.h5"
    for args in (("prepare", "--phi", "0.8", "--n", "16", "--seed", "1", "--out", prepared,
                  "--quiet"),
                 ("minimize", prepared, "--out", minimised),
                 ("shear", prepared, "--dgamma", "1e-3", "--gamma-max", "2e-3", "--out", trace)):
        r = jamlab(*args)
        assert r.returncode == 0, r.stderr
    for path in (prepared, minimised, trace):
        with h5py.File(path, "r") as h5:
            records = json.loads(h5.attrs["provenance"])
        assert len(records) == 1 and records[0]["resumed_from"] == -1, path
        record = records[0]
        # the subprocess's own record: this machine and these libraries, its own host
        assert provenance.machine_key(record) == provenance.machine_key(provenance.machine())
        assert record["host"] == platform.node()


def test_a_field_one_record_lacks_is_unknown_not_a_difference(tmp_path):
    here = provenance.segment(-1)
    older = {k: v for k, v in here.items() if k != "blas_cores"}  # written before the field
    assert not provenance.differ(here, older) and not provenance.differ(older, here)
    assert provenance.differ(here, {**older, "cpu": "another CPU"})
    assert provenance.machine_key(older) != provenance.machine_key(here)  # grouped apart
    assert "BLAS kernels not recorded" in provenance.summary_text(older)
    # a sample resumed by a newer jamlab on the same machine did not run on two machines
    run_study(TOY, tmp_path / "run", Execution(workers=0))
    rd = RunDir(tmp_path / "run")
    key = TOY.keys()[0]
    with h5py.File(rd.sample_path(key), "r+") as h5:
        h5.attrs["provenance"] = json.dumps([older, {**here, "resumed_from": 2}])
    census = machine_census(rd, TOY)
    assert census.mixed == [] and len(census.machines) == 2


@pytest.mark.parametrize("mode", ["", "native"])
def test_blas_list_does_not_depend_on_what_the_process_imported_before(mode):
    """The BLAS list is a key field of a machine. With JAMLAB_CHOLMOD_BLAS=native a process that
    had not imported scipy's linear algebra listed one BLAS less than one that had (`jamlab
    warmup` against a run's worker): the same machine recorded as two."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, JAMLAB_CHOLMOD_BLAS=mode) if mode else {
        k: v for k, v in os.environ.items() if k != "JAMLAB_CHOLMOD_BLAS"}
    code = "from jamlab import provenance; print(provenance.machine()['blas_cores'])"
    lists = [subprocess.run([sys.executable, "-c", pre + code], env=env, capture_output=True,
                            text=True, check=True).stdout
             for pre in ("", "import scipy.sparse.linalg; ", "import cvxopt; ")]
    assert lists[0] and lists[0] == lists[1], lists
    # cvxopt imported before jamlab chose its core: the kernels may differ, the libraries not
    assert [c.rsplit(" ", 1)[0] for c in lists[2].strip().split("; ")] == [
        c.rsplit(" ", 1)[0] for c in lists[0].strip().split("; ")]
