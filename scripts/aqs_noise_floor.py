"""The smallest avalanche that can be told from minimiser noise (issue 6).

    python scripts/aqs_noise_floor.py [--steps 1000]

Shears the N = 500, φ = 0.8 LAMMPS-minimised start of
``tests/data/reference/lammps-aqs-n500-phi0.80-1000steps`` (a random packing minimised at φ = 0.8
if absent) with the fast path, δγ = 1e-5, and prints: the plastic rows, the robust spread
``σ_r`` of the trapezoid residual ``r_n = ΔE_n − ½ δγ ΔΣ_n`` over the elastic steps
(:func:`jamlab.analysis.avalanches.noise_floor`), the elastic term ``½ G L^d δγ²``, their
ratio, the median recorded ``max|F|`` and the largest elastic ``|r_n|``. Asserts nothing;
docs/aqs.md ("Noise floor") quotes the output.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import jamlab.spheres as sp
from jamlab.analysis.avalanches import jumps_from_trace, noise_floor
from jamlab.spheres import aqs
from jamlab.spheres.fire import minimize
from jamlab.spheres.io import read_lammps_positions

N500 = (
    Path(__file__).resolve().parents[1]
    / "tests"
    / "data"
    / "reference"
    / "lammps-aqs-n500-phi0.80-1000steps"
)
DGAMMA = 1e-5


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1000)
    args = ap.parse_args(argv)
    if N500.is_dir():
        meta = json.loads((N500 / "meta.json").read_text())
        start = read_lammps_positions(N500 / "positions.txt", box_length=meta["box_length"])
    else:
        start = minimize(sp.random_packing(500, 3, 0.8, 2026), ftol=1e-13).packing
    tr = aqs.shear(start, DGAMMA, n_steps=args.steps).trace
    ej, sj, dg = jumps_from_trace(tr.gamma, tr.energy, tr.shear_stress)
    plastic = tr.plastic[1:]
    nf = noise_floor(ej, sj, dg, plastic)
    r = ej - 0.5 * dg * sj
    elastic_term = 0.5 * nf.modulus * DGAMMA**2
    print(f"plastic rows: {np.flatnonzero(tr.plastic).tolist()}")
    print(
        f"sigma_r = {nf.sigma:.2e} (median {nf.median:.1e}, {nf.n_elastic} elastic steps); "
        f"G L^d = {nf.modulus:.1f}, 1/2 G L^d dgamma^2 = {elastic_term:.2e}; "
        f"ratio {nf.sigma / elastic_term:.1e}; 10 sigma_r = {10 * nf.sigma:.1e}"
    )
    print(
        f"median recorded max|F| = {np.median(tr.max_force[1:]):.1e}; "
        f"largest elastic |r| = {np.max(np.abs(r[~plastic])):.1e}, "
        f"99th percentile {np.percentile(np.abs(r[~plastic]), 99):.1e}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
