"""Issue 15 (reliability) in the run machinery: damaged samples are not done, the import graph
of ``jamlab.runs`` has no cycle and no module uses another's private names."""

from __future__ import annotations

import ast
from pathlib import Path

import h5py
import numpy as np
import pytest

from jamlab.runs import Execution, RunDir, Study, open_run, run_study

STUDY = Study(phi=[0.8], n=[8], samples=6, dgamma=1e-3, gamma_max=4e-3, task="toy")


def _delete_dataset(h5):
    del h5["trace/energy"]


def _shorten_dataset(h5):
    values = h5["trace/shear_stress"][()]
    del h5["trace/shear_stress"]
    h5["trace/shear_stress"] = values[:-1]


def _delete_packing(h5):
    del h5["packing"]


def _zero_bytes(h5):
    h5["trace/energy"][...] = 0.0


def _nan(h5):
    h5["trace/gamma"][2] = np.nan


def _retype(h5):
    values = h5["trace/plastic"][()]
    del h5["trace/plastic"]
    h5["trace/plastic"] = values.astype(np.float64)


DAMAGES = [_delete_dataset, _shorten_dataset, _delete_packing, _zero_bytes, _nan, _retype]


def test_a_damaged_but_openable_sample_is_redone(tmp_path):
    """On 09aa8ce each of these counted as done and open_run returned NaN or zeros with status
    ``done``."""
    run = tmp_path / "run"
    run_study(STUDY, run, Execution(workers=0))
    rd = RunDir(run)
    keys = STUDY.keys()
    reference = {k: open(rd.sample_path(k), "rb").read() for k in keys}
    for key, damage in zip(keys, DAMAGES, strict=True):
        with h5py.File(rd.sample_path(key), "a") as h5:
            damage(h5)
    states = rd.scan(STUDY)
    assert [states[k] for k in keys] == ["corrupt"] * len(DAMAGES)
    ds = open_run(run)
    assert set(ds.status.values.ravel()) == {"corrupt"}
    assert np.isnan(ds.energy.values).all()
    summary = run_study(STUDY, run, Execution(workers=0))
    assert summary.done == len(DAMAGES) and summary.skipped == 0
    for k in keys:  # redone bit for bit (the sample's seed is fixed)
        assert rd.state(k, STUDY) == "done"
        with h5py.File(rd.sample_path(k)) as a, h5py.File(_copy(reference[k], tmp_path)) as b:
            for name in a["trace"]:
                assert a["trace"][name][()].tobytes() == b["trace"][name][()].tobytes()


def _copy(data: bytes, tmp_path: Path) -> Path:
    path = tmp_path / "ref.h5"
    path.write_bytes(data)
    return path


def test_a_task_returning_an_incomplete_result_is_a_failure(tmp_path):
    from jamlab.runs.tasks import toy_task

    def no_positions(study, key, seed):
        result = toy_task(study, key, seed)
        result.arrays = {}
        return result

    summary = run_study(STUDY, tmp_path / "run", Execution(workers=0), task=no_positions)
    assert summary.failed == STUDY.n_samples and summary.done == 0
    info = RunDir(tmp_path / "run").read_failure(STUDY.keys()[0])
    assert info["error_type"] == "InvalidResult" and "positions" in info["message"]


def test_workers_must_be_an_integer():
    with pytest.raises(ValueError, match="workers"):
        Execution(workers="two")
    with pytest.raises(ValueError, match="workers"):
        Execution(workers=1.5)
    assert Execution(workers="2").workers == 2


def test_study_bounds_from_python_and_toml(tmp_path):
    base = dict(phi=[0.8], n=[32], samples=1, dgamma=1e-3, gamma_max=3e-3)
    for change, needle in [
        ({"seed": 2**64}, "seed"),
        ({"phi": [5.0]}, "phi"),
        ({"dgamma": 1e-320}, "steps"),
        ({"gamma_max": 1e300}, "gamma_max"),
        ({"samples": "two"}, "samples"),
    ]:
        with pytest.raises(ValueError, match=needle):
            Study(**{**base, **change})
    assert Study(**{**base, "seed": 2**64 - 1}).seed == 2**64 - 1
    with pytest.raises(ValueError, match="box length"):
        Study(**{**base, "dim": 10}).check_geometry()


RUNS = Path(__file__).resolve().parents[2] / "src" / "jamlab" / "runs"


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    """(module, imported names) of every import in ``path``, including those inside functions."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.append((node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out.extend((a.name, []) for a in node.names)
    return out


def test_runs_imports_have_no_cycle_and_no_private_names(runs: Path = RUNS):
    modules = {p.stem: p for p in runs.glob("*.py") if p.stem != "__init__"}
    assert {"execute", "storage", "tasks", "study"} <= set(modules), runs
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        for module, names in _imports(path):
            parts = module.split(".")
            if parts[:2] == ["jamlab", "runs"]:
                targets = parts[2:3] or [n for n in names if n in modules]
                graph[name].update(t for t in targets if t in modules)
            if parts[0] == "jamlab":
                # dunder names (``__version__``) are public by convention
                private = [p for p in parts if p.startswith("_") and not p.endswith("__")]
                private += [n for n in names if n.startswith("_") and not n.endswith("__")]
                assert not private, f"{name}.py imports private {module}: {private}"

    def visit(node: str, stack: list[str]) -> None:
        assert node not in stack, f"import cycle {' -> '.join([*stack, node])}"
        for nxt in graph[node]:
            visit(nxt, [*stack, node])

    for start in graph:
        visit(start, [])
