"""Does a sheared packing stay amorphous? Bond order along AQS shear, per strain.

Shears ``prepare(N, 3, φ, seed, sizes=...)`` (an as-quenched UNSAT packing; seeds
``--first-seed …``) by AQS steps of ``--dgamma`` (classification off: only the minima matter)
to ``--gamma-max`` and, every ``--every`` of strain, measures the configuration's bond order
(:func:`jamlab.analysis.order.bond_order`; bonds: the contacts, or the pairs closer than
``--cutoff · σ_ij``: ten Wolde's crystalline fraction and Steinhardt's ``Q_6``), its energy
per particle and its shear stress ``σ_xy = Σ/V``.
Per ``(sizes, N)`` and strain it prints the mean crystalline fraction, how many samples are
ordered (crystalline fraction above ``--ordered``), the mean ``Q_6``, ``E/N`` and ``σ_xy``.

    PYTHONPATH=src python scripts/shear_order.py --phi 0.8 --n 128 256 --sizes mono bidisperse \\
        --samples 20 --dgamma 1e-3 --gamma-max 1.0 --every 0.1 --workers 2

``--gamma-max 0`` measures the quenches alone. ``--out F.npz`` keeps every measurement
(``--load F.npz`` reprints it).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

from jamlab.reproduce.amorphous import ORDERED_FRACTION  # noqa: E402

COLUMNS = ("gamma", "crystalline", "q6", "energy_per_particle", "stress")


def one_sample(job: tuple) -> np.ndarray:
    """Rows ``COLUMNS`` at γ = 0, every, 2·every, … of one packing's shear."""
    from jamlab.analysis.order import bond_order
    from jamlab.spheres import aqs, prepare
    from jamlab.spheres.potential import energy, shear_stress

    n, phi, seed, sizes, dgamma, gamma_max, every, cutoff = job
    packing = prepare(n, 3, phi, seed, sizes=sizes).packing
    per_block = max(1, round(every / dgamma))
    rows, done = [], 0
    while True:
        box = packing.box
        o = bond_order(packing.positions, box.length, box.strain, packing.diameters, cutoff)
        rows.append((done * dgamma, o.crystalline_fraction, o.global_q,
                     energy(packing) / n, shear_stress(packing) / box.length ** 3))
        if (done + per_block) * dgamma > gamma_max * (1 + 1e-9):
            return np.array(rows)
        packing = aqs.shear(packing, dgamma, n_steps=per_block, classify=False).packing
        done += per_block


def table(meta: np.ndarray, data: np.ndarray, ordered: float) -> None:
    """Per ``(sizes, N)`` and strain: the means and the ordered samples."""
    print("| sizes | N (samples) | γ | crystalline fraction (mean) | ordered samples | Q_6 "
          "| E/N (ε) | σ_xy (ε/σ³) |")
    print("|---|---|---|---|---|---|---|---|")
    for key in sorted({(s, int(n)) for s, n in meta}):
        pick = [k for k, (s, n) in enumerate(meta) if (s, int(n)) == key]
        block = data[pick]  # (samples, strains, columns)
        for r in range(block.shape[1]):
            cols = block[:, r, :]
            print(f"| {key[0]} | {key[1]} ({len(pick)}) | {cols[0, 0]:.3g} | "
                  f"{cols[:, 1].mean():.3f} | {int(np.sum(cols[:, 1] > ordered))} | "
                  f"{cols[:, 2].mean():.3f} | {cols[:, 3].mean():.4g} | {cols[:, 4].mean():.3g} |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--phi", type=float, default=0.8)
    ap.add_argument("--n", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--sizes", nargs="+", default=["mono", "bidisperse"],
                    choices=["mono", "bidisperse"])
    ap.add_argument("--samples", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--dgamma", type=float, default=1e-3)
    ap.add_argument("--gamma-max", type=float, default=1.0)
    ap.add_argument("--every", type=float, default=0.1)
    ap.add_argument("--ordered", type=float, default=ORDERED_FRACTION,
                    help="a sample with a larger crystalline fraction counts as ordered")
    ap.add_argument("--cutoff", type=float, default=1.0,
                    help="bonds: pairs closer than cutoff · σ_ij (1: the contacts; 1.3: the "
                         "first shell, as the report's order check)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--load", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.load is not None:
        if not a.load.is_file():
            ap.error(f"--load {a.load}: no such file")
        z = np.load(a.load)
        table(z["meta"], z["data"], a.ordered)
        return
    if not (0.5 < a.phi < 1.0) or a.samples < 1 or a.workers < 1 or min(a.n) < 32:
        ap.error("need 0.5 < --phi < 1, --samples and --workers >= 1, --n >= 32")
    if not (0 < a.dgamma <= a.every and a.gamma_max >= 0):
        ap.error("need 0 < --dgamma <= --every and --gamma-max >= 0 (0: the quench alone)")
    if a.out is not None and a.out.exists():
        ap.error(f"--out {a.out} exists (finished data is never overwritten)")
    if not a.cutoff >= 1:
        ap.error("--cutoff must be >= 1 (the contacts at least)")
    jobs = [(n, a.phi, s, sizes, a.dgamma, a.gamma_max, a.every, a.cutoff)
            for sizes in a.sizes for n in a.n
            for s in range(a.first_seed, a.first_seed + a.samples)]
    t0 = time.time()
    if a.workers == 1:
        results = [one_sample(j) for j in jobs]
    else:
        with ProcessPoolExecutor(a.workers) as ex:
            results = list(ex.map(one_sample, jobs))
    meta = np.array([(j[3], j[0]) for j in jobs], dtype=object)
    data = np.stack(results)
    print(f"{len(jobs)} packings, φ = {a.phi}, δγ = {a.dgamma} to {a.gamma_max}: "
          f"{time.time() - t0:.0f} s wall\n", file=sys.stderr)
    if a.out is not None:
        np.savez(a.out, meta=meta.astype(str), data=data)
    table(meta, data, a.ordered)


if __name__ == "__main__":
    main()
