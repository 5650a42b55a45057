"""How far is FIRE's minimum from the point where the fixed-pressure relaxer's Newton failed?

Every FIRE fallback of the Newton relaxer (``NewtonRelaxer._fire``) that follows a failed
damped-Newton run is compared with the start of that run (the last contact network the
active-set iteration reached, ``_active_set``): the contacts lost and gained between the two
(all contacts of ``jamlab.spheres.aqs.network.contact_list``, rattlers' too), the largest and
the rms displacement, and how many particles moved by more than 1e-3 of the largest. The
question it answers: is a failed step a slide along one floppy mode to one new contact (then a
cheaper path than FIRE could follow it), or a rearrangement of many contacts? Both functions
are wrapped for the run and nothing else changes (same rows as the unwrapped run).

    PYTHONPATH=src python scripts/fallback_contacts.py --n 1000 --seed 1 --steps 150 --cache C

(the options of ``benchmarks/bench_pressure.parse_sample_arguments``; ``--list`` prints every
fallback). Prints the number of fallbacks, their CPU time, and the quantiles of each column.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_pressure import parse_sample_arguments, sample_start  # noqa: E402

# isort: split
import numpy as np  # noqa: E402

import jamlab.spheres.newton_relax as nr  # noqa: E402
import jamlab.spheres.pressure_shear as ps  # noqa: E402
from jamlab.spheres.aqs.network import contact_list  # noqa: E402
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList  # noqa: E402


def contact_keys(packing) -> set[tuple[int, int]]:
    """The packing's contacts as ordered index pairs."""
    ci, cj, _ = contact_list(packing, NeighborList(packing, skin=RELAX_SKIN))
    return set(zip(np.minimum(ci, cj).tolist(), np.maximum(ci, cj).tolist(), strict=True))


def main(argv: list[str] | None = None) -> int:
    a = parse_sample_arguments(__doc__, argv, lambda ap: ap.add_argument(
        "--list", action="store_true", help="print every fallback"))
    packing = sample_start(a)
    last: dict = {"start": None, "ok": True, "reason": ""}
    records: list = []
    damped_newton, fire = nr.damped_newton, nr.NewtonRelaxer._fire

    def wrapped_newton(start, *args, **kw):
        res = damped_newton(start, *args, **kw)
        last.update(start=start, ok=res.ok, reason=res.reason)
        return res

    def wrapped_fire(self, start, ftol, max_iter, params, t0):
        failed = None if last["ok"] else (last["start"], last["reason"])
        t = time.process_time()
        res = fire(self, start, ftol, max_iter, params, t0)
        records.append((failed, res, time.process_time() - t))
        return res

    nr.damped_newton, nr.NewtonRelaxer._fire = wrapped_newton, wrapped_fire
    try:
        run = ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps)
    finally:
        nr.damped_newton, nr.NewtonRelaxer._fire = damped_newton, fire
    plastic = int(np.asarray(run.columns["plastic"], dtype=bool).sum())
    rows = []
    for failed, res, cpu in records:
        if failed is None or not res.converged:
            continue
        start, reason = failed
        before, after = contact_keys(start), contact_keys(res.packing)
        d = np.linalg.norm(res.packing.box.minimum_image(res.packing.positions - start.positions),
                           axis=1)
        rows.append((len(before - after), len(after - before), d.max(), np.sqrt(np.mean(d**2)),
                     int(np.count_nonzero(d > 1e-3 * d.max())), cpu, reason))
    print(f"N = {a.n}, seed {a.seed}, p = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps, "
          f"{plastic} plastic; {len(records)} FIRE fallbacks "
          f"({sum(r[2] for r in records):.1f} CPU s), {len(rows)} after a failed Newton run "
          f"({sum(r[5] for r in rows):.1f} CPU s)")
    if not rows:
        return 0
    cols = np.array([r[:6] for r in rows], dtype=np.float64)
    names = ("contacts lost", "contacts gained", "max |dx| (σ)", "rms |dx| (σ)",
             "particles moved > 1e-3 max", "CPU s")
    print("\n| quantity | min | 10 % | median | 90 % | max |\n|---|---|---|---|---|---|")
    for name, col in zip(names, cols.T, strict=True):
        q = np.percentile(col, [0, 10, 50, 90, 100])
        print(f"| {name} | " + " | ".join(f"{v:.3g}" for v in q) + " |")
    single = np.count_nonzero((cols[:, 0] <= 1) & (cols[:, 1] <= 1))
    print(f"\none contact lost and at most one gained: {single} of {len(rows)}")
    reasons: dict[str, int] = {}
    for r in rows:
        reasons[r[6]] = reasons.get(r[6], 0) + 1
    print("why Newton stopped: " + "; ".join(f"{k}: {v}" for k, v in sorted(
        reasons.items(), key=lambda kv: -kv[1])))
    if a.list:
        for r in rows:
            print(f"{r[0]:4d} {r[1]:4d} {r[2]:.2e} {r[3]:.2e} {r[4]:5d} {r[5]:.3f} {r[6]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
