"""How exact is the shear stress of a recorded fixed-pressure minimum? (issue 18)

Near jamming a minimum found to ``max_i |F_i| < ftol`` is uncertain along its soft modes by
``~ ftol/λ``, and so is its stress: ``Σ`` of the exact minimum differs from the recorded one by
``δΣ = −Ξ · H⁻¹ F`` to first order (``H`` the backbone Hessian, ``F`` the residual forces on the
backbone, ``Ξ = ∂F/∂γ``: :func:`jamlab.spheres.potential.dforce_dstrain`). If that error were
comparable to the increments ``ΔΣ``, the lag-1 anticorrelation ``ρ < 0`` of the increments near
jamming (``scripts/pressure_moduli.py``) could be noise of the minimiser: consecutive errors
``e_k − e_{k−1}`` anticorrelate at lag 1.

For each seed: ``jam(N, 3, seed, p_target=1e-7)``, ``shear_at_pressure`` for ``--steps`` steps of
``--dgamma`` at ``--pressure`` (the defaults of the module), and at every recorded minimum: the
three lowest non-zero eigenvalues of the backbone Hessian (the ``d`` translations removed by
pinning one backbone particle), ``max_i |F_i|`` and ``δΣ`` (one sparse solve). Printed: their
range, and ``rms δΣ`` against ``std ΔΣ`` of the run's steps.

    PYTHONPATH=src python scripts/stress_precision.py --n 1000 --pressure 1e-5 --steps 20 \\
        --seeds 1 2
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.sparse.linalg as spla

from jamlab.spheres import potential
from jamlab.spheres.contacts import remove_rattlers
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


def precision(packing) -> tuple[float, float, float]:
    """``(λ_1, max_i |F_i|, δΣ)`` of a minimum: the lowest eigenvalue of the backbone Hessian
    with one backbone particle pinned, the largest residual force, and the first-order stress
    change to the exact minimum of the backbone's contact network."""
    keep = remove_rattlers(packing).mask
    d = packing.dim
    h = potential.hessian(packing, backbone=keep).tocsc()
    free = np.flatnonzero(np.repeat(keep, d))[d:]  # the first backbone particle pinned
    hp = h[free][:, free]
    forces = potential.forces(packing)
    xi = potential.dforce_dstrain(packing, backbone=keep)
    dx = spla.spsolve(hp, forces.reshape(-1)[free])  # the Newton step H dx = F
    d_sigma = -float(xi.reshape(-1)[free] @ dx)  # ∂Σ/∂x = −Ξ
    low = spla.eigsh(hp, k=1, sigma=0.0, which="LM", return_eigenvectors=False)
    return float(low[0]), float(np.abs(forces).max()), d_sigma


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--pressure", type=float, default=1e-5)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    a = ap.parse_args(argv)
    if a.n < 8 or a.steps < 2 or not (a.pressure > 0 and a.dgamma > 0):
        ap.error("need --n >= 8, --steps >= 2, --pressure > 0 and --dgamma > 0")
    print("| N | p | seed | minima | λ_1 (min … max) | max_i |F_i| (max) | rms δΣ | std ΔΣ | "
          "rms δΣ / std ΔΣ |")
    print("|---|---|---|---|---|---|---|---|---|")
    for seed in a.seeds:
        minima: list = []
        res = shear_at_pressure(jam(a.n, 3, seed, p_target=1e-7).packing, a.dgamma,
                                pressure=a.pressure, n_steps=a.steps,
                                observer=lambda _, q, kept=minima: kept.append(q))
        found = np.array([precision(q) for q in minima])
        stress = np.asarray(res.columns["shear_stress"])
        std = float(np.std(np.diff(stress)))
        rms = float(np.sqrt(np.mean(found[:, 2] ** 2)))
        print(f"| {a.n} | {a.pressure:g} | {seed} | {len(minima)} | {found[:, 0].min():.2e} … "
              f"{found[:, 0].max():.2e} | {found[:, 1].max():.1e} | {rms:.1e} | {std:.2e} | "
              f"{rms / std:.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
