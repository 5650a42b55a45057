"""The event-driven continuation's verdicts against the substep continuation and FIRE (issue 6).

    python scripts/aqs_continuation_check.py [--n 128] [--p 1e-5] [--seed 1] [--steps 30]
                                             [--fine-substep 20]

From ``jam(n, 3, seed, p_target=p)``, for each of ``steps`` AQS steps of ``δγ = 1e-5`` (each
from FIRE's minimum of the previous step, so the chain does not depend on either continuation):

- the event-driven network continuation (``AQSParameters()``, the default): continued or ended;
- the substep continuation of the earlier sessions with substeps down to ``δγ · 2^-fine``
  (``continuation="substep"``);
- FIRE from the affinely sheared start;
- where a continuation continued: whether its minimum (rattlers relaxed by FIRE) is FIRE's
  (energy to 1e-10 relative, backbone positions to 1e-6);
- the trapezoid residual ``r = ΔE − ½ δγ ΔΣ`` of FIRE's step: a drop below the branch (r ≪ 0
  compared with the continued steps) marks an avalanche independently of either continuation.

Asserts nothing; docs/aqs.md quotes the output.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from jamlab.spheres import aqs
from jamlab.spheres.fire import minimize
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import NeighborList, evaluate

DGAMMA = 1e-5


def same_as(packing, fire, nl) -> tuple[bool, float]:
    relaxed = minimize(packing, 1e-12, neighbors=nl).packing
    ea, eb = evaluate(relaxed, nl).energy, evaluate(fire, nl).energy
    dr = relaxed.box.minimum_image(relaxed.positions - fire.positions)
    keep = aqs._backbone(relaxed, nl)
    dx = float(np.max(np.abs(dr[keep] - dr[keep].mean(axis=0))))
    return abs(ea - eb) < 1e-10 * abs(eb) and dx < 1e-6, dx


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--p", type=float, default=1e-5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--fine-substep", type=int, default=20)
    args = ap.parse_args(argv)
    res = jam(args.n, 3, seed=args.seed, p_target=args.p)
    if not res.ok:
        raise SystemExit(f"jam({args.n}, seed={args.seed}) did not reach a jammed packing")
    cur = res.packing
    print(f"N = {cur.n}, phi = {cur.phi:.6f}, p = {res.state.pressure:.3e}")
    network = aqs.AQSParameters()
    fine = aqs.AQSParameters(continuation="substep", min_substep=2.0**-args.fine_substep)
    tally = {"agree": 0, "network only continues": 0, "substep only continues": 0}
    t_net = t_sub = 0.0
    for step in range(1, args.steps + 1):
        nl = NeighborList(cur)
        target = cur.strain + DGAMMA
        t = time.perf_counter()
        a = aqs._continue_network(cur, None, target, nl, 1e-12, network)
        t_net += time.perf_counter() - t
        t = time.perf_counter()
        fac = aqs._factorise(cur, nl, aqs._backbone(cur, nl))
        b = aqs._continue_branch(cur, fac, target, nl, 1e-12, fine)
        t_sub += time.perf_counter() - t
        fire = minimize(aqs._affine_to(cur, target), 1e-12, neighbors=nl).packing
        e0, e1 = evaluate(cur, nl), evaluate(fire, nl)
        r = e1.energy - e0.energy - 0.5 * DGAMMA * (e0.shear_stress + e1.shear_stress)
        words = []
        for name, br in (("network", a), ("substep", b)):
            if br.packing is None:
                words.append(f"{name}: ended")
            else:
                same, dx = same_as(br.packing, fire, nl)
                words.append(f"{name}: continued, {'=' if same else '≠'} FIRE (dx {dx:.0e})")
        ca, cb = a.packing is not None, b.packing is not None
        if ca == cb:
            key = "agree"
        else:
            key = "network only continues" if ca else "substep only continues"
        tally[key] += 1
        print(f"step {step:3d}: r = {r:+.2e}, events {a.events}; " + "; ".join(words), flush=True)
        cur = fire
    print(
        f"{tally}; time per step: network {1e3 * t_net / args.steps:.1f} ms, "
        f"substep (fine) {1e3 * t_sub / args.steps:.1f} ms"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
