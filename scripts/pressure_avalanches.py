"""Avalanche statistics at fixed pressure: τ, ⟨S⟩ and the plastic fraction against p.

    PYTHONPATH=src nice -n 10 python scripts/pressure_avalanches.py --n 250 --seeds 1 2 3 4 \
        --steps 400 --pressures 1e-2 1e-3 1e-4 --out-dir /tmp/pav

Per seed: ``jam(N, 3, seed, p_target=1e-4)``, then ``shear_at_pressure`` at each p (δγ = 1e-5,
``--steps`` steps; the start is brought to p first). Sizes ``S = −ΔH`` of the flagged steps
between jammed minima (``avalanche_sizes(..., plastic, jammed=...)``), pooled over seeds; τ by
``fit_power_law`` (x_min free, bootstrap). Columns of every run are saved as ``.npz``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from jamlab.analysis import avalanche_sizes, exclusions, fit_power_law
from jamlab.spheres import jam
from jamlab.spheres.pressure_shear import shear_at_pressure


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--pressures", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4])
    ap.add_argument("--n-boot", type=int, default=100)
    ap.add_argument("--out-dir", default="pressure_avalanches")
    args = ap.parse_args()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    per_p: dict[float, dict] = {
        p: {"S": [], "steps": 0, "plastic": 0, "cpu": 0.0} for p in args.pressures
    }
    for seed in args.seeds:
        pk = jam(args.n, 3, seed=seed, p_target=1e-4).packing
        for p in args.pressures:
            r = shear_at_pressure(pk, args.dgamma, n_steps=args.steps, pressure=p)
            c = r.columns
            np.savez(out / f"n{args.n}_seed{seed}_p{p:g}.npz", **c)
            ej = c["enthalpy_jump"][1:]
            plastic = c["plastic"][1:]
            s = avalanche_sizes(ej, plastic, jammed=c["jammed"])
            ex = exclusions(ej, c["jammed"], plastic)
            acc = per_p[p]
            acc["S"].append(s)
            acc["steps"] += int(np.count_nonzero(c["jammed"][:-1] & c["jammed"][1:]))
            acc["plastic"] += int(s.size)
            acc["cpu"] += r.time
            row = {
                "seed": seed,
                "p": p,
                "n_avalanches": int(s.size),
                "excluded": ex.n_avalanches_excluded,
                "unjammed_steps": ex.n_steps_excluded,
                "not_converged": r.n_not_converged,
                "seconds": r.time,
                "threshold": r.threshold,
            }
            print(json.dumps(row), flush=True)
    summary = []
    for p, acc in per_p.items():
        s = np.concatenate(acc["S"]) if acc["S"] else np.array([])
        row = {
            "p": p,
            "N": args.n,
            "samples": len(args.seeds),
            "steps_jammed": acc["steps"],
            "n_avalanches": int(s.size),
            "plastic_fraction": acc["plastic"] / max(acc["steps"], 1),
            "mean_S": float(s.mean()) if s.size else float("nan"),
            "median_S": float(np.median(s)) if s.size else float("nan"),
            "cpu_seconds": acc["cpu"],
        }
        if s.size >= 60:
            fit = fit_power_law(s, min_tail=min(50, s.size // 2), n_boot=args.n_boot, seed=1)
            row.update(
                tau=fit.tau,
                tau_stderr=fit.tau_stderr,
                tau_ci=[fit.ci_low, fit.ci_high],
                x_min=fit.x_min,
                n_tail=fit.n_tail,
                fit=fit.method,
            )
        print(json.dumps(row, default=str), flush=True)
        summary.append(row)
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=str))


if __name__ == "__main__":
    main()
