"""The backbone factorisation: SuperLU (jamlab's before), CHOLMOD (now) and MKL PARDISO, in one run.

Each factorises the same pinned backbone Hessian ``K`` (:func:`jamlab.spheres.aqs.linalg.
factorise`, free particles in METIS nested-dissection order) of typical minima: a
``prepare(N, 3, 0.8, seed)`` packing (above jamming, where the fast path's time is SuperLU solves
and a few factorisations per plastic event) and ``jam(N, 3, seed, p_target)`` (near jamming,
the fixed-pressure Newton relaxer). SuperLU as ``factorise`` took it before (natural order, no
pivoting, symmetric mode, :func:`~jamlab.spheres.aqs.linalg.ldlt`); CHOLMOD's supernodal Cholesky
as it takes it now (:func:`~jamlab.spheres.aqs.linalg.cholesky`, the same order); PARDISO
(``pypardiso``, one MKL thread, its own METIS order) as ``LLᵀ``
(``mtype 2``, enough for the positive-definiteness test) and ``LDLᵀ`` (``mtype −2``, inertia in
``iparm[21:23]``). Times are the best of ``--repeat`` runs (CPU time, one core), the solve a
single right-hand side, as the PCG preconditioner uses it; the solutions are compared.

PARDISO is *not* a dependency of jamlab (``pip install pypardiso`` pulls ≈ 1 GB of MKL): without
it the script times SuperLU and CHOLMOD. Prints ratios; asserts nothing about time.

    MKL_NUM_THREADS=1 python benchmarks/bench_factorisation.py --n 1000 --seeds 1 2
    python benchmarks/bench_factorisation.py --n 1000 2000 4000 --seeds 1 2 --no-prepare \\
        --cache CACHE
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sps

import jamlab.spheres as sp
from jamlab.spheres.aqs.linalg import ND_MIN_FREE, backbone_matrix, cholesky, factorise, ldlt
from jamlab.spheres.aqs.network import find_backbone
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_pressure import start as cached_packing  # noqa: E402  (benchmarks run as scripts)


def best(fn, repeat: int):
    """``(best CPU seconds, last result)`` of ``repeat`` calls."""
    times, out = [], None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        times.append(time.process_time() - t)
    return min(times), out


def backbone_hessian(packing) -> sps.csr_matrix:
    nl = NeighborList(packing, skin=RELAX_SKIN)
    fac = factorise(packing, nl, find_backbone(packing, nl))
    return backbone_matrix(packing, nl, fac).tocsr()


def compare(name: str, k: sps.csr_matrix, repeat: int) -> None:
    n = k.shape[0]
    b = np.random.default_rng(0).standard_normal(n)
    kc = sps.csc_matrix((k.data, k.indices, k.indptr), shape=k.shape)  # K symmetric
    natural = n // 3 >= ND_MIN_FREE  # the order factorise takes (d = 3)
    t_f, (lu, _) = best(lambda: ldlt(kc, natural), repeat)  # SuperLU, as before
    t_s, x = best(lambda: lu.solve(b), 10 * repeat)
    t_cf, chol = best(lambda: cholesky(kc, natural), repeat)  # what factorise takes now
    t_cs, y = best(lambda: chol.solve(b), 10 * repeat)
    diff = float(np.max(np.abs(y - x)) / np.max(np.abs(x)))
    row = (f"| {name} | {n} | {lu.L.nnz:,} | {1e3 * t_f:.1f}, {1e3 * t_s:.2f} | "
           f"{1e3 * t_cf:.1f} ({t_f / t_cf:.1f}×), {1e3 * t_cs:.2f} ({t_s / t_cs:.1f}×), "
           f"rel. diff {diff:.0e} |")
    try:
        import pypardiso
    except ImportError:
        print(row + " (pypardiso not installed) | |")
        return
    upper = sps.triu(k, format="csr")
    cells = []
    for mtype in (2, -2):
        solver = pypardiso.PyPardisoSolver(mtype=mtype)
        solver.set_phase(12)
        t_pf, _ = best(lambda s=solver: s._call_pardiso(upper, np.zeros(n)), repeat)
        solver.set_phase(33)
        t_ps, y = best(lambda s=solver: s._call_pardiso(upper, b), 10 * repeat)
        err = float(np.max(np.abs(y - x)) / np.max(np.abs(x)))
        cells.append(
            f"{1e3 * t_pf:.1f} ({t_f / t_pf:.1f}×), {1e3 * t_ps:.2f} ({t_s / t_ps:.2f}×), "
            f"rel. diff {err:.0e}"
        )
    print(row + " " + " | ".join(cells) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1000])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--phi", type=float, default=0.8)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-prepare", action="store_true", help="only the jammed packings")
    ap.add_argument("--cache", type=Path, default=None,
                    help="take the jammed packings from bench_pressure.py's cache (made there "
                         "if missing) instead of jam(N, 3, seed, p_target) here")
    a = ap.parse_args()
    print(
        "| packing | rows | SuperLU nnz(L) | SuperLU: factor, solve ms | CHOLMOD: factor ms "
        "(SuperLU/CHOLMOD), solve ms (ratio), rel. diff | PARDISO LLᵀ: factor ms "
        "(SuperLU/PARDISO), solve ms (ratio) | PARDISO LDLᵀ: the same |"
    )
    print("|---|---|---|---|---|---|---|")
    for n in a.n:
        for seed in a.seeds:
            if not a.no_prepare:
                pk = sp.prepare(n, 3, a.phi, seed=seed).packing
                compare(f"prepare({n}) φ = {a.phi:g}, seed {seed}", backbone_hessian(pk),
                        a.repeat)
            if a.cache is not None:
                pk = cached_packing(n, a.pressure, seed, a.cache)
            else:
                pk = sp.jam(n, 3, seed=seed, p_target=a.pressure).packing
            compare(f"jam({n}) p = {a.pressure:g}, seed {seed}", backbone_hessian(pk), a.repeat)


if __name__ == "__main__":
    main()
