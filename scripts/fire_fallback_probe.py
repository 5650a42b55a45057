"""Where FIRE spends a fixed-pressure step's fallback, and whether a Newton polish would pay.

Runs fixed-pressure AQS (``shear_at_pressure``, default Newton path) on ``jam(N, 3, seed,
p_target=p)`` and keeps the start of every inner problem the Newton relaxer handed to FIRE
(:class:`jamlab.spheres.newton_relax.NewtonRelaxer`'s fallbacks, plastic-flag substeps
included), with the minimum it was made from. For each start:

- how far FIRE's minimum lies from that parent (largest particle displacement, minimum image):
  a rearrangement or a contact change, not a slow elastic relaxation;
- FIRE's iterations to ``max|F| < 1e-7 … 1e-12`` (FIRE is deterministic, so these are the
  prefixes of one run): where its time goes;
- the hybrid "FIRE to a loose tolerance, then Newton from there" (the relaxer with the loose
  point as its own parent; plain FIRE from the loose point where Newton does not accept): its
  time against plain FIRE, and how far its minimum lies from FIRE's (``dx``) and their energies;
  with ``--parent-factor`` the relaxer starts holding the parent's factor, as it does when Newton
  gives a start up, so that no factorisation is made where the backbone did not change;
- with ``--trust-ncg K``: SciPy's trust-region Newton–CG (``trust-ncg``, the sparse Hessian of
  the current contacts for its products, rebuilt once per outer iteration) from the first ``K``
  starts, to a gradient norm 1e-13 or 2000 iterations: iterations, Hessian products, time,
  ``max|F|`` reached, and distance from FIRE's minimum.

    PYTHONPATH=src python scripts/fire_fallback_probe.py --n 1000 --pressure 1e-4 \\
        --dgamma 1e-5 --steps 40 --seed 1 --loose 1e-8 1e-9 1e-10
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.optimize as so

from jamlab.spheres.aqs.linalg import factorise
from jamlab.spheres.aqs.network import backbone_mask, contact_list
from jamlab.spheres.fire import minimize
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.newton_relax import NewtonRelaxer
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import evaluate, hessian
from jamlab.spheres.pressure_shear import shear_at_pressure

TOLERANCES = (1e-7, 1e-8, 1e-9, 1e-10, 1e-12)


def collect(n: int, pressure: float, dgamma: float, steps: int, seed: int) -> list[tuple]:
    """``(start, parent)`` of every inner problem of the run that the relaxer gave to FIRE."""
    caught: list[tuple] = []
    call = NewtonRelaxer.__call__

    def spy(self, packing, ftol=1e-12, max_iter=1_000_000, params=None, parent=None):
        before = self.counters["n_fire_fallbacks"]
        res = call(self, packing, ftol, max_iter, params, parent)
        if self.counters["n_fire_fallbacks"] > before and parent is not None:
            caught.append((packing, parent))
        return res

    NewtonRelaxer.__call__ = spy
    try:
        pk = jam(n, 3, seed=seed, p_target=pressure).packing
        shear_at_pressure(pk, dgamma, pressure=pressure, n_steps=steps)
    finally:
        NewtonRelaxer.__call__ = call
    return caught


_FACTORS: dict[int, object] = {}


def parent_factor(parent):
    """A fresh copy (no corrections) of the relaxer's factor made at ``parent`` (cached)."""
    from dataclasses import replace

    if id(parent) not in _FACTORS:
        # what the relaxer factorises at a parent: its backbone Hessian (RELAX_SKIN list)
        nl = NeighborList(parent, skin=RELAX_SKIN)
        ci, cj, cd = contact_list(parent, nl)
        _FACTORS[id(parent)] = factorise(parent, nl, backbone_mask(ci, cj, parent.n, parent.dim),
                                         (ci, cj, cd))
    return replace(_FACTORS[id(parent)])


