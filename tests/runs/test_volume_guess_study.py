"""``Study.volume_guess``: stored with every fixed-pressure study, absent at constant volume; a
run directory recorded before the option is read with the rule of its time (``"always"``) and
is not resumed by another rule — through ``RunDir`` and ``jamlab run``."""

import json

import pytest

from cli_helpers import jamlab, one_line_error
from jamlab.runs import Execution, RunDir, RunError, Study, run_study

BASE = dict(phi=["jamming"], n=[8], samples=1, dgamma=1e-3, gamma_max=4e-3, seed=3, task="toy")


def test_default_and_storage():
    s = Study(**BASE, pressure=1e-4)
    assert s.volume_guess == "elastic" and s.to_dict()["volume_guess"] == "elastic"
    assert Study.from_dict(s.to_dict()) == s
    assert Study(**BASE, pressure=1e-4, volume_guess="always").differences(s) == [
        "volume_guess: 'always' != 'elastic'"]
    cv = Study(**BASE)
    assert cv.volume_guess is None and "volume_guess" not in cv.to_dict()
    with pytest.raises(ValueError, match="volume_guess applies to fixed-pressure runs only"):
        Study(**BASE, volume_guess="never")
    with pytest.raises(ValueError, match="volume_guess must be"):
        Study(**BASE, pressure=1e-4, volume_guess="sometimes")


@pytest.fixture
def legacy_run(tmp_path):
    """A fixed-pressure run directory whose manifest has no ``volume_guess`` (as made before)."""
    out = tmp_path / "run"
    run_study(Study(**BASE, pressure=1e-4), out, Execution(workers=0))
    path = RunDir(out).manifest_path
    manifest = json.loads(path.read_text())
    del manifest["study"]["volume_guess"]
    path.write_text(json.dumps(manifest))
    return out


def test_a_legacy_manifest_is_the_rule_always(legacy_run):
    assert RunDir(legacy_run).study().volume_guess == "always"
    with pytest.raises(RunError, match="volume_guess: 'always' != 'elastic'"):
        RunDir.open(legacy_run, Study(**BASE, pressure=1e-4))
    assert RunDir.open(legacy_run, Study(**BASE, pressure=1e-4, volume_guess="always"))


def test_jamlab_run_resumes_a_legacy_run_only_with_its_rule(legacy_run):
    study = ["run", "--phi", "jamming", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
             "--gamma-max", "4e-3", "--seed", "3", "--task", "toy", "--pressure", "1e-4",
             "--workers", "0", "--quiet"]
    args = [*study, "--out", legacy_run]
    r = jamlab(*args)
    assert r.returncode == 2 and "volume_guess: 'always' != 'elastic'" in one_line_error(r)
    r = jamlab(*args, "--volume-guess", "always")
    assert r.returncode == 0, r.stderr
    r = jamlab(*study, "--volume-guess", "sometimes", "--out", legacy_run.parent / "new")
    assert r.returncode == 2 and "volume_guess must be" in one_line_error(r)
