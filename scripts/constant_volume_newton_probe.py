"""Would the fixed-pressure Newton path pay at constant volume near jamming? A probe.

``jam(N, 3, seed, p_target=1e-7)``, then ``--steps`` constant-volume steps of ``δγ`` three ways,
CPU time of each: the default fast path (``shear(minimizer="linear")``), plain FIRE with the
classification (``minimizer="fire", classify=True``), and a prototype of the fixed-pressure
scheme without the barostat — each step relaxed by the Newton relaxer
(:class:`jamlab.spheres.newton_relax.NewtonRelaxer`, FIRE where it cannot), a candidate when the
trapezoid residual of ``E`` exceeds ``0.1 δγ²``, confirmed as a jump by the chain of 16 pieces
(:func:`jamlab.spheres.confirm.jump_in_chain`) unless Newton continued the step. Prints time per
step, the steps each flags, the relaxer's counters and the residuals ``r/δγ²`` of the FIRE run
and of the prototype (the same minima give the same residuals).

    python scripts/constant_volume_newton_probe.py --n 500 --seed 1 --steps 20 --dgamma 1e-5
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from jamlab.spheres.aqs import shear
from jamlab.spheres.confirm import jump_in_chain, trapezoid_residual
from jamlab.spheres.fire import minimize
from jamlab.spheres.newton_relax import NewtonRelaxer
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import affine_shear, evaluate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    a = ap.parse_args()
    dg, steps = a.dgamma, a.steps
    pk = jam(a.n, 3, seed=a.seed, p_target=1e-7).packing
    traces = {}
    for mode in ("linear", "fire"):
        t = time.process_time()
        tr = shear(pk, dg, n_steps=steps, minimizer=mode, classify=True).trace
        dt = time.process_time() - t
        traces[mode] = tr
        print(f"{mode:>6}: {1e3 * dt / steps:.0f} ms/step, plastic steps "
              f"{np.flatnonzero(tr.plastic).tolist()}, jammed minima {int(tr.jammed.sum())} of "
              f"{steps + 1}, p {tr.pressure[1]:.1e} .. {tr.pressure[-1]:.1e}", flush=True)
    rel = NewtonRelaxer()

    def advance(c, dh):
        m = rel(affine_shear(c, dh), ftol=1e-12, parent=c)
        e = evaluate(m.packing)
        return m.packing, e.energy, e.shear_stress, m.iterations

    def fire_calls() -> int:
        return rel.counters["n_fire_fallbacks"] + rel.counters["n_rattler_polish"]

    t = time.process_time()
    cur = minimize(pk, ftol=1e-12).packing
    ev = evaluate(cur)
    energy, stress = [ev.energy], [ev.shear_stress]
    jumps, candidates, continued = [], 0, 0
    for k in range(1, steps + 1):
        before = fire_calls()
        nxt, e, s, _ = advance(cur, dg)
        r = trapezoid_residual(energy[-1], stress[-1], e, s, dg)
        if abs(r) > 0.1 * dg * dg:
            candidates += 1
            if fire_calls() == before:
                continued += 1
            elif jump_in_chain(advance, cur, energy[-1], stress[-1], dg, r, 16)[0]:
                jumps.append(k)
        energy.append(e)
        stress.append(s)
        cur = nxt
    dt = time.process_time() - t
    print(f" proto: {1e3 * dt / steps:.0f} ms/step, confirmed jumps {jumps}, candidates "
          f"{candidates} (continued {continued}), relaxer {rel.counters}")
    r_fire = traces["fire"].residual[1:] / dg**2
    e, s = np.asarray(energy), np.asarray(stress)
    r_proto = (np.diff(e) - dg * s[:-1] - 0.5 * dg * np.diff(s)) / dg**2
    print("r/δγ² FIRE :", np.round(r_fire, 2).tolist())
    print("r/δγ² proto:", np.round(r_proto, 2).tolist())


if __name__ == "__main__":
    main()
