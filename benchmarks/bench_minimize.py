"""Plain FIRE against the hybrid FIRE + Newton minimiser on AQS plastic steps near jamming.

Settings: N = 128 at p ≈ 1e-5 and N = 500 at p ≈ 1e-7 (``jamlab.spheres.packing.jam``, seed 1),
sheared in AQS steps ``δγ = 1e-5`` by :func:`jamlab.spheres.aqs.shear` (default fast path: a
step is plastic when the branch of the previous minimum ends inside it, and FIRE then minimises
from the affinely sheared previous minimum), saving every configuration. On the first ``--steps``
plastic steps of each setting, the previous minimum affinely sheared to the step's strain is
minimised to ``max_i |F_i| < 1e-12`` by plain FIRE (:func:`jamlab.spheres.fire.minimize`) and by
:func:`jamlab.spheres.newton.minimize_hybrid`, back to back; printed per step and summed:
wall-clock ms, iterations (FIRE; hybrid as FIRE + Newton, factorisations), and whether both
reached the same minimum (energy difference, largest backbone displacement after removing the
mean). ``--all-steps`` times the first ``--steps`` steps instead, elastic ones included (the
fast path does not use FIRE there; plain-FIRE AQS does). ``--split`` also prints how many FIRE
iterations reach ``max|F|`` < 1e-6, 1e-8, 1e-10, 1e-12 from the same start (where FIRE spends
its time).

Prints ratios; asserts nothing about time. Run:
``.venv/bin/python benchmarks/bench_minimize.py [--steps 10] [--switch 1e-8] [--split]``
(``--only 128`` or ``--only 500`` for one setting).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from jamlab.spheres import aqs
from jamlab.spheres.aqs import checkpoint_paths
from jamlab.spheres.aqs.network import affine_to, find_backbone
from jamlab.spheres.fire import minimize
from jamlab.spheres.io import read_packing
from jamlab.spheres.newton import HybridParameters, minimize_hybrid
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import NeighborList, evaluate

# N -> (goal pressure of the jammed start, AQS steps searched for plastic ones by default);
# at N = 128 the first ~15 steps are elastic, at N = 500 every step is plastic
SETTINGS = {128: (1e-5, 60), 500: (1e-7, 12)}
FTOL = 1e-12
MAX_ITER = 5_000_000


def run_setting(n: int, p_target: float, max_steps: int, args) -> dict:
    t0 = time.perf_counter()
    res = jam(n, 3, seed=1, p_target=p_target)
    if not res.ok:
        raise RuntimeError(f"jam({n}) did not reach a jammed packing")
    start = res.packing
    nl = NeighborList(start)
    cur = minimize(start, FTOL, MAX_ITER, neighbors=nl).packing
    ev = evaluate(cur, nl)
    print(
        f"\n# N={n}, phi={cur.phi:.6f}, p={ev.pressure:.2e} (jammed in "
        f"{time.perf_counter() - t0:.1f} s), dγ={args.dgamma:g}, ftol={FTOL:g}, "
        f"switch={args.switch:g}"
    )
    params = HybridParameters(verify=not args.no_verify)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "trace.h5"
        t0 = time.perf_counter()
        sh = aqs.shear(
            cur,
            args.dgamma,
            n_steps=max_steps,
            out=out,
            save_every=1,
        )
        plastic = np.flatnonzero(sh.trace.plastic)
        print(
            f"AQS (fast path, FIRE on plastic steps): {max_steps} steps in "
            f"{time.perf_counter() - t0:.1f} s, {plastic.size} plastic: {plastic.tolist()}"
        )
        configs = checkpoint_paths(out)[1]
        starts = []
        chosen = range(1, min(args.steps, max_steps) + 1) if args.all_steps else plastic
        for step in list(chosen)[: args.steps]:
            prev = cur if step == 1 else read_packing(configs / f"step_{step - 1:08d}.h5")
            starts.append((step, affine_to(prev, float(sh.trace.gamma[step]))))
    # warm both (compiled kernels, SuperLU) outside the timings
    minimize_hybrid(affine_to(cur, cur.strain + args.dgamma), FTOL, switch=args.switch)
    header = (
        "step   FIRE its      ms |  hybrid FIRE+Newton (fact)      ms  ok cl |  ratio |"
        "  rel dE     |dE|   |dr|_bb"
    )
    if args.split:
        header += " | FIRE its to 1e-6 1e-8 1e-10"
    print(header)
    rows = []
    for step, affine in starts:
        t_f, t_h = [], []
        for _ in range(args.repeat):  # interleaved: the machine's load hits both alike
            fire = minimize(affine, FTOL, MAX_ITER, neighbors=nl)
            t_f.append(fire.time)
            t = time.perf_counter()
            hyb = minimize_hybrid(
                affine, FTOL, switch=args.switch, max_iter=MAX_ITER, neighbors=nl, params=params
            )
            t_h.append(time.perf_counter() - t)
        if not fire.converged:
            raise RuntimeError(f"FIRE did not converge at step {step}")
        bb = find_backbone(fire.packing, nl)
        dr = fire.packing.box.minimum_image(hyb.packing.positions - fire.packing.positions)
        dr_bb = float(np.max(np.abs(dr[bb] - dr[bb].mean(axis=0)))) if bb.any() else 0.0
        d_e = hyb.energy - fire.energy
        row = {
            "fire_ms": 1e3 * min(t_f),
            "hyb_ms": 1e3 * min(t_h),
            "fire_its": fire.iterations,
            "hyb_fire_its": hyb.fire_iterations,
            "newton": hyb.newton_iterations,
            "fact": hyb.n_factorisations,
            "ok": hyb.newton_ok,
            "converged": hyb.converged,
            "rel_de": d_e / abs(fire.energy),
            "de": d_e,
            "dr_bb": dr_bb,
        }
        rows.append(row)
        line = (
            f"{step:4d} {row['fire_its']:9d} {row['fire_ms']:8.1f} | "
            f"{row['hyb_fire_its']:9d}+{row['newton']:<3d}({row['fact']:2d}) "
            f"{row['hyb_ms']:10.1f}  {'y' if row['ok'] else 'n':>2} {hyb.n_cleanup:2d} | "
            f"{row['fire_ms'] / row['hyb_ms']:5.2f}x | {row['rel_de']:8.1e} {abs(d_e):8.1e} "
            f"{dr_bb:8.1e}{'' if hyb.converged else '  NOT CONVERGED'}"
        )
        if args.split:
            tols = (1e-6, 1e-8, 1e-10)
            its = [minimize(affine, tol, MAX_ITER, neighbors=nl).iterations for tol in tols]
            row["split"] = its + [fire.iterations]
            line += f" | {its[0]:6d} {its[1]:6d} {its[2]:6d}"
        print(line, flush=True)
    if not rows:
        print("no plastic step found")
        return {}
    fire_ms = np.array([r["fire_ms"] for r in rows])
    hyb_ms = np.array([r["hyb_ms"] for r in rows])
    same = [abs(r["rel_de"]) < 1e-8 and r["dr_bb"] < 1e-5 for r in rows]
    print(
        f"N={n}: {len(rows)} {'' if args.all_steps else 'plastic '}steps: "
        f"plain FIRE {fire_ms.mean():.1f} ms/step "
        f"({np.mean([r['fire_its'] for r in rows]):.0f} its), hybrid {hyb_ms.mean():.1f} ms/step "
        f"({np.mean([r['hyb_fire_its'] for r in rows]):.0f} FIRE its + "
        f"{np.mean([r['newton'] for r in rows]):.1f} Newton, "
        f"{np.mean([r['fact'] for r in rows]):.1f} factorisations, Newton finished "
        f"{sum(r['ok'] for r in rows)}/{len(rows)})"
    )
    print(
        f"N={n}: ratio FIRE / hybrid = {fire_ms.sum() / hyb_ms.sum():.2f}x (total time), "
        f"median per step {np.median(fire_ms / hyb_ms):.2f}x; all converged: "
        f"{all(r['converged'] for r in rows)}; same minimum (|rel dE| < 1e-8, |dr|_bb < 1e-5): "
        f"{sum(same)}/{len(rows)}; max |rel dE| {max(abs(r['rel_de']) for r in rows):.1e}, "
        f"max |dE| {max(abs(r['de']) for r in rows):.1e}, "
        f"max |dr|_bb {max(r['dr_bb'] for r in rows):.1e}"
    )
    if args.split:
        s = np.array([r["split"] for r in rows], dtype=float)
        mean = s.mean(axis=0)
        print(
            f"N={n}: FIRE iterations to max|F| < 1e-6 / 1e-8 / 1e-10 / 1e-12 (mean): "
            f"{mean[0]:.0f} / {mean[1]:.0f} / {mean[2]:.0f} / {mean[3]:.0f}; "
            f"tail 1e-8 → 1e-12: {(s[:, 3] - s[:, 1]).sum() / s[:, 3].sum():.0%} of the "
            f"iterations, 1e-10 → 1e-12: {(s[:, 3] - s[:, 2]).sum() / s[:, 3].sum():.0%}"
        )
    return {"fire_ms": fire_ms.mean(), "hyb_ms": hyb_ms.mean()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=10, help="plastic steps timed per setting")
    ap.add_argument("--max-steps", type=int, default=None, help="AQS steps searched per setting")
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--switch", type=float, default=1e-8)
    ap.add_argument("--repeat", type=int, default=1, help="timings per step (minimum kept)")
    ap.add_argument(
        "--all-steps", action="store_true", help="the first --steps steps, elastic ones too"
    )
    ap.add_argument("--split", action="store_true", help="FIRE iterations per tolerance")
    ap.add_argument("--no-verify", action="store_true", help="skip the final PD check")
    ap.add_argument("--only", type=int, choices=sorted(SETTINGS), default=None)
    args = ap.parse_args(argv)
    for n, (p_target, max_steps) in SETTINGS.items():
        if args.only is None or args.only == n:
            run_setting(n, p_target, max_steps if args.max_steps is None else args.max_steps, args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
