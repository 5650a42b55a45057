"""Fixed-pressure AQS with the Newton inner minimiser against plain FIRE on many samples.

The same packings (``jam(N, 3, seed)``, brought to ``p`` by one FIRE fixed-pressure step) are
sheared with both minimisers. Paired comparison per sample (plastic flags equal, the sizes
``S = −ΔH`` of the flagged steps equal) and the pooled statistics (plastic fraction, ``⟨S⟩``,
two-sample KS on the sizes), with the CPU time of each. Prints a markdown table.

    python scripts/newton_vs_fire_pressure.py --n 250 --pressure 1e-3 --seeds 1-40 \
        --steps 50 --dgamma 1e-4
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.stats import ks_2samp

from jamlab.analysis.powerlaw import fit_power_law
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


def seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--pressure", type=float, default=1e-3)
    ap.add_argument("--seeds", type=seeds, default=seeds("1-40"))
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--dgamma", type=float, default=1e-4)
    ap.add_argument("--save", default=None, help="write the pooled sizes (npz)")
    a = ap.parse_args()
    sizes = {"newton": [], "fire": []}
    flags = {"newton": 0, "fire": 0}
    steps = {"newton": 0, "fire": 0}
    cpu = {"newton": 0.0, "fire": 0.0}
    same_flags = same_sizes = used = 0
    worst = 0.0
    for seed in a.seeds:
        r = jam(a.n, 3, seed=seed, p_target=min(a.pressure, 1e-4))
        first = shear_at_pressure(r.packing, 1e-6, pressure=a.pressure, n_steps=1,
                                  minimizer="fire")
        if not (first["converged"].all() and first["jammed"].all()):
            print(f"seed {seed}: no jammed minimum at p={a.pressure:g}, skipped")
            continue
        used += 1
        runs = {}
        for m in ("newton", "fire"):
            t = time.process_time()
            runs[m] = res = shear_at_pressure(first.packing, a.dgamma, pressure=a.pressure,
                                              n_steps=a.steps, minimizer=m)
            cpu[m] += time.process_time() - t
            tr = res.trace()
            ok = tr.jammed[1:] & tr.jammed[:-1]
            plastic = res["plastic"][1:]
            sizes[m].extend((-res["enthalpy_jump"][1:][plastic]).tolist())
            flags[m] += int(plastic.sum())
            steps[m] += int(ok.sum())
        pn, pf = runs["newton"]["plastic"], runs["fire"]["plastic"]
        if np.array_equal(pn, pf):
            same_flags += 1
            sn = -runs["newton"]["enthalpy_jump"][pn]
            sf = -runs["fire"]["enthalpy_jump"][pf]
            if sn.size:
                d = float(np.max(np.abs(sn - sf) / np.abs(sf)))
                worst = max(worst, d)
            same_sizes += int(sn.size == 0 or d < 1e-6)
        print(f"seed {seed}: plastic newton {int(pn.sum())} fire {int(pf.sum())}", flush=True)
    ks = ks_2samp(sizes["newton"], sizes["fire"]) if sizes["fire"] and sizes["newton"] else None
    print(f"\nN={a.n}, p={a.pressure:g}, δγ={a.dgamma:g}, {a.steps} steps, {used} samples\n")
    print("| | Newton | FIRE |\n|---|---|---|")
    print(f"| plastic steps / jammed steps | {flags['newton']} / {steps['newton']} | "
          f"{flags['fire']} / {steps['fire']} |")
    for m in ("newton", "fire"):
        s = np.asarray(sizes[m])
        sizes[m] = s
    mean = {m: (np.mean(sizes[m]), np.std(sizes[m]) / np.sqrt(max(1, sizes[m].size)))
            for m in sizes}
    print(f"| ⟨S⟩ | {mean['newton'][0]:.4e} ± {mean['newton'][1]:.1e} | "
          f"{mean['fire'][0]:.4e} ± {mean['fire'][1]:.1e} |")
    print(f"| CPU s per sample | {cpu['newton'] / used:.2f} | {cpu['fire'] / used:.2f} |")
    print(f"\nsamples with identical plastic flags: {same_flags} / {used}; with identical sizes "
          f"(relative 1e-6): {same_sizes} / {used} (largest relative size difference {worst:.1e})")
    if ks is not None:
        print(f"two-sample KS on the sizes: D = {ks.statistic:.3f}, p-value = {ks.pvalue:.3f}")
        # τ: x_min chosen on the FIRE sizes (KS rule), the same x_min for both
        ref = fit_power_law(sizes["fire"], min_tail=50)
        fits = {m: fit_power_law(sizes[m], x_min=ref.x_min) for m in sizes}
        for m, f in fits.items():
            print(f"tau ({m}) = {f.tau:.3f} ± {f.tau_stderr:.3f} from {f.n_tail} sizes above "
                  f"S_min = {f.x_min:.3g}")
        d = abs(fits["newton"].tau - fits["fire"].tau)
        sig = float(np.hypot(fits["newton"].tau_stderr, fits["fire"].tau_stderr))
        print(f"difference {d:.3f} = {d / sig:.2f} sigma (independent-error sigma; the samples "
              "are the same packings, so this overstates the noise of a difference)")
    if a.save is not None:
        np.savez(a.save, **{f"sizes_{m}": np.asarray(v) for m, v in sizes.items()})


if __name__ == "__main__":
    main()
