"""``scripts/enthalpy_parts.py --runs``: its refusal of a constant-volume run (the volumes it
reads are ``jamlab.reproduce.ensembles.row_volumes``, tested in ``tests/test_row_volumes.py``)."""

from __future__ import annotations

from tests.script_helpers import exit_code, script_module

from jamlab.runs import Execution, Study, run_study


def test_constant_volume_run_is_refused(tmp_path, monkeypatch, capsys):
    ep = script_module("enthalpy_parts")
    study = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=4)
    run_study(study, tmp_path / "v", Execution(workers=0))
    assert exit_code(ep, ["--runs", str(tmp_path / "v"), "--run-n", "16"], monkeypatch) == 2
    assert "not a fixed-pressure run" in capsys.readouterr().err
