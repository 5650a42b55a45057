"""Constant-volume AQS at jamming with the floppy steps projected against FIRE, on many samples.

``AQSParameters(floppy="project")`` takes a step that starts from an unjammed minimum to the
overlap-free configuration nearest to its affine start (:mod:`jamlab.spheres.aqs.projection`);
``floppy="fire"`` (the reference) takes it by the usual strategies, FIRE where they end. The
two are different protocols in the floppy states (both ends are minima, ``E = 0`` or below the
resolution floor), so the trajectories part after the first floppy step; what must agree is the
statistics of what is counted: the steps between jammed minima. Same packings for both
(``jam(N, 3, seed, p_target)``, the ``bench_jamming.py`` start), the paper's protocol
(``--steps`` of ``δγ``). Printed per seed and pooled: CPU time, the fraction of jammed minima,
plastic steps among jammed steps, ``⟨S⟩``, the median pressure of the counted avalanches, the
two-sample KS test on the sizes and τ of both above one ``S_min`` (chosen on the reference's
sizes). ``--save`` keeps the traces' columns and CPU times (npz); ``--combine`` reports on
saved runs together (e.g. halves run on two cores).

    python scripts/floppy_projection_check.py --n 250 --seeds 1-20 --save a.npz &
    python scripts/floppy_projection_check.py --n 250 --seeds 21-40 --save b.npz
    python scripts/floppy_projection_check.py --combine a.npz b.npz

``--only project`` runs the variant alone; ``--combine`` then takes the reference's columns
from earlier saved runs given with ``--reference`` (matched by seed; the FIRE path does not
depend on the projection, so a changed projection is compared with the same FIRE runs).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from jamlab.analysis.avalanches import avalanche_sizes
from jamlab.spheres.aqs import AQSParameters, shear
from jamlab.spheres.packing import jam

sys.path.insert(0, str(Path(__file__).resolve().parent))
from newton_vs_fire_pressure import print_size_comparison, seeds  # noqa: E402

MODES = ("project", "fire")  # the variant, then the reference


COLUMNS = ("pressure", "jammed", "plastic", "energy_jump")


def counted(cols: dict) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Sizes and pressures (at the step's end) of the plastic steps between jammed minima, the
    plastic count and the number of jammed steps, from one trace's columns."""
    jammed = np.asarray(cols["jammed"], dtype=bool)
    ej, plastic = cols["energy_jump"][1:], np.asarray(cols["plastic"][1:], dtype=bool)
    ok = jammed[:-1] & jammed[1:]
    sizes = avalanche_sizes(ej, plastic, jammed=jammed)
    return sizes, cols["pressure"][1:][plastic & ok], int((plastic & ok).sum()), int(ok.sum())


def run(a) -> dict[str, np.ndarray]:
    """Shear every seed's packing in both modes (or ``a.only``); the traces' columns and CPU
    times."""
    keep: dict[str, list] = {}
    for seed in a.seeds:
        start = jam(a.n, 3, seed=seed, p_target=a.p_target).packing
        line = f"seed {seed}:"
        for m in (a.only,) if a.only else MODES:
            t = time.process_time()
            res = shear(start, a.dgamma, n_steps=a.steps, params=AQSParameters(floppy=m))
            cpu_s = time.process_time() - t
            tr = res.trace
            if not (tr.max_force < 1e-12).all():
                raise SystemExit(f"seed {seed} {m}: a recorded minimum has max|F| >= 1e-12")
            cols = {c: np.asarray(getattr(tr, c)) for c in COLUMNS}
            for c, v in cols.items():
                keep.setdefault(f"{m}_{c}", []).append(v)
            keep.setdefault(f"{m}_cpu", []).append(cpu_s)
            _, _, n_pl, n_ok = counted(cols)
            extra = ""
            if m == "project":
                extra = (f", projected {tr.attrs.get('n_projected', 0)}"
                         f" (failed {tr.attrs.get('n_projection_failed', 0)})")
            line += (f" | {m}: {cpu_s:.1f} s, jammed minima {int(np.sum(tr.jammed))}, "
                     f"counted {n_pl}/{n_ok}{extra}")
        keep.setdefault("seed", []).append(seed)
        print(line, flush=True)
    return {k: np.array(v) for k, v in keep.items()}


