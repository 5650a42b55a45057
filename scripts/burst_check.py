"""Is the second avalanche of a burst a property of its starting minimum, or of the run's history?

At p = 1e-6 avalanches come in short bursts (docs/reproduce.md, "26 of 40 packings, and the
strain window"). A fixed-pressure step starts from the run's history as well as from the last
minimum: the Newton relaxer's stored factorisation, the volume slope of the last step, the
box-side guess (not after a candidate jump, rule ``elastic``). For each ``--pairs INDEX:ROW``
(the sample and the trace row of the second avalanche), this script

1. recomputes the sample's first ``ROW − 1`` steps here (its study shortened, in a temporary
   checkpoint folder, as ``scripts/machine_bits_probe.py`` does) and checks them bit for bit
   against the stored trace (energy, pressure, shear stress, ``max_force``, ``phi``);
2. takes the step ``ROW`` again from that minimum *afresh*: ``shear_at_pressure`` started at it,
   one step, no stored factor, no slope or box-side guess;
3. prints the stored ``S = −ΔH`` of row ``ROW``, the fresh one, and the enthalpies of the two end
   minima: the same minimum means the avalanche belongs to the start minimum and the strain
   increment, not to the history. (The fresh one-step run has no plastic flag to compare: the
   flag's threshold is measured on a whole run.)

Run it with the code that made the samples (bits): for ``data/runs/n500-p1e-6-vg``, a worktree of
46b3333 on ``PYTHONPATH`` and ``JAMLAB_CHOLMOD_BLAS=native`` on the machine that made them:

    PYTHONPATH=WT/src python scripts/burst_check.py data/runs/n500-p1e-6-vg --pairs 10:50 23:219
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

COLUMNS = ("energy", "pressure", "shear_stress", "max_force", "phi")


def check_pair(run: Path, index: int, row: int) -> dict:
    """The comparison of the module docstring for sample ``index``, second avalanche at ``row``."""
    from jamlab.runs import RunDir, read_sample, sample_seed
    from jamlab.runs.physics import prepare_and_shear
    from jamlab.spheres.io import read_packing
    from jamlab.spheres.pressure_shear import shear_at_pressure

    rd = RunDir(run)
    study = rd.study()
    if study.pressure is None:
        raise ValueError(f"{run} is not a fixed-pressure study")
    key = [k for k in study.keys() if k.index == index][0]
    stored = read_sample(rd.sample_path(key))["trace"]
    if not 2 <= row < len(stored["energy"]):
        raise ValueError(f"row must be in [2, {len(stored['energy']) - 1}], got {row}")
    short = replace(study, gamma_max=(row - 1) * study.dgamma)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "ck"
        result = prepare_and_shear(short, key, sample_seed(study.seed, key), folder)
        start = read_packing(folder / "trace.last.h5")
    same = all(np.asarray(result.traces[c]).tobytes() == np.asarray(stored[c][:row]).tobytes()
               for c in COLUMNS)
    fresh = shear_at_pressure(start, study.dgamma, n_steps=1, pressure=study.pressure)
    h = fresh.columns["enthalpy"]
    return {
        "index": index, "row": row, "replayed_bit_for_bit": same,
        "first_S": float(-stored["energy_jump"][row - 1]),
        "stored_S": float(-stored["energy_jump"][row]),
        "fresh_S": float(-fresh.columns["enthalpy_jump"][1]),
        "stored_H_end": float(stored["energy"][row]), "fresh_H_end": float(h[1]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--pairs", nargs="+", required=True, help="INDEX:ROW of a second avalanche")
    a = ap.parse_args()
    pairs = []
    for text in a.pairs:
        try:
            index, row = (int(x) for x in text.split(":"))
        except ValueError:
            ap.error(f"--pairs takes INDEX:ROW, got {text!r}")
        pairs.append((index, row))
    print("| sample | row | replayed bit for bit | S of row − 1 | S stored | S fresh | "
          "H at the end: stored − fresh |")
    print("|---|---|---|---|---|---|---|")
    for index, row in pairs:
        r = check_pair(a.run, index, row)
        print(f"| {index} | {row} | {r['replayed_bit_for_bit']} | {r['first_S']:.3e} | "
              f"{r['stored_S']:.3e} | {r['fresh_S']:.3e} | "
              f"{r['stored_H_end'] - r['fresh_H_end']:+.2e} |",
              flush=True)


if __name__ == "__main__":
    main()