def trust_ncg(start, max_iter: int = 2000) -> tuple:
    """SciPy ``trust-ncg`` on the pair energy from ``start``: ``(result, Hessian products,
    seconds)``; the Hessian is rebuilt once per new point (cached for its products)."""
    nl = NeighborList(start)
    shape = start.positions.shape
    cache: dict = {"key": None, "h": None, "products": 0}

    def fun(x):
        ev = evaluate(start.with_positions(x.reshape(shape)), nl)
        return ev.energy, -ev.forces.ravel()

    def hessp(x, v):
        key = x.tobytes()
        if cache["key"] != key:
            cache["key"], cache["h"] = key, hessian(start.with_positions(x.reshape(shape)), nl)
        cache["products"] += 1
        return cache["h"] @ v

    t0 = time.perf_counter()
    res = so.minimize(fun, start.positions.ravel().copy(), jac=True, hessp=hessp,
                      method="trust-ncg", options={"gtol": 1e-13, "maxiter": max_iter})
    return res, cache["products"], time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--loose", type=float, nargs="*", default=[1e-8, 1e-9, 1e-10])
    ap.add_argument("--parent-factor", action="store_true",
                    help="the hybrid's Newton starts with the parent's factor (Woodbury-corrected "
                    "for the loose point's contacts) instead of factorising at the loose point")
    ap.add_argument("--trust-ncg", type=int, default=0, metavar="K",
                    help="also run SciPy trust-ncg from the first K starts")
    a = ap.parse_args()
    starts = collect(a.n, a.pressure, a.dgamma, a.steps, a.seed)
    print(f"N = {a.n}, p = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps, seed {a.seed}: "
          f"{len(starts)} inner problems handed to FIRE")
    minimize(starts[0][0], ftol=1e-6)  # compile
    head = " ".join(f"its@{t:.0e}" for t in TOLERANCES)
    print(f"\n| # | strain from parent | max|F| at start | |x_FIRE − x_parent| | {head} | "
          + " | ".join(f"hybrid {t:.0e}: time, Newton?, dx, dE/E" for t in a.loose) + " |")
    total_fire = 0.0
    total = dict.fromkeys(a.loose, 0.0)
    accepted = dict.fromkeys(a.loose, 0)
    for k, (s, parent) in enumerate(starts):
        its = [minimize(s, ftol=t).iterations for t in TOLERANCES[:-1]]
        t0 = time.perf_counter()
        ref = minimize(s, ftol=1e-12)
        total_fire += time.perf_counter() - t0
        its.append(ref.iterations)
        moved = float(np.max(np.abs(s.box.minimum_image(ref.packing.positions
                                                        - parent.positions))))
        cells = []
        for tl in a.loose:
            if a.parent_factor:
                parent_factor(parent)  # (made before the clock starts)
            t0 = time.perf_counter()
            lo = minimize(s, ftol=tl)
            # the relaxer with the loose point as its own parent: Newton (and its rattler
            # polish) where it accepts, else its FIRE fallback from the same loose point
            relaxer = NewtonRelaxer()
            if a.parent_factor:
                # as the relaxer stands when Newton gave the start up: holding the factor of the
                # parent (no new factorisation where the loose point's backbone is the parent's;
                # the factorisation itself is not timed: the relaxer already has it)
                relaxer.fac, relaxer.age = parent_factor(parent), 1
            fin = relaxer(lo.packing, ftol=1e-12, parent=lo.packing).packing
            ok = relaxer.counters["n_fire_fallbacks"] == 0
            dt = time.perf_counter() - t0
            total[tl] += dt
            accepted[tl] += ok
            dx = float(np.max(np.abs(s.box.minimum_image(fin.positions - ref.packing.positions))))
            de = (evaluate(fin).energy - ref.energy) / abs(ref.energy)
            cells.append(f"{dt:.2f} s, {'yes' if ok else 'no'}, {dx:.1e}, {de:.1e}")
        print(f"| {k} | {s.strain - parent.strain:.2e} | {evaluate(s).max_force:.1e} | "
              f"{moved:.1e} | " + " | ".join(map(str, its)) + f" | {' | '.join(cells)} |")
    print(f"\nplain FIRE to 1e-12: {total_fire:.2f} s in all; hybrid: "
          + ", ".join(f"loose {t:.0e}: {total[t]:.2f} s (Newton accepted {accepted[t]} of "
                      f"{len(starts)})" for t in a.loose))
    if a.trust_ncg:
        print("\n| # | FIRE its, s | trust-ncg iterations | Hessian products | s | max|F| | "
              "dx from FIRE's minimum |")
        print("|---|---|---|---|---|---|---|")
    for k, (s, _) in enumerate(starts[: a.trust_ncg]):
        ref = minimize(s, ftol=1e-12)
        res, products, dt = trust_ncg(s)
        fin = s.with_positions(res.x.reshape(s.positions.shape))
        dx = float(np.max(np.abs(s.box.minimum_image(fin.positions - ref.packing.positions))))
        print(f"| {k} | {ref.iterations}, {ref.time:.2f} | {res.nit} | {products} | {dt:.1f} | "
              f"{evaluate(fin).max_force:.1e} | {dx:.1e} |")


if __name__ == "__main__":
    main()
