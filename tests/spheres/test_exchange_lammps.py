"""LAMMPS reads jamlab's data files (``read_data`` + ``run 0``: jamlab's energy and Σ to 1e-12)
and jamlab reads LAMMPS's own ``write_data`` output (skipped when LAMMPS is not installed; found
as in ``benchmarks/_lammps.py``)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.spheres import exchange as ex
from lammps_helpers import LAMMPS_MARKS, LMP, benchmark_module

lmp_helpers = benchmark_module("_lammps")
pytestmark = LAMMPS_MARKS

SCRIPT = """
units lj
dimension {dim}
boundary p p p
atom_style sphere
atom_modify map array
read_data in.data
pair_style harmonic/cut
pair_coeff * * 1.0 1.0
neighbor 0.3 bin
compute pv all pressure NULL virial
thermo_style custom step pe c_pv[4]
thermo_modify norm no format float %.17g
run 0
write_data out.data
"""


def _run(packing: sp.Packing, workdir: Path) -> tuple[float, float]:
    ex.write_lammps_data(workdir / "in.data", packing)
    script = SCRIPT.format(dim=packing.dim)
    exe, env = LMP
    log, _ = lmp_helpers.run_script(exe, env, script, workdir)
    step, pe, pxy = re.findall(r"^\s*(\d+)\s+(\S+)\s+(\S+)\s*$", log, re.M)[-1]
    return float(pe), -float(pxy) * packing.box.volume


@pytest.mark.parametrize(("dim", "strain"), [(3, 0.0), (3, 0.3), (3, 1.3), (3, -0.7), (2, 0.45)])
def test_lammps_reads_jamlab_data_energy_and_stress(tmp_path, dim, strain):
    p = sp.minimize(sp.random_packing(200, dim, 0.85, seed=11), ftol=1e-4).packing
    p = sp.affine_shear(p, strain)
    energy, sigma = _run(p, tmp_path)
    assert energy == pytest.approx(sp.energy(p), rel=1e-12)
    assert sigma == pytest.approx(sp.shear_stress(p), rel=1e-12)
    # and LAMMPS's own data file (its box, its wrapped positions) reads back to the same state
    (q,) = ex.read_frames(tmp_path / "out.data", "lammps-data")
    assert q.box.length == pytest.approx(p.box.length, rel=1e-15)
    assert q.box.dim == dim
    assert np.isclose(q.box.reduced_strain, p.box.reduced_strain, rtol=0, atol=1e-15)
    assert sp.energy(q) == pytest.approx(sp.energy(p), rel=1e-12)
    assert sp.shear_stress(q) == pytest.approx(sp.shear_stress(p), rel=1e-12)


def test_lammps_reads_the_diameters(tmp_path):
    """Per-particle diameters reach LAMMPS (its ``diameter`` per atom), one type per size."""
    p = sp.random_packing(50, 3, 0.6, seed=2)
    diam = np.where(np.arange(p.n) % 2 == 0, 1.0, 1.4)
    if "diameters" in {f.name for f in dataclasses.fields(sp.Packing)}:
        p = dataclasses.replace(p, diameters=diam)
    else:  # a stand-in carrying diameters: the writer reads them with getattr
        p = type("WithDiameters", (), {})()
        base = sp.random_packing(50, 3, 0.6, seed=2)
        for name in ("positions", "box", "n", "dim", "seed"):
            setattr(p, name, getattr(base, name))
        p.diameters = diam
    ex.write_lammps_data(tmp_path / "in.data", p)
    script = (
        "units lj\natom_style sphere\natom_modify map array\nread_data in.data\n"
        "compute d all property/atom diameter type\n"
        "dump 1 all custom 1 out.dump id c_d[1] c_d[2]\ndump_modify 1 sort id format float %.17g\n"
        "pair_style zero 1.0\npair_coeff * *\nrun 0\n"
    )
    exe, env = LMP
    lmp_helpers.run_script(exe, env, script, tmp_path)
    dump = np.loadtxt(tmp_path / "out.dump", skiprows=9)
    assert np.array_equal(dump[:, 1], diam)
    assert np.array_equal(dump[:, 2], np.where(diam == 1.0, 1, 2))
