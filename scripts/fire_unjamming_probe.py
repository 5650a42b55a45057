"""FIRE on the step that unjams a packing at constant volume: why it takes ~3e5 iterations.

The issue's example (issue 18): ``jam(N, 3, seed, p_target=1e-7)`` sheared affinely by ``δγ``
at constant volume, then FIRE to ``max|F| < 1e-12``. The compiled FIRE loop is run from a copy
made at run time from its source (``jamlab/spheres/kernels/fire.py``, by
``scripts/kernel_copy.py``) with counters added: the restarts (``P ≤ 0``), the iterations with
``Δt < Δt_max / 2`` (a time step that has collapsed), and ``max|F|`` at iterations ``2^k``.
Each ``--params`` is a set of :class:`FireParameters` fields (``"alpha0=0.1,f_alpha=0.999"``)
run on the same start after the defaults. The copy fails loudly if the kernel's text changed
where the counters go.

    PYTHONPATH=src python scripts/fire_unjamming_probe.py --n 1000 --seed 21 \\
        --params f_alpha=0.999 alpha0=0.1 alpha0=0.1,f_alpha=0.999
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from kernel_copy import edited_fire  # noqa: E402

# isort: split
import numpy as np  # noqa: E402

from jamlab.spheres.fire import FireParameters, kernel_arguments, kernel_start  # noqa: E402
from jamlab.spheres.neighbors import RELAX_SKIN  # noqa: E402
from jamlab.spheres.packing import jam  # noqa: E402
from jamlab.spheres.potential import affine_shear  # noqa: E402

EDITS = [
    ("    while fmax2 >= ftol2 and it < max_iter:\n        it += 1\n",
     "    n_restart = 0\n    n_small = 0\n    trace = np.full(64, np.nan)\n"
     "    while fmax2 >= ftol2 and it < max_iter:\n        it += 1\n"
     "        if dt < 0.5 * dt_max:\n            n_small += 1\n"
     "        if (it & (it - 1)) == 0:\n"
     "            trace[int(np.log2(it) + 0.5)] = np.sqrt(fmax2)\n"),
    ("            n_pos = 0\n            n_neg += 1\n",
     "            n_pos = 0\n            n_restart += 1\n            n_neg += 1\n"),
    ("    return it, fmax, fmax < ftol, e, n_rebuild, start, nbr, shift, img_y, ref\n",
     "    return it, fmax, fmax < ftol, e, n_restart, n_small, trace\n"),
]


def instrumented_fire():
    """The compiled FIRE loop with the counters (module docstring)."""
    return edited_fire("fire_counted", EDITS)


def run(fire, packing, params: FireParameters, ftol: float, max_iter: int):
    pos, nl = kernel_start(packing, skin=RELAX_SKIN)
    return fire(*kernel_arguments(pos, packing.box, nl, ftol, max_iter, params))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--p-target", type=float, default=1e-7)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--max-iter", type=int, default=2_000_000)
    ap.add_argument("--params", nargs="*", default=[])
    a = ap.parse_args()
    fire = instrumented_fire()
    start = affine_shear(jam(a.n, 3, seed=a.seed, p_target=a.p_target).packing, a.dgamma)
    sets = [("defaults", FireParameters())]
    for text in a.params:
        fields = {k: float(v) if "." in v or "e" in v else int(v)
                  for k, v in (item.split("=") for item in text.split(","))}
        sets.append((text, FireParameters(**fields)))
    print(f"jam({a.n}, 3, seed={a.seed}, p_target={a.p_target:g}), sheared by {a.dgamma:g}, "
          f"FIRE to 1e-12:")
    print("| FIRE parameters | iterations | converged | E at the end | restarts | "
          "iterations at Δt < Δt_max/2 | CPU s |")
    print("|---|---|---|---|---|---|---|")
    traces = []
    for label, params in sets:
        t = time.process_time()
        it, _fmax, conv, e, n_restart, n_small, trace = run(fire, start, params, 1e-12,
                                                            a.max_iter)
        print(f"| {label} | {it:,} | {bool(conv)} | {e:.3g} | {n_restart} | {n_small} | "
              f"{time.process_time() - t:.1f} |", flush=True)
        traces.append((label, trace[~np.isnan(trace)]))
    for label, trace in traces:
        print(f"max|F| at iterations 2^0, 2^1, … ({label}):",
              " ".join(f"{x:.1e}" for x in trace))


if __name__ == "__main__":
    main()
