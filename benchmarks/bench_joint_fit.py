"""The joint finite-size fit (``fit_joint_scaling``) in two source trees, side by side in one run.

Each tree runs in its own child process (``_trees.run_in_tree``: one thread of every library):
the fit of ``--ensembles`` synthetic ensembles (the generator of
``tests/analysis/test_finite_size_joint.py``, seeds ``100 t + 1``: 4 sizes N = 250–2000, 20
samples each, a cut-off ``S* ∝ N``) with ``--boot`` bootstrap resamples, each timed alone after
one warm-up fit (numba's compile or cache load is not counted). Rounds alternate between the trees
(``--repeat``), and the best time of each ensemble is kept. Printed per ensemble: the times, their
ratio, and the largest difference of ``τ``, ``β`` and their bootstrap errors between the trees (the
compiled search sorts its simplex stably, scipy's ``argsort`` does not; resamples that pass
through exactly equal values move by the search's tolerance).

Run: ``python benchmarks/bench_joint_fit.py --compare-src /tmp/base/src [--src src]
[--ensembles 6] [--boot 100] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trees import run_in_tree  # noqa: E402

CHILD = r"""
import json, math, sys, time
import numpy as np
from jamlab.analysis.finite_size import fit_joint_scaling

TAU, BETA, AMP, NS = 1.4, 1.0, 30.0, (250, 500, 1000, 2000)

def draw(rng, floor, s_star, k):
    out = []
    while len(out) < k:
        s = floor * (1.0 - rng.random(4 * k + 8)) ** (-1.0 / (TAU - 1.0))
        s = s[rng.random(s.size) < np.exp(-s / s_star)]
        out.extend(s.tolist())
    return np.array(out[:k])

def ensemble(seed):
    rng = np.random.default_rng(seed)
    fl = {n: (n / NS[0]) ** 0.5 for n in NS}
    return {n: [draw(rng, fl[n], AMP * (n / NS[0]) ** BETA, rng.poisson(4 * n / NS[0]))
                for _ in range(20)] for n in NS}, fl

n_ens, n_boot = int(sys.argv[1]), int(sys.argv[2])
ens0, fl0 = ensemble(1)
fit_joint_scaling(ens0, fl0, n_boot=2)  # compile or load the cache
rows = []
for t in range(n_ens):
    ens, fl = ensemble(100 * t + 1)
    start = time.perf_counter()
    f = fit_joint_scaling(ens, fl, n_boot=n_boot, seed=t)
    rows.append([time.perf_counter() - start, f.tau, f.beta, f.tau_err, f.beta_err])
print(json.dumps(rows))
"""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--src", default="src")
    ap.add_argument("--compare-src", required=True, help="the other tree (e.g. before a change)")
    ap.add_argument("--ensembles", type=int, default=6)
    ap.add_argument("--boot", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    trees = {"this": a.src, "other": a.compare_src}
    best: dict[str, list[list[float]]] = {}
    for _ in range(a.repeat):
        for name, src in trees.items():
            rows = json.loads(run_in_tree(src, CHILD, [a.ensembles, a.boot]))
            if name not in best:
                best[name] = rows
            else:
                for old, new in zip(best[name], rows, strict=True):
                    old[0] = min(old[0], new[0])
    print(f"fit_joint_scaling, {a.boot} resamples, best of {a.repeat} alternated rounds; "
          f"this = {a.src}, other = {a.compare_src}")
    print("| ensemble | other s | this s | other / this | max |Δ| of τ, β, σ_τ, σ_β |")
    print("|---|---|---|---|---|")
    for t, (o, n) in enumerate(zip(best["other"], best["this"], strict=True)):
        diff = max(abs(x - y) for x, y in zip(o[1:], n[1:], strict=True))
        print(f"| {100 * t + 1} | {o[0]:.3f} | {n[0]:.3f} | {o[0] / n[0]:.1f} | {diff:.1e} |")
    total_o = sum(r[0] for r in best["other"])
    total_n = sum(r[0] for r in best["this"])
    print(f"| all | {total_o:.2f} | {total_n:.2f} | {total_o / total_n:.1f} | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
