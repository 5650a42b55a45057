"""Fixed-pressure AQS: the Newton inner minimiser against plain FIRE, side by side in one run.

For each ``N``, target pressure ``p`` and packing seed: ``jam(N, 3, seed, p_target=min(p, 1e-4))``
(cached in ``--cache``), one fixed-pressure step with FIRE (which brings it to ``p``), then
``--steps`` steps of ``δγ`` with ``minimizer="newton"`` and ``"fire"``, alternating, best of
``--repeat`` in CPU time (the machine is shared: CPU time, not wall). Printed per case: CPU
ms/step of both, their ratio, the FIRE iterations, the Newton relaxer's counters, whether the
plastic flags agree and the largest difference of the recorded enthalpy, stress and box side
(the two minimisers must find the same minima); and the projection of a 1000-step sample.

    python benchmarks/bench_pressure.py --n 250 500 1000 --pressures 1e-3 1e-4 --seeds 1 2
"""

from __future__ import annotations

import argparse
import pickle
import time
from pathlib import Path

import numpy as np

from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


def start(n: int, p: float, seed: int, cache: Path):
    f = cache / f"jam_n{n}_p{p:g}_s{seed}.pkl"
    if f.is_file():
        return pickle.loads(f.read_bytes())
    t = time.process_time()
    # jam near jamming, then the fixed-pressure step brings it to p (as the reproduce scales do)
    # (a jammed packing off jam's pressure target is fine: the enthalpy minimisation sets p)
    r = jam(n, 3, seed=seed, p_target=min(p, 1e-4))
    first = shear_at_pressure(r.packing, 1e-6, pressure=p, n_steps=1, minimizer="fire")
    if not (first.columns["converged"].all() and first.columns["jammed"].all()):
        raise SystemExit(f"N={n} seed={seed}: no jammed minimum at p={p:g}")
    pk = first.packing
    cache.mkdir(parents=True, exist_ok=True)
    f.write_bytes(pickle.dumps(pk))
    print(f"  (jam N={n} p={p:g} seed={seed}: {time.process_time() - t:.0f} CPU s)", flush=True)
    return pk


def run(pk, dg, p, steps, minimizer):
    t = time.process_time()
    r = shear_at_pressure(pk, dg, pressure=p, n_steps=steps, minimizer=minimizer)
    return time.process_time() - t, r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[250, 500, 1000])
    ap.add_argument("--pressures", type=float, nargs="+", default=[1e-3, 1e-4])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--cache", type=Path, default=Path("bench_pressure_cache"))
    a = ap.parse_args()
    print(f"fixed-pressure AQS, d=3, δγ={a.dgamma:g}, {a.steps} steps, CPU time, best of "
          f"{a.repeat}")
    print(f"{'N':>5} {'p':>6} {'seed':>4} | {'newton ms':>9} {'fire ms':>9} {'ratio':>6} | "
          f"{'FIRE it N/F':>15} {'accepted':>9} {'cands':>5} {'plastic':>7} | "
          f"{'same flags':>10} {'max dH':>8} {'max dL':>8} | {'1000 steps N/F':>14}")
    for n in a.n:
        for p in a.pressures:
            for seed in a.seeds:
                pk = start(n, p, seed, a.cache)
                best = {"newton": (np.inf, None), "fire": (np.inf, None)}
                for _ in range(a.repeat):
                    for m in ("newton", "fire"):
                        t, r = run(pk, a.dgamma, p, a.steps, m)
                        if t < best[m][0]:
                            best[m] = (t, r)
                (tn, rn), (tf, rf) = best["newton"], best["fire"]
                cn, cf = rn.columns, rf.columns
                dh = float(np.max(np.abs(cn["enthalpy"] - cf["enthalpy"])))
                dl = float(np.max(np.abs(cn["box_length"] - cf["box_length"])))
                same = bool(np.array_equal(cn["plastic"], cf["plastic"]))
                at = rn.attrs
                print(f"{n:>5} {p:>6.0e} {seed:>4} | {1e3 * tn / a.steps:>9.1f} "
                      f"{1e3 * tf / a.steps:>9.1f} {tf / tn:>6.2f} | "
                      f"{int(cn['iterations'][1:].sum()):>7}/{int(cf['iterations'][1:].sum()):<7} "
                      f"{at['n_newton_accepted']:>4}/{at['n_newton_calls']:<4} "
                      f"{at['n_candidates']:>5} {at['n_plastic']:>3}/{rf.attrs['n_plastic']:<3} | "
                      f"{str(same):>10} {dh:>8.1e} {dl:>8.1e} | "
                      f"{tn / a.steps * 1000 / 60:>5.1f}/{tf / a.steps * 1000 / 60:<5.1f} min",
                      flush=True)


if __name__ == "__main__":
    main()
