"""Fixed-pressure avalanches: how much of ``S = −ΔH = −ΔE − p ΔV`` is the compaction term.

For each seed: ``jam(N, 3, seed, p_target=p)``, ``shear_at_pressure`` for ``--steps`` steps of
``--dgamma`` (module defaults), then for every counted avalanche (plastic, between jammed
minima, ``S > 0``) with ``S ≥ --floor``: its step, ``S``, and the share ``−p ΔV / S`` (``V`` from
``box_length``³), with φ and the shear stress ``Σ`` (extensive, ``∂H/∂γ``) at the start, middle and
end of the run.

    PYTHONPATH=src python scripts/enthalpy_parts.py --n 250 --seeds 70 87 145 1 2 3

``--runs DIR … --run-n N …``: the same for the finished samples of fixed-pressure run
directories (φ label ``jamming``), with no new simulation: ``V`` of each row from the trace's φ
and the prepared packing's box and φ (``box_length``, ``phi_actual``: the particles' volume),
``V_n = L_prep^d φ_prep / φ_n``; per run the share's quantiles over the
avalanches ≥ ``--floor``, where along the strain window they fall (first tenth of the steps or
later), how many each sample carries, and the largest ones.

    PYTHONPATH=src python scripts/enthalpy_parts.py --floor 1e-8 --runs RUNS/n250-p1e-6-fix40 \
        RUNS/n500-p1e-6-fix RUNS/n1000-p1e-6 --run-n 250 500 1000
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from jamlab.analysis.avalanches import classify_steps
from jamlab.reproduce.ensembles import finished, jammed_flags, row_volumes
from jamlab.runs import open_run
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
    ap.add_argument("--runs", type=Path, nargs="+", default=[])
    ap.add_argument("--run-n", type=int, nargs="+", default=[])
    a = ap.parse_args()
    if a.runs:
        if len(a.run_n) != len(a.runs):
            ap.error(f"--run-n takes one N per run ({len(a.runs)}), got {len(a.run_n)}")
        for run, n in zip(a.runs, a.run_n, strict=True):
            run_parts(run, n, a.floor)
        return
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


def run_parts(run: Path, n: int, floor: float) -> None:
    """The ``--runs`` report of one run directory (module docstring)."""
    ds = open_run(run)
    study = json.loads(ds.attrs["study"])
    if study.get("pressure") is None:
        print(f"error: {run} is not a fixed-pressure run", file=sys.stderr)
        raise SystemExit(2)
    p = float(study["pressure"])
    done = finished(ds, "jamming", n)
    sel = {"phi": "jamming", "N": n}
    ej = np.asarray(ds.energy_jump.sel(**sel).values)[done]
    pl = np.asarray(ds.plastic.sel(**sel).values)[done] > 0.5
    jammed = jammed_flags(ds, "jamming", n)
    counted = classify_steps(ej[:, 1:], pl[:, 1:], jammed=jammed)
    v = row_volumes(ds, "jamming", n)
    size = -ej[:, 1:]
    share = -p * np.diff(v, axis=1) / size
    sample, step = np.nonzero(counted & (size >= floor))
    n_steps = size.shape[1]
    print(f"\n{run} (N = {n}, p = {p:g}): {int(done.sum())} samples, {int(counted.sum())} "
          f"avalanches, {sample.size} with S ≥ {floor:g}")
    if not sample.size:
        return
    x = share[sample, step]
    q = np.quantile(x, [0.1, 0.5, 0.9])
    first = int(np.count_nonzero(step < n_steps // 10))
    print(f"  −pΔV/S median {q[1]:.3f} (10–90 %: {q[0]:.3f} – {q[2]:.3f}); in the first tenth "
          f"of the steps: {first} (a tenth would be {sample.size / 10:.1f}); per sample: "
          f"{sorted(np.bincount(sample, minlength=size.shape[0]).tolist(), reverse=True)}")
    order = np.argsort(-size[sample, step])[:5]
    for k in order:
        i, j = sample[k], step[k]
        print(f"  S = {size[i, j]:.2e} ε, sample {int(np.nonzero(done)[0][i])}, step {j + 1}, "
              f"−pΔV/S = {share[i, j]:.3f}")


if __name__ == "__main__":
    main()
