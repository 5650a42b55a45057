"""`jamlab.runs.cost` and `jamlab status`'s cost lines: the times are the sample files' own
attributes (read here independently with h5py) and the projection is their mean times the work
left, with checkpoints counted by their steps."""

import dataclasses

import h5py
import pytest

from cli_helpers import jamlab
from jamlab.runs import Execution, RunDir, Study, cost, run_study
from jamlab.runs.cost import cell_costs

STUDY = Study(phi=["jamming", 0.8], n=[8], samples=4, dgamma=1e-3, gamma_max=5e-3, seed=2,
              task="toy")  # fmt: skip


@pytest.fixture
def run(tmp_path):
    run_study(STUDY, tmp_path / "r", Execution(workers=0))
    return RunDir(tmp_path / "r")


def recorded(run: RunDir, phi: str, n: int) -> dict[int, float]:
    out = {}
    for path in sorted((run.path / "samples" / f"phi={phi}" / f"N={n}").glob("sample-*.h5")):
        with h5py.File(path, "r") as h5:
            if "cpu_seconds" in h5.attrs:
                out[int(h5.attrs["index"])] = float(h5.attrs["cpu_seconds"])
    return out


def test_costs_are_the_files_times_and_the_work_left(run):
    jam = [k for k in STUDY.keys() if k.phi_label == "jamming"]
    run.sample_path(jam[0]).unlink()  # pending
    with h5py.File(run.sample_path(jam[1]), "a") as h5:  # a file from before the attribute
        del h5.attrs["cpu_seconds"]
    costs = {c.phi: c for c in cell_costs(run, STUDY)}
    times = recorded(run, "jamming", 8)
    assert sorted(times) == [2, 3] and all(t > 0 for t in times.values())
    c = costs["jamming"]
    assert (c.done, c.to_do, sorted(c.seconds)) == (3, 1.0, sorted(times.values()))
    assert c.mean == pytest.approx(sum(times.values()) / 2, rel=1e-15)
    assert c.left == pytest.approx(c.mean, rel=1e-15)
    other = costs["0.8"]
    assert (other.done, other.to_do, other.left) == (4, 0.0, 0.0)
    assert sorted(other.seconds) == sorted(recorded(run, "0.8", 8).values())


def test_a_checkpoint_counts_by_its_steps(run, monkeypatch):
    study = dataclasses.replace(STUDY, checkpoint_every=1)
    jam = [k for k in study.keys() if k.phi_label == "jamming"]
    for key in jam[:3]:
        run.sample_path(key).unlink()
    saved = {jam[0]: 2, jam[1]: None, jam[2]: -1}  # 2 of 5 steps; none; unreadable (redone)
    monkeypatch.setattr(cost, "resume_step", lambda run, key, study: saved.get(key))
    c = {c.phi: c for c in cell_costs(run, study)}["jamming"]
    assert c.to_do == pytest.approx(0.6 + 1 + 1, rel=1e-15)
    assert c.left == pytest.approx(c.seconds[0] * 2.6, rel=1e-15)


def test_no_timed_sample_gives_no_projection(run):
    for key in STUDY.keys():
        if key.phi_label == "jamming":
            if key.index == 0:
                run.sample_path(key).unlink()
                continue
            with h5py.File(run.sample_path(key), "a") as h5:
                del h5.attrs["cpu_seconds"]
    c = {c.phi: c for c in cell_costs(run, STUDY)}["jamming"]
    assert (c.mean, c.left, c.done, c.to_do) == (None, None, 3, 1.0)


