"""FIRE against the projection on the floppy steps of one hovering constant-volume sample.

From a sample file's packing (a ``jamlab run`` sample, e.g. the ``medium`` scale's N = 1000
index 0, which hovers at the edge of jamming) placed at the sample's final strain, FIRE takes
``--steps`` steps of ``δγ`` at constant volume (the usual chain). Sample files keep the
*prepared* packing (at γ = 0), not the run's last minimum, so the first step here relaxes an
affine jump of the whole strain (1 %) and the chain runs from that state, not from the run's own
(``scripts/projection_settle_probe.py`` replays the run instead). From step ``--skip`` on,
each step's affine start is also minimised by FIRE to ``max|F| < 1e-8`` only, and projected
(:func:`jamlab.spheres.aqs.projection.project`, cold and with the parent's touching pairs).
Printed per step: FIRE's iterations and CPU time to 1e-12, its energy and pressure; where FIRE
is at 1e-8 (iterations, distance to its end); the projection's CPU time (cold, warm), its
linearisations and factorisations, its largest distance to FIRE's minimum, and the distances
``|x − x₀|`` of both minima from the affine start (the projection's must be the smaller where
FIRE's minimum is overlap-free). Asserts nothing.

    python scripts/floppy_projection_probe.py SAMPLE.h5 --steps 12 --skip 4
"""

from __future__ import annotations

import argparse
import time

import h5py
import numpy as np

from jamlab.runs import prepared_packing
from jamlab.spheres.aqs.projection import project
from jamlab.spheres.box import Box
from jamlab.spheres.fire import minimize
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.potential import pressure
from jamlab.spheres.state import affine_shear


def distance(box: Box, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sqrt((box.minimum_image(a - b) ** 2).sum(1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sample")
    ap.add_argument("--steps", type=int, default=12)
    ap.add_argument("--skip", type=int, default=4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    a = ap.parse_args()
    with h5py.File(a.sample, "r") as f:
        gamma_end = float(f["trace/gamma"][-1])
    cur = prepared_packing(a.sample, gamma_end)
    nl = NeighborList(cur, skin=RELAX_SKIN)
    print("| step | FIRE its / CPU s | E, p | at 1e-8: its, distance to the end | projection "
          "cold / warm CPU s (linearisations, factorisations) | max distance to FIRE's | "
          "|x − x₀| projection, FIRE |")
    print("|---|---|---|---|---|---|---|")
    for step in range(a.steps):
        aff = affine_shear(cur, a.dgamma)
        t = time.process_time()
        fire = minimize(aff, neighbors=nl)
        t_fire = time.process_time() - t
        if step >= a.skip:
            loose = minimize(aff, ftol=1e-8, neighbors=NeighborList(aff, skin=RELAX_SKIN))
            d_loose = distance(aff.box, loose.packing.positions, fire.packing.positions).max()
            t = time.process_time()
            cold = project(aff, NeighborList(aff, skin=RELAX_SKIN))
            t_cold = time.process_time() - t
            t = time.process_time()
            warm = project(aff, NeighborList(aff, skin=RELAX_SKIN), parent=cur)
            t_warm = time.process_time() - t
            row = (f"| {step} | {fire.iterations} / {t_fire:.2f} | {fire.energy:.1e}, "
                   f"{pressure(fire.packing):.1e} | {loose.iterations}, {d_loose:.1e} | ")
            if warm and cold:
                x, xf = warm.packing.positions, fire.packing.positions
                row += (f"{t_cold:.3f} / {t_warm:.3f} ({warm.sqp}, {warm.solves}) | "
                        f"{distance(aff.box, x, xf).max():.1e} | "
                        f"{np.linalg.norm(distance(aff.box, x, aff.positions)):.4e}, "
                        f"{np.linalg.norm(distance(aff.box, xf, aff.positions)):.4e} |")
            else:
                row += f"not found: {warm.reason} | – | – |"
            print(row, flush=True)
        cur = fire.packing


if __name__ == "__main__":
    main()
