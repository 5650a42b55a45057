"""CHOLMOD's BLAS kernels: cvxopt's OpenBLAS as it chooses alone (``native``) against the kernels
numpy's OpenBLAS chose (``aligned``, the default; ``jamlab.spheres.blas``), in one run.

Where cvxopt's bundled OpenBLAS (0.3.15) does not know the CPU it runs generic kernels
(``Prescott`` on an Emerald Rapids Xeon); ``aligned`` gives it the CPU's. Each round runs both
modes, alternating, each in a fresh process (a library chooses its kernels when it is loaded)
with the run workers' one-thread environment, on the same cached starts:

- ``factorise``: CHOLMOD's supernodal Cholesky of the pinned backbone Hessian (the call
  ``linalg.factorise`` makes), best of 5, of ``prepare(1000, 3, 0.8, s)`` and of the
  fixed-pressure start ``jam(1000, 3, s)`` at p = 1e-4 (``bench_pressure.start``);
- ``fast path``: ``aqs.shear`` of the prepared φ = 0.8 packing, ``--steps`` steps of δγ = 1e-5
  (the ``bench_aqs.py --prepared-seeds`` case);
- ``fixed p``: ``aqs.shear(pressure=1e-4)`` of the p = 1e-4 start, ``--steps`` steps (the Newton
  relaxer factorises the backbone at most steps).

Prints per case the best CPU time of each mode, their ratio (native / aligned: > 1 means aligned
is faster) and every round's ratio, the kernels each mode ran, and whether the two runs end at
the same energy, bit for bit (and their plastic steps). Asserts nothing about time.

    python benchmarks/bench_blas_core.py --seeds 1 2 3 --repeat 3 --cache CACHE
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from jamlab.runs.execute import SINGLE_THREAD_ENV

HERE = Path(__file__).resolve().parent
MODES = ("native", "aligned")


def prepared(seed: int, cache: Path):
    """``prepare(1000, 3, 0.8, seed)``, cached (made once, by the first process that needs it)."""
    from jamlab.spheres.packing import prepare

    f = cache / f"prepare_n1000_phi0.8_s{seed}.pkl"
    if not f.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        f.write_bytes(pickle.dumps(prepare(1000, 3, 0.8, seed).packing))
    return pickle.loads(f.read_bytes())


def child(seeds: list[int], steps: int, cache: Path) -> dict:
    """Every case in this process: CPU seconds and a digest of each result."""
    import scipy.sparse as sps

    sys.path.insert(0, str(HERE))
    from bench_factorisation import backbone_hessian
    from bench_pressure import start
    from jamlab.spheres import aqs, blas
    from jamlab.spheres.aqs.linalg import ND_MIN_FREE, cholesky

    out: dict = {"cores": sorted({f"{c['prefix']} {c['architecture']}" for c in blas.cores()})}
    for s in seeds:
        starts = {"prepare φ=0.8": prepared(s, cache), "p=1e-4": start(1000, 1e-4, s, cache)}
        for label, packing in starts.items():
            k = backbone_hessian(packing)
            kc = sps.csc_matrix((k.data, k.indices, k.indptr), shape=k.shape)
            natural = k.shape[0] // 3 >= ND_MIN_FREE
            best = min(_cpu(lambda kc=kc, nat=natural: cholesky(kc, nat))[0] for _ in range(5))
            out[f"factorise {label} s{s}"] = {"seconds": best}
        aqs.shear(starts["prepare φ=0.8"], 1e-5, n_steps=2)  # compile, warm
        for label, kw in (("fast path φ=0.8", {}), ("fixed p=1e-4", {"pressure": 1e-4})):
            key = "prepare φ=0.8" if not kw else "p=1e-4"
            t, r = _cpu(lambda p=starts[key], kw=kw: aqs.shear(p, 1e-5, n_steps=steps, **kw))
            energy = np.asarray(r.trace.energy)
            out[f"{label} s{s}"] = {"seconds": t / steps, "plastic": int(r.trace.plastic.sum()),
                                    "final_energy": energy[-1:].tobytes().hex()}
    return out


def _cpu(fn):
    t = time.process_time()
    result = fn()
    return time.process_time() - t, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cache", type=Path, default=Path("bench-cache"))
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.seeds, args.steps, args.cache)))
        return
    rounds: dict[str, list[dict]] = {m: [] for m in MODES}
    for i in range(args.repeat):
        for mode in MODES if i % 2 == 0 else MODES[::-1]:
            env = {**os.environ, **SINGLE_THREAD_ENV, "JAMLAB_CHOLMOD_BLAS": mode}
            env.pop("OPENBLAS_CORETYPE", None)
            cmd = [sys.executable, __file__, "--child", "--seeds", *map(str, args.seeds),
                   "--steps", str(args.steps), "--cache", str(args.cache)]
            done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
            rounds[mode].append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(f"round {i + 1}/{args.repeat} done", flush=True)
    for mode in MODES:
        print(f"{mode}: kernels {', '.join(rounds[mode][0]['cores'])}")
    print(f"\n{'case':28s} {'native ms':>10s} {'aligned ms':>11s} {'ratio':>6s}  per round   "
          "same final E / plastic steps")
    for case in [k for k in rounds["native"][0] if k != "cores"]:
        a = [r[case]["seconds"] for r in rounds["native"]]
        b = [r[case]["seconds"] for r in rounds["aligned"]]
        per = " ".join(f"{x / y:.2f}" for x, y in zip(a, b, strict=True))
        extra = ""
        if "final_energy" in rounds["native"][0][case]:
            same = (rounds["native"][0][case]["final_energy"]
                    == rounds["aligned"][0][case]["final_energy"])
            extra = (f"{'yes' if same else 'no'} / {rounds['native'][0][case]['plastic']}, "
                     f"{rounds['aligned'][0][case]['plastic']}")
        print(f"{case:28s} {1e3 * min(a):10.2f} {1e3 * min(b):11.2f} {min(a) / min(b):6.2f}  "
              f"{per:11s} {extra}")


if __name__ == "__main__":
    main()
