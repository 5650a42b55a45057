"""Cross-check of :func:`jamlab.analysis.order.bond_order` against freud (a peer program).

freud (``pip install freud-analysis``; not a jamlab dependency) computes Steinhardt's per-particle
``q_6`` in a triclinic box; a Lees–Edwards cube of side ``L`` at strain ``γ`` is freud's box
``(L, L, L)`` with tilt ``xy = γ`` (the ``y`` image vector ``(γL, L, 0)``). The script shears
``prepare(N, 3, φ, seed)`` (positions from jamlab; run it in an environment that has both) to
each ``--gamma`` by AQS steps of ``--dgamma`` and prints, per snapshot, the largest difference of
``q_6(i)`` between the two, the bonds per particle of both, and ``Q_6`` from jamlab.

    PYTHONPATH=src python scripts/order_vs_freud.py --n 256 --phi 0.8 --seed 1 --gamma 0 0.3 0.7
"""

from __future__ import annotations

import argparse

import numpy as np


def freud_q6(positions: np.ndarray, length: float, strain: float, r_max: float) -> tuple:
    """Per-particle ``q_6`` and bonds per particle from freud, neighbours within ``r_max``."""
    import freud

    box = freud.box.Box(length, length, length, xy=strain)
    pts = box.wrap(np.asarray(positions, dtype=np.float64) - 0.5 * length)
    nlist = freud.locality.AABBQuery(box, pts).query(
        pts, {"r_max": r_max, "exclude_ii": True}).toNeighborList()
    st = freud.order.Steinhardt(6)
    st.compute((box, pts), neighbors=nlist)
    return np.asarray(st.particle_order), np.bincount(nlist.query_point_indices,
                                                      minlength=len(pts))


def main(argv: list[str] | None = None) -> None:
    from jamlab.analysis.order import bond_order
    from jamlab.spheres import aqs, prepare

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--phi", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dgamma", type=float, default=1e-3)
    ap.add_argument("--gamma", type=float, nargs="+", default=[0.0, 0.3, 0.7])
    a = ap.parse_args(argv)
    if any(g < 0 for g in a.gamma) or sorted(a.gamma) != a.gamma:
        ap.error("--gamma: increasing values >= 0")
    packing = prepare(a.n, 3, a.phi, a.seed).packing
    gamma = 0.0
    print("| γ | max |Δq_6(i)| | bonds per particle jamlab / freud | Q_6 (jamlab) | crystalline |")
    print("|---|---|---|---|---|")
    for target in a.gamma:
        steps = round((target - gamma) / a.dgamma)
        if steps > 0:
            packing = aqs.shear(packing, a.dgamma, n_steps=steps, classify=False).packing
            gamma += steps * a.dgamma
        box = packing.box
        ours = bond_order(packing.positions, box.length, box.strain)
        q6, count = freud_q6(packing.positions, box.length, box.strain, 1.0)
        diff = float(np.nanmax(np.abs(ours.local_q - q6)))
        print(f"| {gamma:.3f} | {diff:.2e} | {ours.neighbours.mean():.4f} / {count.mean():.4f} | "
              f"{ours.global_q:.4f} | {ours.crystalline_fraction:.3f} |")


if __name__ == "__main__":
    main()
