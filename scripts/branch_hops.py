"""Fixed-pressure AQS: single steps that leave the quasi-static branch (measured, issue 18).

A step whose trapezoid residual ``r_n = ΔH_n − ½ δγ ΔΣ_n`` is far above any kink (``|r_n| >
100 ×`` the run's plastic threshold) but which the confirmation rejects (redone in 16 pieces from
the same minimum, no piece keeps a quarter of ``r_n``) is not an avalanche of the quasi-static
path: the single step of ``δγ`` landed in another minimum, the chain of small steps stayed on the
branch. Such steps are not counted (``plastic`` False), but the run continues from the single
step's minimum. For each seed: ``jam(N, 3, seed, p_target=p)``, ``shear_at_pressure`` for
``--steps`` steps of ``--dgamma`` (the defaults of the module), then for every such step the
chain redone from its start minimum in 16 pieces (``confirm_substeps=0``, so each piece's own
residual is seen): its largest piece residual and the enthalpy difference between the chain's
end and the single step's end.

    PYTHONPATH=src python scripts/branch_hops.py --n 250 --pressure 1e-4 --dgamma 1e-5 \\
        --steps 200 --seeds 1 2 3 4 5 6 7 8 9 10 70 87
"""

from __future__ import annotations

import argparse

import numpy as np

from jamlab.analysis.avalanches import branch_residual, jammed_steps
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--pieces", type=int, default=16)
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 11)))
    a = ap.parse_args()
    steps = plastic = 0
    hops = []
    for seed in a.seeds:
        minima = {}
        pk = jam(a.n, 3, seed=seed, p_target=a.pressure).packing
        # the chain's rule (the default when this was measured): the default "located" counts
        # these steps as plastic, so it would find none
        r = shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                              confirm="continued",
                              observer=lambda k, cur, m=minima: m.__setitem__(k, cur))
        c = r.columns
        resid = np.full(c["gamma"].size, np.nan)
        resid[1:] = branch_residual(c["enthalpy_jump"][1:], c["stress_jump"][1:],
                                    np.diff(c["gamma"]))
        off = np.zeros(resid.size, dtype=bool)
        off[1:] = (~c["plastic"][1:]) & jammed_steps(c["jammed"]) & (
            np.abs(resid[1:]) > 100.0 * r.threshold)
        steps += a.steps
        plastic += int(c["plastic"].sum())
        for k in np.where(off)[0]:
            start = minima[k - 1] if k - 1 in minima else pk
            h = a.dgamma / a.pieces
            ch = shear_at_pressure(start, h, pressure=a.pressure, n_steps=a.pieces,
                                   confirm_substeps=0).columns
            pieces = branch_residual(ch["enthalpy_jump"][1:], ch["stress_jump"][1:],
                                     np.diff(ch["gamma"]))
            hops.append((seed, int(k), float(resid[k]), float(np.max(np.abs(pieces))),
                         float(ch["enthalpy"][-1] - c["enthalpy"][k]), float(r.threshold)))
        print(f"seed {seed}: threshold {r.threshold:.2e} ε, {int(c['plastic'].sum())} plastic "
              f"steps, {int(off.sum())} off the branch", flush=True)
    print(f"\nN = {a.n}, p = {a.pressure:g}, δγ = {a.dgamma:g}: {steps} steps, {plastic} plastic, "
          f"{len(hops)} single steps off the quasi-static branch")
    if hops:
        print("| seed | step | r_n (ε) | largest piece residual of the chain (ε) | "
              "H(chain end) − H(single step) (ε) | threshold (ε) |")
        print("|---|---|---|---|---|---|")
        for seed, k, rn, piece, dh, thr in hops:
            print(f"| {seed} | {k} | {rn:.3g} | {piece:.2g} | {dh:.3g} | {thr:.2g} |")


if __name__ == "__main__":
    main()
