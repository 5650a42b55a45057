"""``jamlab.reproduce.ensembles.row_volumes``: the volume of every row of a fixed-pressure run,
read back from the stored φ and the prepared packing, against the box side of the same shear
replayed from that packing (``shear_at_pressure``, whose columns carry ``box_length``); and
at constant volume the box itself, ``L³`` at every row. ``intensive_stress`` divides by those
volumes: against the replay's ``Σ / L_row³`` at fixed pressure, and bit for bit ``Σ / L³`` of
the stored box at constant volume; a fixed-pressure run without row φ is refused, not divided
by the prepared box."""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.reproduce.ensembles import intensive_stress, row_volumes
from jamlab.runs import Execution, RunDir, Study, open_run, prepared_packing, run_study
from jamlab.spheres.pressure_shear import shear_at_pressure


def test_row_volumes_are_the_replayed_boxes(tmp_path):
    study = Study(phi=["jamming"], n=[16], samples=2, dgamma=1e-3, gamma_max=1e-2, seed=4,
                  pressure=1e-3)
    run_study(study, tmp_path / "p", Execution(workers=0))
    ds = open_run(tmp_path / "p")
    volumes = row_volumes(ds, "jamming", 16)
    sigma = intensive_stress(ds, "jamming", 16)
    rd = RunDir(tmp_path / "p")
    assert volumes.shape == (2, 11)
    for row, sig, key in zip(volumes, sigma, study.keys(), strict=True):
        c = shear_at_pressure(prepared_packing(rd.sample_path(key)), 1e-3, pressure=1e-3,
                              n_steps=10).columns
        stored = ds.energy.sel(phi="jamming", N=16, sample=key.index).values
        # the same trajectory (the enthalpy of every row), so the same boxes
        np.testing.assert_allclose(c["enthalpy"], stored, rtol=1e-9)
        np.testing.assert_allclose(row, c["box_length"] ** 3, rtol=1e-12)
        assert np.ptp(row) > 0  # the box did change along the shear
        np.testing.assert_allclose(sig, c["shear_stress"] / c["box_length"] ** 3, rtol=1e-9)
    # the same run as one made before trace format 2: no row φ, so no row volumes to divide by
    old = ds.drop_vars("phi_step")
    assert row_volumes(old, "jamming", 16) is None
    with pytest.raises(ValueError, match="phi_step"):
        intensive_stress(old, "jamming", 16)


def test_a_constant_volume_run_keeps_its_box(tmp_path):
    study = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=4)
    run_study(study, tmp_path / "v", Execution(workers=0))
    ds = open_run(tmp_path / "v")
    volumes = row_volumes(ds, "jamming", 16)
    length = float(ds.box_length.sel(phi="jamming", N=16).values[0])
    assert volumes.shape == (1, 4)
    np.testing.assert_allclose(volumes, length**3, rtol=1e-12)
    stress = ds.shear_stress.sel(phi="jamming", N=16).values[0]
    np.testing.assert_array_equal(intensive_stress(ds, "jamming", 16)[0], stress / length**3)
