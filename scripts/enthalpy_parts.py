"""Fixed-pressure avalanches: how much of ``S = −ΔH = −ΔE − p ΔV`` is the compaction term.

For each seed: ``jam(N, 3, seed, p_target=p)``, ``shear_at_pressure`` for ``--steps`` steps of
``--dgamma`` (module defaults), then for every counted avalanche (plastic, between jammed
minima, ``S > 0``) with ``S ≥ --floor``: its step, ``S``, and the share ``−p ΔV / S`` (``V`` from
``box_length``³), with φ and the shear stress ``Σ`` (extensive, ``∂H/∂γ``) at the start, middle and
end of the run.

    PYTHONPATH=src python scripts/enthalpy_parts.py --n 250 --seeds 70 87 145 1 2 3
"""

from __future__ import annotations

import argparse

import numpy as np

from jamlab.analysis.avalanches import classify_steps
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--floor", type=float, default=1e-8)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    a = ap.parse_args()
    shares = []
    for seed in a.seeds:
        pk = jam(a.n, 3, seed=seed, p_target=a.pressure).packing
        c = shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps).columns
        v = c["box_length"] ** 3
        size = -c["enthalpy_jump"]
        counted = np.zeros(size.size, dtype=bool)
        counted[1:] = classify_steps(c["enthalpy_jump"][1:], c["plastic"][1:],
                                     jammed=c["jammed"])
        big = np.where(counted & (size >= a.floor))[0]
        share = -a.pressure * (v[big] - v[big - 1]) / size[big]
        shares.extend(share.tolist())
        mid = c["gamma"].size // 2
        print(f"seed {seed}: φ {c['phi'][0]:.5f} → {c['phi'][mid]:.5f} → {c['phi'][-1]:.5f}, "
              f"Σ {c['shear_stress'][0]:.2e} → {c['shear_stress'][mid]:.2e} → "
              f"{c['shear_stress'][-1]:.2e}; {int(counted.sum())} avalanches, {big.size} with "
              f"S ≥ {a.floor:g}: " + ", ".join(
                  f"step {k}: S = {size[k]:.2e}, −pΔV/S = {x:.2f}"
                  for k, x in zip(big, share, strict=True)), flush=True)
    if shares:
        q = np.quantile(shares, [0.1, 0.5, 0.9])
        print(f"\n{len(shares)} avalanches with S ≥ {a.floor:g}: −pΔV/S median {q[1]:.2f} "
              f"(10–90 %: {q[0]:.2f} – {q[2]:.2f})")


if __name__ == "__main__":
    main()
