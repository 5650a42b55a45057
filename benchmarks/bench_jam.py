"""Time to jam N=1000 spheres in 3D beside one FIRE minimisation from random at φ = 0.64.

Prints the ratio to the 20 s target; asserts nothing about wall-clock time. CPU time
(``time.process_time``) is printed too, since the machine may be shared.

    python benchmarks/bench_jam.py [--n 1000] [--seeds 1 2 3]
"""

from __future__ import annotations

import argparse
import time

from jamlab.spheres import random_packing
from jamlab.spheres.fire import minimize
from jamlab.spheres.packing import jam

TARGET_SECONDS = 20.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args()
    jam(64, 3, 0)  # compile the numba kernels outside the timings
    t, c = time.perf_counter(), time.process_time()
    r = minimize(random_packing(args.n, 3, 0.64, args.seeds[0]), ftol=1e-12)
    print(
        f"one FIRE (engine defaults) from random at phi=0.64: {time.perf_counter() - t:.2f} s "
        f"wall, {time.process_time() - c:.2f} s CPU, {r.iterations} steps, converged={r.converged}"
    )
    for seed in args.seeds:
        t, c = time.perf_counter(), time.process_time()
        res = jam(args.n, 3, seed)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        print(
            f"jam N={args.n} seed={seed}: {wall:.2f} s wall, {cpu:.2f} s CPU, "
            f"{res.n_minimizations} minimisations, {res.fire_iterations} FIRE steps, "
            f"phi_J={res.phi_j:.6f} p={res.state.pressure:.2e} ok={res.ok}; "
            f"CPU / 20 s target = {cpu / TARGET_SECONDS:.2f}"
        )


if __name__ == "__main__":
    main()
