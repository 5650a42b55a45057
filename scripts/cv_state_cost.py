"""Where a constant-volume run's FIRE iterations go, by the state of each step's two minima.

Every minimum of a ``jamlab run`` sample at constant volume is **J** (jammed by the trace's
``jammed`` column: a rigid backbone and ``p`` above the resolution floor), **S** (unjammed but
stressed: ``p`` above the floor ``rigidity.pressure_floor(N, d, L, ftol = 1e-12)``, no rigid
backbone — a minimum that hovers at the edge of jamming) or **F** (floppy: ``p`` at or below the
floor). A step is the pair (its start, its end). Printed per run directory and N: for each kind
of step its count, its FIRE iterations (the trace's ``iterations``; a projected step counts its
linearisations, a fast-path step its Newton iterations — both negligible next to FIRE's) and
their share, and the median pressure at its end. Only J → J steps are ever counted as
avalanches. Asserts nothing.

    python scripts/cv_state_cost.py RUNS/jamming RUNS/jamming-project
"""

from __future__ import annotations

import argparse
import glob
import os
from collections import defaultdict

import h5py
import numpy as np

from jamlab.spheres.rigidity import pressure_floor

FTOL = 1e-12
KINDS = [a + b for a in "JSF" for b in "JSF"]


def states(h5: h5py.File) -> np.ndarray:
    t = h5["trace"]
    jammed = t["jammed"][:].astype(bool)
    n = int(h5.attrs["n"])
    dim = h5["packing/positions"].shape[1]
    floor = pressure_floor(n, dim, float(h5.attrs["box_length"]), FTOL)
    return np.where(jammed, "J", np.where(t["pressure"][:] > floor, "S", "F"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args()
    for run in a.runs:
        by_n: dict[int, dict] = defaultdict(lambda: defaultdict(lambda: [0, 0, []]))
        samples: dict[int, int] = defaultdict(int)
        for path in sorted(glob.glob(os.path.join(run, "samples", "*", "*", "*.h5"))):
            with h5py.File(path, "r") as h5:
                if not h5.attrs.get("complete", False):
                    continue
                n = int(h5.attrs["n"])
                s = states(h5)
                its = h5["trace/iterations"][:]
                p = h5["trace/pressure"][:]
            samples[n] += 1
            for i in range(1, s.size):
                c = by_n[n][s[i - 1] + s[i]]
                c[0] += 1
                c[1] += int(its[i])
                c[2].append(p[i])
        for n in sorted(by_n):
            total = sum(c[1] for c in by_n[n].values())
            print(f"\n{run}: N = {n}, {samples[n]} samples, {total:,} iterations\n")
            print("| step (start → end) | steps | iterations | share | per step | median p at "
                  "the end |\n|---|---|---|---|---|---|")
            for k in KINDS:
                if k in by_n[n]:
                    cnt, it, ps = by_n[n][k]
                    print(f"| {k[0]} → {k[1]} | {cnt} | {it:,} | {it / max(total, 1):.1%} | "
                          f"{it / cnt:,.0f} | {np.median(ps):.1e} |")


if __name__ == "__main__":
    main()