def test_status_prints_them(run):
    key = next(k for k in STUDY.keys() if k.phi_label == "0.8")
    run.sample_path(key).unlink()
    seconds = recorded(run, "0.8", 8)
    r = jamlab("status", run.path)
    assert r.returncode == 0, r.stderr
    lines = {line.split(":")[0]: line for line in r.stdout.splitlines() if line.startswith("cpu ")}
    assert set(lines) == {"cpu phi=jamming N=8", "cpu phi=0.8 N=8"}
    assert lines["cpu phi=jamming N=8"].endswith("nothing left")
    mean = sum(seconds.values()) / 3
    assert f"{mean:,.0f} s per finished sample (3 timed of 3;" in lines["cpu phi=0.8 N=8"]
    assert f"left ≈ {mean / 3600:.2f} CPU-h (1.0 samples' worth)" in lines["cpu phi=0.8 N=8"]


def test_status_opens_each_sample_file_once(run, monkeypatch):
    """`jamlab status` reads the table's states, the costs and the machines in one pass: each
    sample file is opened once, and what it prints is what the separate readers find."""
    from typer.testing import CliRunner

    from jamlab.cli import app
    from jamlab.runs.origin import census_lines, machine_census

    separate = (cell_costs(run, STUDY), census_lines(machine_census(run, STUDY)))
    opened: list[str] = []
    real = h5py.File

    def counting(path, *args, **kwargs):
        opened.append(str(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(h5py, "File", counting)
    result = CliRunner().invoke(app, ["status", str(run.path)], terminal_width=400)
    assert result.exit_code == 0, result.output
    samples = [p for p in opened if "/samples/" in p]
    assert len(samples) == len(STUDY.keys()) == len(set(samples))
    opened.clear()
    states, attrs = run.survey(STUDY, ("cpu_seconds", "provenance"))
    assert states == run.scan(STUDY) and set(attrs) == set(STUDY.keys())
    surveyed = (cell_costs(run, STUDY, states, attrs),
                census_lines(machine_census(run, STUDY, states, attrs=attrs)))
    assert surveyed == separate and separate[1]  # the census lines are not empty
    for line in separate[1][:2]:
        assert line.strip() in " ".join(result.output.split())


def _slow_failure(study, key, seed):
    """Fails sample 1 of each cell after spending measurable CPU time (a busy loop)."""
    import time

    from jamlab.runs import SampleFailed
    from jamlab.runs.tasks import toy_task

    if key.index == 1:
        end = time.thread_time() + 0.05
        while time.thread_time() < end:
            pass
        raise SampleFailed("did not converge (test)")
    return toy_task(study, key, seed)


def test_failed_attempts_are_counted_with_their_cpu_time(tmp_path):
    """The failures' CPU time is the records' own (read here from the JSON files), summed per
    cell over the failed samples and the ones a retry finished; status prints the sum."""
    import json

    path = tmp_path / "r"
    run_study(STUDY, path, Execution(workers=0), task=_slow_failure)
    run_study(STUDY, path, Execution(workers=0), task=_slow_failure)  # failed twice
    run = RunDir(path)
    jam = next(k for k in STUDY.keys() if k.phi_label == "jamming" and k.index == 1)
    run_study(STUDY, path, Execution(workers=0))  # ... then finished by a retry
    by_hand: dict[str, list[float]] = {"jamming": [], "0.8": []}
    for f in sorted(path.rglob("sample-*.*.json")):
        data = json.loads(f.read_text())
        for record in data.get("failures", []):
            by_hand[record["phi"]].append(record["cpu_seconds"])
    assert len(by_hand["jamming"]) == len(by_hand["0.8"]) == 2
    assert all(x >= 0.05 for x in by_hand["jamming"] + by_hand["0.8"])
    costs = {c.phi: c for c in cell_costs(run, STUDY)}
    for phi, seconds in by_hand.items():
        assert costs[phi].failures == 2
        assert sorted(costs[phi].failed_seconds) == sorted(seconds)
    assert run.state(jam) == "done"
    r = jamlab("status", path)
    line = next(x for x in r.stdout.splitlines() if x.startswith("cpu phi=jamming N=8"))
    assert line.endswith(f"; 2 failed attempt(s), {sum(by_hand['jamming']) / 3600:.2f} CPU-h "
                         "in the 2 that record it")
