"""``scripts/fire_variant_run.py``: the FIRE overrides reach the shear of a ``jamlab run`` study
(compared with the same study run by ``jamlab run`` itself), are recorded, and a run directory
with other overrides, or a bad override, is refused with exit code 2."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from tests.script_helpers import script_module

from jamlab.cli import main as jamlab_main

STUDY = ["--phi", "jamming", "--n", "32", "--samples", "1", "--dgamma", "1e-4",
         "--gamma-max", "0.003", "--pressure", "1e-3"]


def trace(run) -> dict:
    with h5py.File(next(run.glob("samples/*/*/sample-*.h5")), "r") as h5:
        return {k: h5["trace"][k][()] for k in ("iterations", "energy")}


def test_overrides_reach_the_shear(tmp_path):
    probe = script_module("fire_variant_run")
    slow = tmp_path / "slow"
    assert probe.main(["--fire", "dt_max=0.02", "--fire", "dt=0.02", "--",
                       *STUDY, "--out", str(slow)]) == 0
    assert json.loads((slow / "fire_params.json").read_text()) == {"dt_max": 0.02, "dt": 0.02}
    with pytest.raises(SystemExit) as done:
        jamlab_main(["run", *STUDY, "--out", str(tmp_path / "plain"), "--workers", "0"])
    assert done.value.code == 0
    a, b = trace(slow), trace(tmp_path / "plain")
    # a 15x smaller time step: many more FIRE iterations, the same minima here
    assert a["iterations"].sum() > 3 * b["iterations"].sum()
    np.testing.assert_allclose(a["energy"], b["energy"], rtol=1e-9)
    assert probe.main(["--fire", "variant=fire", "--", *STUDY, "--out", str(slow)]) == 2
    # nor is a plain run's directory continued with overrides (its samples are not theirs)
    plain = tmp_path / "plain"
    assert probe.main(["--fire", "dt_max=0.02", "--", *STUDY, "--out", str(plain)]) == 2
    assert not (plain / "fire_params.json").exists()


@pytest.mark.parametrize("bad", [["--fire", "foo=1"], ["--fire", "dt_max=-1"],
                                 ["--fire", "variant=x"], []])
def test_bad_overrides_refused(tmp_path, bad):
    probe = script_module("fire_variant_run")
    assert probe.main([*bad, "--", *STUDY, "--out", str(tmp_path / "r")]) == 2
    assert not (tmp_path / "r").exists()
