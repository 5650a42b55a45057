"""Where the time goes at the jamming point, and the linear-response strain at pressure p.

    PYTHONPATH=src nice -n 10 python scripts/jamming_cost.py cost --n 250 500 --seeds 1 2 \
        --steps 100 --out cost.json
    PYTHONPATH=src nice -n 10 python scripts/jamming_cost.py strain --n 250 --seeds 1 2 \
        --pressures 1e-2 1e-3 1e-4 1e-5 --out strain.json

``cost``: ``jam(N, 3, seed, p_target=1e-7)``, then (a) constant-volume AQS with plain FIRE
(``affine_shear`` + ``fire.minimize`` with one neighbour list, as ``shear(minimizer="fire",
classify=False)`` does), δγ = 1e-5, every minimum classified by ``rigidity.is_jammed``; (b) the
fixed-pressure protocol (``shear_at_pressure``) from the same packing at p = 1e-3, 1e-4, 1e-5,
δγ = 1e-5. Steps are grouped by the jammed flags of their two minima (J→J, J→U, U→U, U→J);
per group: steps, FIRE iterations (mean, total share), wall time.

``strain``: fixed-pressure AQS at each p with δγ = ``--dgamma`` (or ``factor × p``), recording
the contact set of every minimum: the strain to the first contact change and to the first plastic
step (flag of ``shear_at_pressure``), the median strain between successive ones, and the strain
per step-with-a-change (run strain / number of such steps; an upper bound on δγ's that resolve
single events).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from jamlab.spheres import NeighborList, affine_shear, contacts, jam, minimize
from jamlab.spheres.pressure_shear import shear_at_pressure
from jamlab.spheres.rigidity import is_jammed

CLASSES = ("J->J", "J->U", "U->U", "U->J")


def classify(jammed: np.ndarray) -> np.ndarray:
    a, b = jammed[:-1], jammed[1:]
    out = np.empty(a.shape, dtype=object)
    out[a & b] = "J->J"
    out[a & ~b] = "J->U"
    out[~a & ~b] = "U->U"
    out[~a & b] = "U->J"
    return out


def summarise(kind: np.ndarray, iters: np.ndarray, secs: np.ndarray) -> dict:
    total_it = max(int(iters.sum()), 1)
    total_t = max(float(secs.sum()), 1e-300)
    out = {}
    for c in CLASSES:
        m = kind == c
        out[c] = {
            "steps": int(m.sum()),
            "iter_mean": float(iters[m].mean()) if m.any() else float("nan"),
            "iter_share": float(iters[m].sum() / total_it),
            "ms_per_step": float(1e3 * secs[m].mean()) if m.any() else float("nan"),
            "time_share": float(secs[m].sum() / total_t),
        }
    return out


def constant_volume(packing, dgamma: float, steps: int) -> dict:
    nl = NeighborList(packing)
    cur = packing
    jammed = [is_jammed(cur).jammed]
    iters, secs, pressures = [], [], [is_jammed(cur).pressure]
    for _ in range(steps):
        t = time.perf_counter()
        res = minimize(affine_shear(cur, dgamma), ftol=1e-12, neighbors=nl)
        secs.append(time.perf_counter() - t)
        iters.append(res.iterations)
        cur = res.packing
        s = is_jammed(cur)
        jammed.append(s.jammed)
        pressures.append(s.pressure)
    jammed_a = np.array(jammed)
    kind = classify(jammed_a)
    out = summarise(kind, np.array(iters), np.array(secs))
    out["pressure_last"] = pressures[-1]
    out["first_unjammed_row"] = int(np.argmin(jammed_a)) if not jammed_a.all() else -1
    return out


def fixed_pressure(packing, p: float, dgamma: float, steps: int) -> dict:
    stamps: list[float] = []
    r = shear_at_pressure(
        packing,
        dgamma,
        n_steps=steps,
        pressure=p,
        observer=lambda n, pk: stamps.append(time.perf_counter()),
    )
    c = r.columns
    kind = classify(c["jammed"])
    out = summarise(kind, c["iterations"][1:], np.diff(np.array(stamps)))
    out["n_not_converged"] = r.n_not_converged
    out["volume_steps_mean"] = float(c["volume_steps"][1:].mean())
    out["n_plastic"] = int(c["plastic"].sum())
    return out


def cmd_cost(args) -> dict:
    results = []
    for n in args.n:
        for seed in args.seeds:
            t = time.perf_counter()
            pk = jam(n, 3, seed=seed, p_target=1e-7).packing
            t_jam = time.perf_counter() - t
            row = {"N": n, "seed": seed, "jam_seconds": t_jam}
            row["constant_volume"] = constant_volume(pk, args.dgamma, args.steps)
            print(json.dumps({k: row[k] for k in ("N", "seed")} | row["constant_volume"]))
            for p in args.pressures:
                row[f"p={p:g}"] = fixed_pressure(pk, p, args.dgamma, args.steps)
                print(json.dumps({"N": n, "seed": seed, "p": p} | row[f"p={p:g}"]))
            results.append(row)
    return {"command": "cost", "args": vars(args), "results": results}


def cmd_strain(args) -> dict:
    results = []
    for n in args.n:
        for seed in args.seeds:
            pk = jam(n, 3, seed=seed, p_target=1e-7).packing
            for p in args.pressures:
                dg = args.dgamma if args.dgamma else args.factor * p
                keys: list[np.ndarray] = []

                def observe(_: int, q, keys=keys) -> None:
                    i, j, _d = contacts(q)
                    keys.append(i.astype(np.int64) * q.n + j)

                r = shear_at_pressure(pk, dg, n_steps=args.steps, pressure=p, observer=observe)
                changed = np.array(
                    [not np.array_equal(a, b) for a, b in zip(keys[:-1], keys[1:], strict=True)]
                )
                n_changes = np.array(
                    [np.setxor1d(a, b).size for a, b in zip(keys[:-1], keys[1:], strict=True)]
                )
                plastic = r.columns["plastic"][1:]

                def median_gap(flags: np.ndarray, dg: float = dg) -> float:
                    idx = np.flatnonzero(flags)
                    if idx.size < 2:
                        return float("nan")
                    return float(np.median(np.diff(idx)) * dg)

                row = {
                    "N": n,
                    "seed": seed,
                    "p": p,
                    "dgamma": dg,
                    "steps": args.steps,
                    "frac_steps_contact_change": float(changed.mean()),
                    "contact_changes_per_step": float(n_changes.mean()),
                    "first_contact_change_strain": float(
                        (np.argmax(changed) + 1) * dg if changed.any() else np.nan
                    ),
                    "median_strain_between_contact_changes": median_gap(changed),
                    "frac_steps_plastic": float(plastic.mean()),
                    "first_plastic_strain": float(
                        (np.argmax(plastic) + 1) * dg if plastic.any() else np.nan
                    ),
                    "median_strain_between_plastic": median_gap(plastic),
                    "strain_per_contact_change_step": float(
                        dg * len(changed) / max(changed.sum(), 1)
                    ),
                    "strain_per_plastic_step": float(dg * len(plastic) / max(plastic.sum(), 1)),
                    "n_not_converged": r.n_not_converged,
                    "seconds": r.time,
                }
                print(json.dumps(row))
                results.append(row)
    return {"command": "strain", "args": vars(args), "results": results}


def cmd_table(args) -> None:
    """Markdown tables from the JSON files of ``cost`` and ``strain``."""
    for path in args.files:
        with open(path) as f:
            data = json.load(f)
        if data["command"] == "cost":
            print("| N | seed | protocol | " + " | ".join(CLASSES) + " | ms/step (all) |")
            print("|---|---|---|" + "---|" * len(CLASSES) + "---|")
            for row in data["results"]:
                for key in [k for k in row if k == "constant_volume" or k.startswith("p=")]:
                    r = row[key]
                    cells = []
                    total_t, total_n = 0.0, 0
                    for c in CLASSES:
                        if r[c]["steps"]:
                            cells.append(
                                f"{r[c]['steps']} × {r[c]['iter_mean']:,.0f} it, "
                                f"{r[c]['ms_per_step']:,.0f} ms"
                            )
                            total_t += r[c]["ms_per_step"] * r[c]["steps"]
                            total_n += r[c]["steps"]
                        else:
                            cells.append("–")
                    name = "constant V" if key == "constant_volume" else key
                    print(
                        f"| {row['N']} | {row['seed']} | {name} | "
                        + " | ".join(cells)
                        + f" | {total_t / max(total_n, 1):,.0f} |"
                    )
        else:
            print(
                "| N | seed | p | δγ | first contact change | strain per step with a change | "
                "changes per step | first plastic | strain per plastic step |"
            )
            print("|---|---|---|---|---|---|---|---|---|")
            for r in data["results"]:
                cc = ">" if r["frac_steps_contact_change"] == 0 else ""
                pl = ">" if r["frac_steps_plastic"] == 0 else ""
                print(
                    f"| {r['N']} | {r['seed']} | {r['p']:g} | {r['dgamma']:g} | "
                    f"{r['first_contact_change_strain']:.2g} | "
                    f"{cc}{r['strain_per_contact_change_step']:.2g} | "
                    f"{r['contact_changes_per_step']:.2f} | {r['first_plastic_strain']:.2g} | "
                    f"{pl}{r['strain_per_plastic_step']:.2g} |"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cost")
    c.add_argument("--n", type=int, nargs="+", default=[250, 500])
    c.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    c.add_argument("--steps", type=int, default=100)
    c.add_argument("--dgamma", type=float, default=1e-5)
    c.add_argument("--pressures", type=float, nargs="+", default=[1e-3, 1e-4, 1e-5])
    c.add_argument("--out", default=None)
    s = sub.add_parser("strain")
    s.add_argument("--n", type=int, nargs="+", default=[250])
    s.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    s.add_argument("--steps", type=int, default=300)
    s.add_argument("--factor", type=float, default=1e-3, help="δγ = factor × p")
    s.add_argument("--dgamma", type=float, default=None, help="fixed δγ (overrides --factor)")
    s.add_argument("--pressures", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 1e-5])
    s.add_argument("--out", default=None)
    t = sub.add_parser("table")
    t.add_argument("files", nargs="+")
    args = ap.parse_args()
    if args.cmd == "table":
        cmd_table(args)
        return
    out = cmd_cost(args) if args.cmd == "cost" else cmd_strain(args)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(out, f, indent=1, default=str)


if __name__ == "__main__":
    main()
