"""Where the floppy-step projection stops, and what its iteration settings change.

A sample's packing (a ``jamlab run`` sample file at constant volume, e.g. the ``medium`` scale's
N = 1000 index 0) is sheared with ``floppy="project"`` for ``--warm`` steps from γ = 0, the
run's own start (sample files keep the prepared packing, not the last minimum), to reach the
state of the run there — at ``--warm 337`` for that sample a minimum that hovers at the edge of
jamming (unjammed by the verdict, ``E ≈ 1e-17``). From there FIRE carries ``--steps`` steps of
``δγ``; at each, the affine start is also projected (:func:`jamlab.spheres.aqs.projection.project`,
the parent's touching pairs first) with the settings of ``VARIANTS``: the earlier
``max_sqp = 16`` without mixing, ``max_sqp = 40`` without mixing, and the defaults (40, Anderson
mixing of 4), and where the last fails a second attempt first linearised at FIRE's minimum to
``LOOSE_FTOL`` (``project(..., start=...)``; tried in the stepper and not kept, docs/aqs.md).
Printed per step: FIRE's iterations, CPU time and energy; per variant, found or why not,
linearisations / factorisations and CPU time (the second attempt's with its FIRE). Asserts
nothing.

    PYTHONPATH=src python scripts/projection_settle_probe.py SAMPLE.h5 --warm 337 --steps 24
"""

from __future__ import annotations

import argparse
import time

from jamlab.runs import prepared_packing
from jamlab.spheres.aqs import AQSParameters, shear
from jamlab.spheres.aqs.projection import project
from jamlab.spheres.fire import minimize
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.state import affine_shear

LOOSE_FTOL = 1e-10  # the second attempt's FIRE tolerance (tried in the stepper, not kept)
VARIANTS = ({"max_sqp": 16, "anderson": 0}, {"max_sqp": 40, "anderson": 0}, {})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sample")
    ap.add_argument("--warm", type=int, default=337)
    ap.add_argument("--steps", type=int, default=24)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    a = ap.parse_args()
    start = prepared_packing(a.sample)
    t = time.process_time()
    warm = shear(start, a.dgamma, n_steps=a.warm, params=AQSParameters(floppy="project"))
    cur = warm.packing
    print(f"warm-up: {a.warm} steps in {time.process_time() - t:.1f} CPU s; last minimum "
          f"E = {warm.trace.energy[-1]:.2e}, p = {warm.trace.pressure[-1]:.2e}, "
          f"jammed = {bool(warm.trace.jammed[-1])}")
    print("| step | FIRE its, CPU s, E | " + " | ".join(
        f"max_sqp {v.get('max_sqp', 40)}, anderson {v.get('anderson', 4)}" for v in VARIANTS)
          + " | where that fails: first linearised at FIRE's 1e-10 minimum |")
    print("|---|---|" + "---|" * (len(VARIANTS) + 1))
    nl = NeighborList(cur, skin=RELAX_SKIN)
    for step in range(a.steps):
        aff = affine_shear(cur, a.dgamma)
        t = time.process_time()
        fire = minimize(aff, neighbors=nl)
        row = f"| {step} | {fire.iterations}, {time.process_time() - t:.2f}, {fire.energy:.1e} |"
        for v in VARIANTS:
            t = time.process_time()
            res = project(aff, NeighborList(aff, skin=RELAX_SKIN), parent=cur, **v)
            row += (f" {'found' if res else res.reason}: {res.sqp} / {res.solves}, "
                    f"{time.process_time() - t:.2f} s |")
        if not res:  # the stepper's second attempt: first linearised at FIRE's loose minimum
            t = time.process_time()
            loose = minimize(aff, ftol=LOOSE_FTOL, neighbors=NeighborList(aff, skin=RELAX_SKIN))
            res = project(aff, NeighborList(aff, skin=RELAX_SKIN), parent=cur,
                          start=loose.packing)
            row += (f" {'found' if res else res.reason}: FIRE {loose.iterations}, "
                    f"{res.sqp} / {res.solves}, {time.process_time() - t:.2f} s |")
        else:
            row += " – |"
        print(row, flush=True)
        cur = fire.packing


if __name__ == "__main__":
    main()
