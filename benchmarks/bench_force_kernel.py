"""The force kernel per particle against N: Verlet skin and the branch on the contact test.

For d = 3 monodisperse harmonic spheres near a minimum (``random_packing(N, 3, 0.645, seed)``
relaxed by FIRE to ``max|F| < 1e-6``: every particle in a few contacts, as in AQS near
jamming), times one force evaluation with the branchy kernel (``energy_forces_3d``: the contact
test ``r² < σ²`` is a branch) and the branch-free one (``energy_forces_3d_masked``: the test is a
select), on neighbour lists with skin 0.2 (``DEFAULT_SKIN``) and 0.1 (``RELAX_SKIN``), and which
one ``energy_forces_any`` dispatches to. Best of ``--repeat`` rounds of ``≈ 2e6 / N``
evaluations, the four cases interleaved, for each seed; prints ns per particle per evaluation and
the ratios to the old default (branchy, skin 0.2) side by side, and the machine's crossover as
:mod:`jamlab.spheres.kernel_choice` measures it (the dispatch column follows it). Asserts nothing
about time; checks that both kernels give the same bits.

The evaluation is repeated on one configuration, as FIRE's iterations nearly are (the contact
pattern changes little between iterations), so a branch predictor that can learn the pattern is
given the chance it has in FIRE.

``--fire PKL …`` (pickled jammed packings, e.g. the ``bench_pressure.py`` cache) times whole FIRE
relaxations instead: each packing sheared affinely by ``--dgamma`` at constant volume, then FIRE to
``max|F| < 1e-12`` on the relaxations' skin, once with every list on the branchy kernel and once
with every long list on the branch-free one (``JAMLAB_FORCE_KERNEL``'s two fixed choices),
alternating, CPU time, best of ``--repeat``; the iterations must agree (same bits), the time per
iteration and the ratio are printed beside the machine's automatic choice.

Run: ``python benchmarks/bench_force_kernel.py [--n 250 500 1000 2000 4000 8000] [--seeds 1 2]``
or ``python benchmarks/bench_force_kernel.py --fire CACHE/jam_n2000_p0.0001_s1.pkl …``
"""

from __future__ import annotations

import argparse
import pickle
import time
from pathlib import Path

import numpy as np

from jamlab.spheres import kernel_choice as KC
from jamlab.spheres.fire import minimize
from jamlab.spheres.kernel_choice import calibration, threshold_for
from jamlab.spheres.kernels import pairs as P
from jamlab.spheres.neighbors import DEFAULT_SKIN, RELAX_SKIN, NeighborList
from jamlab.spheres.state import affine_shear, random_packing


def per_particle(fn, n: int, repeat: int) -> float:
    fn()
    reps = max(20, 2_000_000 // n)
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(reps):
            fn()
        best = min(best, (time.perf_counter() - t) / reps)
    return 1e9 * best / n


def fire_runs(files: list[Path], dgamma: float, repeat: int) -> None:
    """Whole FIRE relaxations with each kernel (module docstring)."""
    auto = calibration()
    fixed = {k: KC.fixed(k) for k in ("branchy", "branch-free")}
    print("| packing | N | pairs | FIRE its | branchy: µs/it | branch-free: µs/it | "
          "branch-free / branchy | automatic choice |")
    print("|---|---|---|---|---|---|---|---|")
    for f in files:
        pk = affine_shear(pickle.loads(f.read_bytes()), dgamma)
        pairs = NeighborList(pk, skin=RELAX_SKIN).nbr.size
        best = {k: np.inf for k in fixed}
        its = set()
        for cal in fixed.values():  # load both compiled paths before timing
            KC.use(cal)
            minimize(pk, ftol=1e-12, max_iter=10, skin=RELAX_SKIN)
        for _ in range(repeat):
            for k, cal in fixed.items():
                KC.use(cal)
                t = time.process_time()
                r = minimize(pk, ftol=1e-12, skin=RELAX_SKIN)
                best[k] = min(best[k], time.process_time() - t)
                its.add((r.iterations, r.energy))
        KC.use(auto)
        if len(its) != 1:
            raise SystemExit(f"{f}: the two kernels gave different FIRE runs: {its}")
        (n_it, _), = its
        a, b = (1e6 * best[k] / n_it for k in ("branchy", "branch-free"))
        choice = "branch-free" if pairs > threshold_for(pairs) else "branchy"
        if pairs <= KC.CALIBRATE_ABOVE:
            choice += " (a short list: both columns ran the branchy kernel)"
        print(f"| {f.name} | {pk.n} | {pairs} | {n_it} | {a:.1f} | {b:.1f} | {b / a:.2f} | "
              f"{choice} |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[250, 500, 1000, 2000, 4000, 8000])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--fire", type=Path, nargs="+", default=None)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    a = ap.parse_args()
    print(calibration().describe())
    if a.fire:
        fire_runs(a.fire, a.dgamma, a.repeat)
        return
    print("ns per particle per force evaluation (best of rounds); ratio = branchy skin 0.2 / case")
    print("| N | seed | pairs (0.2 / 0.1) | branchy 0.2 | masked 0.2 | branchy 0.1 | masked 0.1 | "
          "dispatch at 0.1 | speed-up of the dispatch at 0.1 |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in a.n:
        for seed in a.seeds:
            pk = minimize(random_packing(n, 3, 0.645, seed), ftol=1e-6, max_iter=20_000).packing
            cells = {}
            pairs = []
            for skin in (DEFAULT_SKIN, RELAX_SKIN):
                nl = NeighborList(pk, skin=skin)
                pos = np.ascontiguousarray(nl.sorted(pk.positions))
                f, g = np.empty_like(pos), np.empty_like(pos)
                lst = (pos, nl.start, nl.nbr, nl.shift, nl.diameters)
                e1 = P.energy_forces_3d(*lst, None, f)
                e2 = P.energy_forces_3d_masked(*lst, g)
                if not (e1 == e2 and np.array_equal(f, g)):
                    raise SystemExit(f"N={n} seed={seed}: the kernels differ")
                pairs.append(int(nl.start[-1]))
                cells[("branchy", skin)] = per_particle(
                    lambda lst=lst, f=f: P.energy_forces_3d(*lst, None, f), n, a.repeat)
                cells[("masked", skin)] = per_particle(
                    lambda lst=lst, g=g: P.energy_forces_3d_masked(*lst, g), n, a.repeat)
            which = "masked" if pairs[1] > threshold_for(pairs[1]) else "branchy"
            base = cells[("branchy", DEFAULT_SKIN)]
            row = " | ".join(f"{cells[(k, s)]:.1f} ({base / cells[(k, s)]:.2f}×)"
                             for s in (DEFAULT_SKIN, RELAX_SKIN) for k in ("branchy", "masked"))
            print(f"| {n} | {seed} | {pairs[0]} / {pairs[1]} | {row} | {which} | "
                  f"{base / cells[(which, RELAX_SKIN)]:.2f}× |", flush=True)


if __name__ == "__main__":
    main()
