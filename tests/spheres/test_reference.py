"""Against LAMMPS reference data (no LAMMPS needed): row 0 of each reference trace."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.spheres.io import read_lammps_positions
from reference_data import REFERENCE

FOLDERS = sorted(p for p in REFERENCE.glob("lammps-aqs-*") if p.is_dir())


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda p: p.name)
def test_row0_of_lammps_trace(folder):
    meta = json.loads((folder / "meta.json").read_text())
    with open(folder / "trace.csv") as fh:
        row = next(csv.DictReader(fh))
    p = read_lammps_positions(folder / "positions.txt", box_length=meta["box_length"])
    assert p.n == meta["n"] and p.dim == meta["dim"]
    assert p.phi == pytest.approx(meta["phi"], rel=1e-12)
    assert sp.energy(p) == pytest.approx(float(row["energy"]), rel=1e-12)
    assert sp.shear_stress(p) == pytest.approx(float(row["shear_stress"]), rel=1e-12)
    assert sp.pressure(p) == pytest.approx(float(row["pressure"]), rel=1e-12)
    assert sp.max_force(p) < 1e-13
    # LAMMPS reports an O(1e-13) force; ours on the same positions must be that small too
    assert sp.max_force(p) == pytest.approx(float(row["max_force"]), abs=5e-14)
    # a minimum is mechanically stable: the Hessian without rattlers has no negative modes
    assert np.isfinite(sp.remove_rattlers(p).z_nr)
