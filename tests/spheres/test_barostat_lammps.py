"""The fixed-pressure minimum against LAMMPS ``fix box/relax iso`` (``min_style cg``, then a FIRE
polish at fixed box); skipped when LAMMPS is not installed (``benchmarks/_lammps.py``)."""

from __future__ import annotations

import math
import re

import pytest

from jamlab.spheres import jam
from jamlab.spheres.barostat import minimize_enthalpy
from lammps_helpers import LAMMPS_MARKS, LMP, benchmark_module

lm = benchmark_module("_lammps")
pytestmark = LAMMPS_MARKS

SCRIPT = """
units lj
dimension 3
boundary p p p
atom_style atomic
atom_modify map array
read_data in.data
pair_style harmonic/cut
pair_coeff 1 1 1.0 1.0
neighbor 0.3 bin
neigh_modify every 1 delay 0 check yes
compute pv all pressure NULL virial
thermo_style custom step pe c_pv fmax vol
thermo_modify norm no format float %.17g
fix br all box/relax iso {p!r} vmax {vmax!r}
min_style cg
min_modify norm max
minimize 0.0 1e-14 1000000 10000000
unfix br
min_style fire
timestep 0.1
minimize 0.0 1e-13 1000000 10000000
"""


@pytest.mark.parametrize("p_t,vmax", [(1e-3, 1e-4), (1e-4, 1e-6), (1e-5, 1e-7)])
def test_same_packing_fraction_as_lammps_box_relax(tmp_path, p_t, vmax):
    # from a packing at p ≈ 1e-4 the path to p_t is elastic, so both land on the same minimum
    pk = jam(64, 3, seed=1, p_target=1e-4).packing
    lm.write_data(tmp_path / "in.data", pk)
    log, _ = lm.run_script(*LMP, SCRIPT.format(p=p_t, vmax=vmax), tmp_path)
    assert re.findall(r"Stopping criterion\s*=\s*(.*)", log)[0].strip() == "force tolerance"
    rows = re.findall(r"^\s*(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$", log, re.M)
    _, _, press, _, vol = rows[-1]
    assert float(press) == pytest.approx(p_t, rel=1e-6)
    phi_lammps = 64 * math.pi / 6 / float(vol)
    r = minimize_enthalpy(pk, p_t)
    assert r.converged
    assert r.phi == pytest.approx(phi_lammps, rel=1e-10)
