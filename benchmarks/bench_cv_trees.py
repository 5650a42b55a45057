"""Constant-volume AQS at jamming with two source trees: CPU time side by side, traces compared.

For a change meant to keep the constant-volume protocol's results bit for bit (a faster path to
the same verdicts) and to make it cheaper. Each packing — ``jam(N, 3, seed,
p_target=--p-start)`` (the paper's start at jamming by default), made once with the "after"
tree and kept in ``--cache``; its ``packing`` is used whether or not the search met its window
(``p_target = 1e-5`` ends at p = 4.9e-6 for seed 1 at N = 1000 and 2000, ``ok`` False) — is
sheared for ``--steps`` steps of ``δγ`` (the default path,
``AQSParameters(floppy=--floppy)``) in child processes with ``PYTHONPATH`` set to each tree,
alternately ``A B A B …`` for ``--repeat`` rounds (the machine is shared). Per packing it prints
the best CPU time of each tree, their ratio, the counters (FIRE fallbacks, rattler clean-ups,
substepped steps; in the JSON) and whether every trace dataset and the final positions are
equal bit for bit (NaN equal to NaN). ``iterations`` is compared apart: it counts the
continuation's Newton iterations too, which a change that ends a failing continuation sooner
lowers.
CPU time of the child (``time.process_time``, one BLAS/numba thread), compiled kernels
warmed first. Asserts nothing about time; exits 1 if a trace differs.

    PYTHONPATH=src python benchmarks/bench_cv_trees.py --old-src /tmp/base/src --n 1000 \\
        --seeds 1 3 --p-start 1e-5 --steps 100 --cache /tmp/cv_trees
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trees import run_in_tree  # noqa: E402  (benchmarks run as scripts)

CHILD = r"""
import json, pickle, sys, time
import numpy as np
from jamlab.spheres.aqs import AQSParameters, shear
from jamlab.spheres.packing import jam

n, seed, p_start, steps, dgamma, floppy, cache, out = sys.argv[1:9]
n, seed, p_start, steps, dgamma = int(n), int(seed), float(p_start), int(steps), float(dgamma)
path = f"{cache}/jam_n{n}_s{seed}_p{p_start:g}.pkl"
try:
    with open(path, "rb") as fh:
        packing = pickle.load(fh)
except FileNotFoundError:
    packing = jam(n, 3, seed=seed, p_target=p_start).packing
    with open(path, "wb") as fh:
        pickle.dump(packing, fh)
if steps == 0:
    sys.exit(0)  # the packing only
params = AQSParameters(floppy=floppy)
shear(packing, dgamma, n_steps=2, params=params)  # compile
t = time.process_time()
res = shear(packing, dgamma, n_steps=steps, params=params)
cpu = time.process_time() - t
tr = res.trace
arrays = {k: np.asarray(tr[k]) for k in tr.keys()} if hasattr(tr, "keys") else {
    k: np.asarray(v) for k, v in vars(tr).items() if isinstance(v, np.ndarray)}
arrays["final_positions"] = res.packing.positions
np.savez(out, **arrays)
print(json.dumps({"cpu": cpu, "fallback": res.n_fallback, "cleanup": res.n_cleanup,
                  "substepped": res.n_substepped}))
"""


def run(src: str, args: list[str]) -> dict:
    stdout = run_in_tree(src, CHILD, args)
    lines = stdout.strip().splitlines()
    return json.loads(lines[-1]) if lines else {}


def same(a: Path, b: Path) -> tuple[bool, list[str]]:
    x, y = np.load(a), np.load(b)
    bad = [k for k in sorted(set(x.files) | set(y.files)) if k != "iterations"
           if k not in x.files or k not in y.files
           or not np.array_equal(x[k], y[k], equal_nan=x[k].dtype.kind == "f")]
    if not np.array_equal(x["iterations"], y["iterations"]):
        fewer = int(np.sum(x["iterations"]) - np.sum(y["iterations"]))
        return not bad, bad + [f"(iterations: {fewer:+,} fewer in B)"]
    return not bad, bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old-src", required=True, help="the 'before' source tree (A)")
    ap.add_argument("--src", default=str(Path(__file__).resolve().parents[1] / "src"),
                    help="the 'after' source tree (B)")
    ap.add_argument("--n", type=int, nargs="+", default=[1000])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 3])
    ap.add_argument("--p-start", type=float, default=1e-7)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--floppy", choices=("fire", "project"), default="project")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--cache", type=Path, default=Path("cv_trees_cache"))
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    a.cache.mkdir(parents=True, exist_ok=True)
    rows, all_same = [], True
    for n in a.n:
        for seed in a.seeds:
            common = [str(n), str(seed), repr(a.p_start), str(a.steps), repr(a.dgamma), a.floppy,
                      str(a.cache)]
            made = [str(n), str(seed), repr(a.p_start), "0", *common[4:]]
            run(a.src, [*made, str(a.cache / "unused.npz")])  # the packing, once (B)
            best: dict[str, dict] = {}
            for _ in range(a.repeat):
                for tag, src in (("A", a.old_src), ("B", a.src)):
                    r = run(src, [*common, str(a.cache / f"trace_n{n}_s{seed}_{tag}.npz")])
                    if tag not in best or r["cpu"] < best[tag]["cpu"]:
                        best[tag] = r
            ok, notes = same(a.cache / f"trace_n{n}_s{seed}_A.npz",
                             a.cache / f"trace_n{n}_s{seed}_B.npz")
            bad = [k for k in notes if not k.startswith("(")]
            all_same &= ok
            row = {"n": n, "seed": seed, "p_start": a.p_start, "steps": a.steps,
                   "A": best["A"], "B": best["B"], "ratio": best["A"]["cpu"] / best["B"]["cpu"],
                   "identical": ok, "differing": bad}
            rows.append(row)
            ta, tb = best["A"]["cpu"], best["B"]["cpu"]
            print(f"N={n} seed={seed} p_start={a.p_start:g} {a.steps} steps: "
                  f"A {ta:.1f} s, B {tb:.1f} s, A/B {row['ratio']:.2f}; "
                  f"fallbacks {best['A']['fallback']}/{best['B']['fallback']}, cleanups "
                  f"{best['A']['cleanup']}/{best['B']['cleanup']}; traces "
                  f"{'identical' if ok else 'DIFFER in ' + ', '.join(bad)} "
                  f"{' '.join(k for k in notes if k.startswith('('))}", flush=True)
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0 if all_same else 1


if __name__ == "__main__":
    raise SystemExit(main())
