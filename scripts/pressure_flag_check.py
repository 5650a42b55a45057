"""How good is the fixed-pressure plastic flag? Redo steps in substeps and look for the jump.

    PYTHONPATH=src nice -n 10 python scripts/pressure_flag_check.py --n 64 --pressure 1e-3 \
        --steps 300 --substeps 16

A fixed-pressure run (``shear_at_pressure``) keeps every minimum; each flagged step and as many
unflagged ones (control) are redone from the previous minimum in ``substeps`` steps of
``δγ/substeps``. On a continuous branch every substep's residual ``r = ΔH − ½ δγ' ΔΣ`` is
``O(δγ'³)`` + noise and a contact kink leaves at most ``δγ'²/16``; a real event leaves one substep
with ``|r| ≈ S`` whatever the substep. A flagged step is confirmed when one substep has
``|r| > max(10 σ, 0.1 δγ'²)`` (σ of the run) *and* the substepped end state has the same enthalpy
as the single step's (same minimum, so the comparison is about the same path).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from jamlab.analysis import noise_floor
from jamlab.spheres import affine_shear, jam
from jamlab.spheres.barostat import minimize_enthalpy
from jamlab.spheres.potential import evaluate
from jamlab.spheres.pressure_shear import shear_at_pressure


def substep(start, dgamma: float, k: int, p: float) -> tuple[np.ndarray, float]:
    cur = start
    ev = evaluate(cur)
    h, s = ev.energy + p * cur.box.volume, ev.shear_stress
    r = []
    for _ in range(k):
        res = minimize_enthalpy(affine_shear(cur, dgamma / k), p)
        cur = res.packing
        ev = evaluate(cur)
        h2, s2 = ev.energy + p * cur.box.volume, ev.shear_stress
        r.append(h2 - h - (dgamma / k) * s - 0.5 * (dgamma / k) * (s2 - s))
        h, s = h2, s2
    return np.array(r), h


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--pressure", type=float, default=1e-3)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--substeps", type=int, default=16)
    args = ap.parse_args()
    pk = jam(args.n, 3, seed=args.seed, p_target=1e-4).packing
    kept: dict[int, object] = {}
    run = shear_at_pressure(
        pk,
        args.dgamma,
        n_steps=args.steps,
        pressure=args.pressure,
        observer=lambda n, q: kept.__setitem__(n, q),
    )
    c = run.columns
    flagged = np.flatnonzero(c["plastic"])
    rng = np.random.default_rng(0)
    pool = np.flatnonzero(~c["plastic"][1:]) + 1
    control = rng.choice(pool, size=min(len(flagged), len(pool)), replace=False)
    resid = (
        c["enthalpy_jump"]
        - 0.5 * np.concatenate([[np.nan], np.diff(c["gamma"])]) * c["stress_jump"]
    )
    nf = noise_floor(
        c["enthalpy_jump"][1:], c["stress_jump"][1:], np.diff(c["gamma"]), jammed=c["jammed"]
    )
    noise = nf.threshold(10.0)  # |median| + 10σ of the run's residuals
    out = {"flagged": [], "control": []}
    for kind, rows in (("flagged", flagged), ("control", control)):
        for n in rows:
            r, h_end = substep(kept[n - 1], args.dgamma, args.substeps, args.pressure)
            dgs = args.dgamma / args.substeps
            thr = max(noise, 0.1 * dgs**2)
            same = abs(h_end - c["enthalpy"][n]) <= 1e-12 * max(1.0, abs(h_end))
            jump = bool(np.max(np.abs(r)) > thr)
            out[kind].append(
                {
                    "row": int(n),
                    "r_step": float(resid[n]),
                    "dH": float(c["enthalpy_jump"][n]),
                    "max_abs_r_sub": float(np.max(np.abs(r))),
                    "threshold_sub": float(thr),
                    "jump_in_substeps": jump,
                    "same_end": bool(same),
                }
            )
    for kind in ("flagged", "control"):
        rows = out[kind]
        conf = sum(1 for x in rows if x["jump_in_substeps"])
        same = sum(1 for x in rows if x["same_end"])
        print(f"{kind}: {len(rows)} steps, a substep jumps in {conf}, same end minimum in {same}")
    print(json.dumps({"run_threshold": run.threshold, "noise": noise, **out})[:6000])


if __name__ == "__main__":
    main()
