"""Cross-check against a live LAMMPS (skipped when LAMMPS is not installed; see
``benchmarks/bench_engine.py`` for how it is found and the full comparison)."""

from __future__ import annotations

import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.spheres.fire import minimize
from lammps_helpers import LAMMPS_MARKS, LMP, benchmark_module

bench = benchmark_module("bench_engine")
pytestmark = LAMMPS_MARKS


@pytest.mark.parametrize("strain", [0.0, 0.3, 1.3])
def test_energy_stress_pressure_match_lammps(tmp_path, strain):
    p = minimize(sp.random_packing(300, 3, 0.8, seed=4), ftol=1e-4).packing
    p = sp.affine_shear(p, strain)
    lm = bench.run_lammps(LMP, p, None, tmp_path)
    assert sp.energy(p) == pytest.approx(lm["energy"], rel=1e-12)
    assert sp.shear_stress(p) == pytest.approx(lm["shear_stress"], rel=1e-12)
    assert sp.pressure(p) == pytest.approx(lm["pressure"], rel=1e-12)


def test_same_minimum_after_small_kick(tmp_path):
    p = sp.affine_shear(sp.random_packing(300, 3, 0.8, seed=5), 0.3)
    lm = bench.run_lammps(LMP, p, 1e-13, tmp_path)
    q = lm["packing"]
    q = q.with_positions(q.positions + np.random.default_rng(1).normal(0, 1e-6, (q.n, 3)))
    r = minimize(q)
    assert r.converged
    assert r.energy == pytest.approx(lm["energy"], rel=1e-10)


def _lammps_bidisperse(packing, workdir):
    """Energy, Σ and p of ``packing`` (two sizes) from LAMMPS ``harmonic/cut`` with, per type
    pair, ``k = 1/σ_ij²`` and ``r_c = σ_ij`` (``SPEC.md`` §5): ``k (r_c − r)² = (1 − r/σ_ij)²``."""
    d = packing.dim
    L = float(packing.box.length)
    sizes = sorted(set(packing.diameters.tolist()))
    kind = {s: t + 1 for t, s in enumerate(sizes)}
    pos = packing.box.wrap(packing.positions)
    z = "-0.5 0.5 zlo zhi" if d == 2 else f"0 {L!r} zlo zhi"
    lines = ["jamlab bidisperse", "", f"{packing.n} atoms", f"{len(sizes)} atom types", "",
             f"0 {L!r} xlo xhi", f"0 {L!r} ylo yhi", z,
             f"{packing.box.reduced_strain * L!r} 0 0 xy xz yz", "", "Masses", ""]
    lines += [f"{t} 1.0" for t in range(1, len(sizes) + 1)] + ["", "Atoms # atomic", ""]
    for i, (x, dd) in enumerate(zip(pos.tolist(), packing.diameters.tolist(), strict=True)):
        zz = 0.0 if d == 2 else x[2]
        lines.append(f"{i + 1} {kind[dd]} {x[0]!r} {x[1]!r} {zz!r}")
    (workdir / "data.lmp").write_text("\n".join(lines) + "\n")
    coeffs = []
    for a in sizes:
        for b in sizes:
            if kind[a] <= kind[b]:
                sig = 0.5 * (a + b)
                coeffs.append(f"pair_coeff {kind[a]} {kind[b]} {1.0 / sig**2!r} {sig!r}")
    script = "\n".join(
        [f"dimension {d}", "units lj", "atom_style atomic", "boundary p p p",
         "read_data data.lmp", "pair_style harmonic/cut", *coeffs,
         "neighbor 0.3 bin", "thermo_style custom pe pxy press", "thermo_modify norm no",
         "thermo_modify format float %.17g", "run 0"]
    )
    log, _ = bench.run_script(LMP[0], LMP[1], script, workdir)
    rows = log.splitlines()
    k = next(i for i, r in enumerate(rows) if r.split()[:3] == ["PotEng", "Pxy", "Press"])
    pe, pxy, press = (float(v) for v in rows[k + 1].split())
    return pe, -pxy * L**d, press


@pytest.mark.parametrize("dim,strain", [(2, 0.0), (2, 0.4), (3, 0.0), (3, -0.7)])
def test_bidisperse_harmonic_matches_lammps(tmp_path, dim, strain):
    """Bidisperse (1 : 1.4) harmonic energy, Σ and p equal LAMMPS's to 1e-12 relative."""
    p = sp.random_packing(200, dim, 0.9 if dim == 2 else 0.75, seed=6, sizes="bidisperse")
    p = sp.affine_shear(minimize(p, ftol=1e-3).packing, strain)
    pe, sigma, press = _lammps_bidisperse(p, tmp_path)
    assert sp.energy(p) == pytest.approx(pe, rel=1e-12)
    assert sp.shear_stress(p) == pytest.approx(sigma, rel=1e-12)
    assert sp.pressure(p) == pytest.approx(press, rel=1e-12)
