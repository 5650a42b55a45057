"""Contacts below the force resolution: how many fixed-pressure AQS minima hold a pair whose
overlap is below ``1e-12 σ`` (a contact by SPEC §3, ``r < σ``, whose force no minimum converged
to ``max|F_i| < 1e-12`` resolves), and in how many the jammed verdict could depend on them (the
isostatic excess ``N_c' − d(N'−1) − 1`` smaller than their number). ``docs/aqs.md``, "Jammed or
not".

    PYTHONPATH=src python scripts/touching_contacts.py --n 250 --pressure 1e-4 --seeds 1 2 3 4 \
        --steps 200 [--minimizer fire]
"""

from __future__ import annotations

import argparse

import numpy as np

from jamlab.spheres.contacts import contacts
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure
from jamlab.spheres.rigidity import is_jammed

UNRESOLVED = 1e-12
"""Overlap/σ below which a contact's force is below the minimiser's force tolerance."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--minimizer", choices=("newton", "fire"), default="newton")
    args = ap.parse_args()
    count = dict(minima=0, with_unresolved=0, unresolved_pairs=0, verdict_at_stake=0)
    smallest: list[float] = []

    def observe(_: int, pk) -> None:
        ci, cj, cd = contacts(pk)
        d = np.asarray(pk.diameters)
        overlap = 1.0 - np.sqrt((cd**2).sum(axis=1)) / (0.5 * (d[ci] + d[cj]))
        k = int(np.count_nonzero(overlap < UNRESOLVED))
        js = is_jammed(pk)
        count["minima"] += 1
        count["with_unresolved"] += k > 0
        count["unresolved_pairs"] += k
        count["verdict_at_stake"] += bool(k > 0 and js.jammed and js.excess < k)
        smallest.append(float(overlap.min()) if overlap.size else np.nan)

    for seed in args.seeds:
        shear_at_pressure(jam(args.n, 3, seed=seed, p_target=args.pressure).packing, args.dgamma,
                          pressure=args.pressure, n_steps=args.steps, observer=observe,
                          minimizer=args.minimizer)  # fmt: skip
    print(f"N = {args.n}, p = {args.pressure:g}, {args.minimizer}: {count}")
    q = np.nanquantile(smallest, [0.0, 0.05, 0.5])
    print("smallest overlap/sigma per minimum, quantiles 0, 5, 50 %: "
          + ", ".join(f"{v:.2e}" for v in q))  # fmt: skip


if __name__ == "__main__":
    main()
