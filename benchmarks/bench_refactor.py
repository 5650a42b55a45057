"""AQS speed of two source trees, timed alternately in one run (before/after a refactor).

Runs the jamlab part of ``bench_aqs.py`` (φ = 0.8: N = 1000 from the LAMMPS start of
``shared/reference/lammps-aqs-n1000-phi0.80``, δγ = 1e-5, fast path and plain FIRE; near
jamming: ``jam(128, seed=1, p_target=1e-5)``, fast path and FIRE with classification) in
subprocesses with ``PYTHONPATH`` set to each tree in turn, ``--repeat`` rounds ``A B A B …``
(the machine is shared: alternating spreads the disturbance over both), and prints per case the
best time per step of each tree and their ratio, and the ratio of every round, both in wall
clock and in CPU time of the process (one BLAS/numba thread; less sensitive to other load on a
shared machine). Compiled kernels are warmed before timing in every subprocess. Asserts nothing
about time.

With ``--at-jamming N …`` it also times constant-volume shear (fast path, ``--jam-steps``
steps of δγ = 1e-5) from ``jam(N, 3, seed, p_target=1e-7)`` for ``--at-jamming-seeds`` (default
1 2), and with ``--prepared-seeds S …`` the fast path from ``prepare(1000, 3, 0.8, S)`` (the
typical starts of ``bench_aqs.py``), and with ``--at-pressure P …`` fixed-pressure shear
(``--jam-steps`` steps) from ``jam_at_pressure(--at-pressure-n, 3, seed, P)`` for the same seeds;
those packings are made once per tree and kept in
``--cache`` between rounds. With ``--jam-n N`` (default 256)
it also times ``jam(N, 3, seed)`` for seeds 1–3 (the
``bench_jam.py`` protocol, jamlab only), per packing (the "ms/step" columns are then ms per
packing).

Run: ``python benchmarks/bench_refactor.py --compare-src /work/wt-base/src [--src src]
[--repeat 5] [--steps 200] [--no-jamming] [--fast-only] [--jam-n 256]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trees import run_in_tree  # noqa: E402  (benchmarks run as scripts)

HERE = Path(__file__).resolve()
REFERENCE = HERE.parents[1] / "tests" / "data" / "reference"
START = REFERENCE / "lammps-aqs-n1000-phi0.80"

# the child: time each case with the jamlab found on PYTHONPATH; prints one JSON line
CHILD = r"""
import json, pickle, sys, time
import jamlab
from jamlab.spheres.aqs import shear
from jamlab.spheres.io import read_lammps_positions
from jamlab.spheres.packing import jam, jam_at_pressure, prepare

start_dir, steps, jam_steps, jamming = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
fast_only = sys.argv[5] == "1"
jam_n = int(sys.argv[6])
at_jamming = json.loads(sys.argv[7])
cache_dir = sys.argv[8]
prepared_seeds = json.loads(sys.argv[9])
at_pressure = json.loads(sys.argv[10])

def cached(name, make):
    # a packing made once per tree (outside the timings) and kept in cache_dir between rounds
    path = f"{cache_dir}/{name}" + jamlab.__file__.replace("/", "_") + ".pkl"
    try:
        return pickle.load(open(path, "rb"))
    except OSError:
        packing = make()
        pickle.dump(packing, open(path, "wb"))
        return packing
meta = json.load(open(start_dir + "/meta.json"))
start = read_lammps_positions(start_dir + "/positions.txt", box_length=meta["box_length"])
shear(start, 1e-5, n_steps=2)  # compile outside the timings
out = {"jamlab": jamlab.__file__}

def timed(name, packing, n, **kw):
    # wall clock of the stepping loop (ShearResult.time) and CPU time of the whole call
    cpu = time.process_time()
    r = shear(packing, 1e-5, n_steps=n, **kw)
    cpu = time.process_time() - cpu
    out[name] = (r.time / n, cpu / n, int(r.trace.plastic.sum()))

timed("phi0.8 fast path", start, steps)
if not fast_only:
    timed("phi0.8 plain FIRE", start, steps, minimizer="fire", classify=False)
if jamming == "1":
    jammed = jam(128, 3, seed=1, p_target=1e-5).packing
    shear(jammed, 1e-5, n_steps=1)
    timed("jamming N=128 fast path", jammed, jam_steps)
    if not fast_only:
        timed("jamming N=128 FIRE+classify", jammed, jam_steps, minimizer="fire", classify=True)
for seed in prepared_seeds:
    packing = cached(f"prepare_s{seed}", lambda: prepare(1000, 3, 0.8, seed=seed).packing)
    timed(f"phi0.8 prepared seed {seed} fast", packing, steps)
for n_cv, seed in at_jamming:
    # constant volume from jam(N, 3, seed, p_target=1e-7)
    packing = cached(f"jam_n{n_cv}_s{seed}", lambda: jam(n_cv, 3, seed=seed, p_target=1e-7).packing)
    timed(f"jamming N={n_cv} seed {seed} fast", packing, jam_steps)
