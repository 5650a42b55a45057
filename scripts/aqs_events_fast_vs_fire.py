"""Plastic events of the fast path against plain FIRE on 300-step AQS traces (issue 6).

    python scripts/aqs_events_fast_vs_fire.py [--steps 300] [--n-jam 500] [--seed 1]
                                              [--which phi080 jamming] [--json out.json]

Two settings, N = 500, δγ = 1e-5: φ = 0.8 from the LAMMPS-minimised start of
``tests/data/reference/lammps-aqs-n500-phi0.80-1000steps`` (random packing minimised at φ = 0.8 if
absent), and a jammed packing from ``jamlab.spheres.packing.jam(500, 3, seed)`` (p ≈ 1e-7).
Each is sheared with the fast path (``minimizer="linear"``) and with plain FIRE
(``minimizer="fire"``, which classifies by running the same continuation beside FIRE), both to
``max|F_i| < 1e-12``. Printed: time per step, the plastic steps of each, the first row where the
two runs are in different minima (energies differ by more than 1e-9 relative), whether the
plastic flags agree up to there, the largest relative difference of ``ΔE`` on steps that both
flag plastic while in the same minimum, and an independent event list: steps whose trapezoid
residual ``r = ΔE − ½ δγ ΔΣ`` is below ``−100 δγ²`` (a drop of the energy below the continued
branch; meaningful at φ = 0.8, not at jamming where avalanches are as small as ``δγ |ΔΣ|``).
Asserts nothing; the test suite checks a shorter version.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import jamlab.spheres as sp
from jamlab.analysis.avalanches import branch_residual, jumps_from_trace
from jamlab.spheres import aqs
from jamlab.spheres.fire import minimize
from jamlab.spheres.io import read_lammps_positions
from jamlab.spheres.packing import jam

REFERENCE = Path(__file__).resolve().parents[1] / "tests" / "data" / "reference"
N500 = REFERENCE / "lammps-aqs-n500-phi0.80-1000steps"
DGAMMA = 1e-5


def start_phi080() -> sp.Packing:
    if N500.is_dir():
        meta = json.loads((N500 / "meta.json").read_text())
        return read_lammps_positions(N500 / "positions.txt", box_length=meta["box_length"])
    return minimize(sp.random_packing(500, 3, 0.8, 2026), ftol=1e-13).packing


def compare(name: str, start: sp.Packing, steps: int) -> dict:
    out: dict = {"setting": name, "N": start.n, "phi": start.phi, "steps": steps}
    out["pressure"] = float(sp.pressure(start))
    runs = {}
    for minimizer in ("linear", "fire"):
        t = time.perf_counter()
        res = aqs.shear(start, DGAMMA, n_steps=steps, minimizer=minimizer)
        runs[minimizer] = res.trace
        out[f"ms_per_step_{minimizer}"] = 1e3 * (time.perf_counter() - t) / steps
    fast, fire = runs["linear"], runs["fire"]
    same = np.isclose(fast.energy, fire.energy, rtol=1e-9, atol=0)
    common = int(np.argmin(same)) if not same.all() else fast.gamma.size
    out["first_row_in_different_minima"] = common if common < fast.gamma.size else None
    upto = slice(0, common + 1 if common < fast.gamma.size else common)
    out["plastic_fast"] = np.flatnonzero(fast.plastic).tolist()
    out["plastic_fire"] = np.flatnonzero(fire.plastic).tolist()
    out["flags_agree_up_to_divergence"] = bool(
        np.array_equal(fast.plastic[upto], fire.plastic[upto])
    )
    both = fast.plastic & fire.plastic & same
    if both.any():
        dej = np.abs(fast.energy_jump[both] - fire.energy_jump[both])
        out["max_rel_dE_on_common_events"] = float(np.max(dej / np.abs(fire.energy_jump[both])))
    out["n_common_events_same_minimum"] = int(both.sum())
    for key, tr in runs.items():
        ej, sj, dg = jumps_from_trace(tr.gamma, tr.energy, tr.shear_stress)
        r = branch_residual(ej, sj, dg)
        out[f"residual_events_{key}"] = (np.flatnonzero(-r > 100 * DGAMMA**2) + 1).tolist()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--n-jam", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--which", nargs="+", default=["phi080", "jamming"])
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    aqs.shear(start_phi080(), DGAMMA, n_steps=2)  # compile outside the timings
    results = []
    for which in args.which:
        if which == "phi080":
            start = start_phi080()
        elif which == "jamming":
            res = jam(args.n_jam, 3, seed=args.seed)
            if not res.ok:
                raise SystemExit(f"jam({args.n_jam}, seed={args.seed}) failed: {res.reason}")
            start = res.packing
        else:
            raise SystemExit(f"unknown setting {which!r} (phi080, jamming)")
        out = compare(which, start, args.steps)
        results.append(out)
        print(json.dumps(out), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