def report(data: dict[str, np.ndarray], header: str) -> None:
    """The pooled table, the KS test and τ of both modes."""
    n = int(data["seed"].size)
    sizes = {m: [] for m in MODES}
    press = {m: [] for m in MODES}
    plastic = {m: 0 for m in MODES}
    steps = {m: 0 for m in MODES}
    for m in MODES:
        for k in range(n):
            s, p, n_pl, n_ok = counted({c: data[f"{m}_{c}"][k] for c in COLUMNS})
            sizes[m].extend(s.tolist())
            press[m].extend(p.tolist())
            plastic[m] += n_pl
            steps[m] += n_ok
        sizes[m] = np.asarray(sizes[m])
    cpu = {m: float(np.sum(data[f"{m}_cpu"])) for m in MODES}
    minima = data["fire_jammed"].size
    print(f"\n{header}, {n} samples\n")
    print("| | " + " | ".join(MODES) + " |\n|---|---|---|")
    print("| CPU s per sample | " + " | ".join(f"{cpu[m] / n:.1f}" for m in MODES) + " |")
    print("| jammed minima | " + " | ".join(
        f"{int(data[f'{m}_jammed'].sum())} / {minima}" for m in MODES) + " |")
    print("| plastic / jammed steps | " + " | ".join(
        f"{plastic[m]} / {steps[m]} ({plastic[m] / max(1, steps[m]):.4f})" for m in MODES) + " |")
    print("| ⟨S⟩ | " + " | ".join(
        f"{sizes[m].mean():.3e} ± {sizes[m].std() / np.sqrt(max(1, sizes[m].size)):.1e}"
        for m in MODES) + " |")
    print("| median p of the counted avalanches | " + " | ".join(
        f"{np.median(press[m]):.2e}" for m in MODES) + " |")
    print(f"\nCPU time fire / project: {cpu['fire'] / cpu['project']:.2f}")
    if sizes["project"].size and sizes["fire"].size:
        print_size_comparison(sizes, "project", "fire")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--seeds", type=seeds, default=seeds("1-40"))
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--p-target", type=float, default=1e-7)
    ap.add_argument("--save", type=Path, default=None, help="write the columns (npz)")
    ap.add_argument("--combine", type=Path, nargs="+", default=None,
                    help="report on saved runs (npz from --save) instead of running")
    ap.add_argument("--only", choices=MODES, default=None,
                    help="run this mode alone (combine with --reference)")
    ap.add_argument("--reference", type=Path, nargs="+", default=None,
                    help="with --combine: the reference mode's columns from these saved runs")
    a = ap.parse_args()
    if a.combine:
        parts = [dict(np.load(p)) for p in a.combine]
        data = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        if a.reference:
            ref = [dict(np.load(p)) for p in a.reference]
            ref_data = {k: np.concatenate([p[k] for p in ref]) for k in ref[0]}
            row = {int(s): i for i, s in enumerate(ref_data["seed"])}
            missing = [int(s) for s in data["seed"] if int(s) not in row]
            if missing:
                raise SystemExit(f"seeds {missing} are not in the reference runs")
            take = [row[int(s)] for s in data["seed"]]
            m = MODES[1]
            data |= {k: v[take] for k, v in ref_data.items() if k.startswith(f"{m}_")}
        report(data, f"{len(parts)} saved runs combined")
        return
    data = run(a)
    if a.save is not None:
        np.savez(a.save, **data)
    if a.only:
        return
    report(data, f"N={a.n}, constant volume from p={a.p_target:g}, δγ={a.dgamma:g}, "
                 f"{a.steps} steps")


if __name__ == "__main__":
    main()
