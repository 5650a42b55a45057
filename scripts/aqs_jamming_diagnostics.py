"""Why the substep continuation was slow near jamming (issue 6; the default is now the
event-driven one, see docs/aqs.md).

    python scripts/aqs_jamming_diagnostics.py [--n 128] [--p 1e-5] [--seed 1] [--steps 10]

Shears ``jam(n, 3, seed, p_target=p)`` with the fast path and
``AQSParameters(continuation="substep")`` and instruments that continuation
(``aqs._continue_branch``) from outside, without changing it. Printed:

1. contact changes between consecutive accepted substeps (rattler contacts / backbone-backbone);
2. the substep sizes tried, as ``log2(substep / δγ)``, accepted or not;
3. for each failure with a fresh factorisation: whether the linear-response point
   ``trial + M⁻¹ F_b`` has lost backbone particles (rattler rule on its contacts);
4. why Newton failed: PCG negative curvature, PCG iteration cap, or another test;
5. the lowest eigenvalues of the backbone Hessian at the start and at affinely sheared points,
   and the smallest overlaps.

Asserts nothing; the numbers are quoted in docs/aqs.md ("Near jamming").
"""

from __future__ import annotations

import argparse
import collections
import math

import numpy as np

from jamlab.spheres import aqs
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import NeighborList, energy_and_forces


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--p", type=float, default=1e-5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    args = ap.parse_args(argv)
    res = jam(args.n, 3, seed=args.seed, p_target=args.p)
    if not res.ok:
        raise SystemExit(f"jam({args.n}, seed={args.seed}) did not reach a jammed packing")
    start = res.packing
    n = start.n
    print(f"packing: N = {n}, phi = {start.phi:.6f}, p = {res.state.pressure:.3e}")

    # 5. spectrum and overlaps at the start
    nl = NeighborList(start)
    fac = aqs._factorise(start, nl, aqs._backbone(start, nl))
    ci, cj, cd = aqs._contact_list(start, nl)
    overlaps = np.sort(1.0 - np.sqrt(np.einsum("ij,ij->i", cd, cd)))
    print(f"backbone {int(fac.backbone.sum())} particles; smallest overlaps {overlaps[:5]}")
    for ds in (0.0, 0.03, 0.1, 1.0):
        q = aqs._affine_to(start, start.strain + ds * args.dgamma)
        ev = np.linalg.eigvalsh(aqs._backbone_matrix(q, nl, fac).toarray())
        print(
            f"  Hessian at the affine point {ds:g} dgamma: lowest {ev[0]:.2e}, "
            f"{int((ev < 0).sum())} negative"
        )

    stats: collections.Counter = collections.Counter()
    state: dict = {}
    newton, pcg, cont = aqs._newton, aqs._pcg, aqs._continue_branch

    def keys(packing, nl_):
        a, b, _ = aqs._contact_list(packing, nl_)
        return set((np.minimum(a, b) * n + np.maximum(a, b)).tolist())

    def pcg_counting(k, b, precond, atol, maxiter, d):
        x, ok, it = pcg(k, b, precond, atol, maxiter, d)
        if not ok:
            stats["newton failure: PCG " + ("cap" if it == maxiter else "negative curvature")] += 1
        return x, ok, it

    def newton_counting(trial, nl_, fac_, ftol, params):
        fails = sum(v for k, v in stats.items() if k.startswith("newton failure: PCG"))
        out = newton(trial, nl_, fac_, ftol, params)
        ds = trial.strain - state["strain"]
        size = int(round(math.log2(abs(ds) / args.dgamma))) if ds else 0
        stats[f"substep 2^{size:+d} dgamma " + ("accepted" if out.ok else "failed")] += 1
        if out.ok:
            now = keys(out.packing, nl_)
            for key in now ^ state["keys"]:
                i, j = divmod(key, n)
                both = fac_.backbone[i] and fac_.backbone[j]
                stats["contact change: " + ("backbone-backbone" if both else "rattler")] += 1
            state["keys"], state["strain"] = now, trial.strain
        else:
            if sum(v for k, v in stats.items() if k.startswith("newton failure: PCG")) == fails:
                stats["newton failure: other test"] += 1
            if fac_.fresh:
                free = fac_.free
                f = energy_and_forces(trial, nl_)[1][free]
                pos = np.array(trial.positions)
                pos[free] += fac_.solve(f.ravel()).reshape(free.size, trial.dim)
                lost = int((fac_.backbone & ~aqs._backbone(trial.with_positions(pos), nl_)).sum())
                label = f"{lost}" if lost < 3 else "3 or more"
                stats[f"fresh failure: prediction lost {label} backbone particles"] += 1
        return out

    def continue_tracking(branch_start, *a, **k):
        state["strain"] = branch_start.strain
        state["keys"] = keys(branch_start, a[2])
        return cont(branch_start, *a, **k)

    aqs._newton, aqs._pcg, aqs._continue_branch = newton_counting, pcg_counting, continue_tracking
    try:
        params = aqs.AQSParameters(continuation="substep")
        out = aqs.shear(start, args.dgamma, n_steps=args.steps, params=params)
    finally:
        aqs._newton, aqs._pcg, aqs._continue_branch = newton, pcg, cont
    print(
        f"{args.steps} steps: plastic rows {np.flatnonzero(out.trace.plastic).tolist()}, "
        f"{out.trace.attrs['n_factorisations']} factorisations"
    )
    for key in sorted(stats):
        print(f"  {key}: {stats[key]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