for n_p, pressure, seed in at_pressure:
    # fixed pressure from jam_at_pressure(N, 3, seed, pressure)
    packing = cached(f"jam_n{n_p}_p{pressure:g}_s{seed}",
                     lambda: jam_at_pressure(n_p, 3, seed, pressure).packing)
    timed(f"p={pressure:g} N={n_p} seed {seed}", packing, jam_steps, pressure=pressure)
if jam_n:
    jam(64, 3, seed=1, p_target=1e-4)  # compile outside the timings
    wall, cpu = time.perf_counter(), time.process_time()
    for seed in (1, 2, 3):
        res = jam(jam_n, 3, seed=seed)
        assert res.ok, res.reason
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    out[f"jam N={jam_n}, per packing"] = (wall / 3, cpu / 3, 0)
print("RESULT " + json.dumps(out))
"""


def run_child(src: str, args) -> dict:
    child_args = [
        START,
        args.steps,
        args.jam_steps,
        "0" if args.no_jamming else "1",
        "1" if args.fast_only else "0",
        args.jam_n,
        json.dumps([(n, s) for n in args.at_jamming for s in args.at_jamming_seeds]),
        args.cache,
        json.dumps(args.prepared_seeds),
        json.dumps([(args.at_pressure_n, p, s) for p in args.at_pressure
                    for s in args.at_jamming_seeds]),
    ]
    stdout = run_in_tree(src, CHILD, child_args)
    line = next(x for x in stdout.splitlines() if x.startswith("RESULT "))
    return json.loads(line[len("RESULT ") :])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare-src", required=True, help="the 'before' source tree (A)")
    ap.add_argument("--src", default=str(HERE.parents[1] / "src"), help="the 'after' tree (B)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--jam-steps", type=int, default=30)
    ap.add_argument("--no-jamming", action="store_true")
    ap.add_argument("--fast-only", action="store_true", help="time the fast path only")
    ap.add_argument(
        "--jam-n", type=int, default=256, help="also time jam(N, 3, seed), seeds 1-3 (0: no)"
    )
    ap.add_argument(
        "--at-jamming", type=int, nargs="*", default=[],
        help="also time constant-volume shear (fast path, --jam-steps steps) from "
        "jam(N, 3, seed, p_target=1e-7) for these N",
    )
    ap.add_argument("--at-jamming-seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument(
        "--at-pressure", type=float, nargs="*", default=[],
        help="also time fixed-pressure shear (the default inner minimiser, --jam-steps steps) "
        "from jam_at_pressure(--at-pressure-n, 3, seed, P) for these P and --at-jamming-seeds",
    )
    ap.add_argument("--at-pressure-n", type=int, default=250)
    ap.add_argument(
        "--prepared-seeds", type=int, nargs="*", default=[],
        help="also time the fast path (--steps steps) from prepare(1000, 3, 0.8, seed), the "
        "typical starts of bench_aqs.py",
    )
    ap.add_argument("--cache", default=None,
                    help="where the made packings are kept between rounds (default: a temporary "
                    "directory, removed at the end)")
    args = ap.parse_args(argv)
    if not START.is_dir():
        print(f"reference start not found at {START}")
        return 0
    runs: dict[str, list[dict]] = {"A": [], "B": []}
    with tempfile.TemporaryDirectory(prefix="bench_refactor_") as tmp:
        if args.cache is None:
            args.cache = tmp
        Path(args.cache).mkdir(parents=True, exist_ok=True)  # (the children only write into it)
        for k in range(args.repeat):
            for label, src in (("A", args.compare_src), ("B", args.src)):
                runs[label].append(run_child(src, args))
            print(f"round {k + 1}/{args.repeat} done", flush=True)
    print(f"A (before) = {runs['A'][0]['jamlab']}\nB (after)  = {runs['B'][0]['jamlab']}")
    cases = [c for c in runs["A"][0] if c != "jamlab"]
    for what, col in (("wall clock (ShearResult.time)", 0), ("CPU time (process_time)", 1)):
        print(f"\n{what}")
        print(f"{'case':30s} {'A ms/step':>10s} {'B ms/step':>10s} {'B/A best':>9s}  B/A per round")
        for case in cases:
            a = [r[case][col] for r in runs["A"]]
            b = [r[case][col] for r in runs["B"]]
            plastic = sorted({r[case][2] for r in runs["A"] + runs["B"]})
            rounds = " ".join(f"{y / x:.2f}" for x, y in zip(a, b, strict=True))
            print(
                f"{case:30s} {1e3 * min(a):10.2f} {1e3 * min(b):10.2f} {min(b) / min(a):9.3f}  "
                f"{rounds}  (plastic: {plastic})"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
