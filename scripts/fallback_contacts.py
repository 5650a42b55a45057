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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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


@dataclass(frozen=True)
class Fallback:
    """One FIRE fallback after a failed Newton run: ``start`` of that run, FIRE's ``minimum``,
    why Newton stopped, FIRE's CPU seconds, and the columns of the module docstring."""

    start: Any
    minimum: Any
    reason: str
    cpu: float
    lost: int
    gained: int
    max_dx: float
    rms_dx: float
    moved: int


def fallbacks(packing, dgamma: float, pressure: float, n_steps: int) -> tuple[Any, list, int]:
    """``(run, fallbacks after a failed Newton run, FIRE fallbacks in all)`` of
    ``shear_at_pressure(packing, dgamma, pressure=pressure, n_steps=n_steps)``, with the
    relaxer's ``damped_newton`` and ``_fire`` wrapped for the run (restored after)."""
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
        run = ps.shear_at_pressure(packing, dgamma, pressure=pressure, n_steps=n_steps)
    finally:
        nr.damped_newton, nr.NewtonRelaxer._fire = damped_newton, fire
    out = []
    for failed, res, cpu in records:
        if failed is None or not res.converged:
            continue
        start, reason = failed
        before, after = contact_keys(start), contact_keys(res.packing)
        d = np.linalg.norm(res.packing.box.minimum_image(res.packing.positions - start.positions),
                           axis=1)
        out.append(Fallback(start, res.packing, reason, cpu, len(before - after),
                            len(after - before), float(d.max()), float(np.sqrt(np.mean(d**2))),
                            int(np.count_nonzero(d > 1e-3 * d.max()))))
    return run, out, len(records)


def main(argv: list[str] | None = None) -> int:
    a = parse_sample_arguments(__doc__, argv, lambda ap: ap.add_argument(
        "--list", action="store_true", help="print every fallback"))
    t = time.process_time()
    run, rows, n_fire = fallbacks(sample_start(a), a.dgamma, a.pressure, a.steps)
    plastic = int(np.asarray(run.columns["plastic"], dtype=bool).sum())
    print(f"N = {a.n}, seed {a.seed}, p = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps, "
          f"{plastic} plastic ({time.process_time() - t:.1f} CPU s with the comparisons); "
          f"{n_fire} FIRE fallbacks, {len(rows)} after a failed Newton run "
          f"({sum(r.cpu for r in rows):.1f} CPU s)")
    if not rows:
        return 0
    names = ("contacts lost", "contacts gained", "max |dx| (σ)", "rms |dx| (σ)",
             "particles moved > 1e-3 max", "CPU s")
    cols = np.array([(r.lost, r.gained, r.max_dx, r.rms_dx, r.moved, r.cpu) for r in rows])
    print("\n| quantity | min | 10 % | median | 90 % | max |\n|---|---|---|---|---|---|")
    for name, col in zip(names, cols.T, strict=True):
        q = np.percentile(col, [0, 10, 50, 90, 100])
        print(f"| {name} | " + " | ".join(f"{v:.3g}" for v in q) + " |")
    single = sum(1 for r in rows if r.lost <= 1 and r.gained <= 1)
    print(f"\none contact lost and at most one gained: {single} of {len(rows)}")
    reasons: dict[str, int] = {}
    for r in rows:
        reasons[r.reason] = reasons.get(r.reason, 0) + 1
    print("why Newton stopped: " + "; ".join(f"{k}: {v}" for k, v in sorted(
        reasons.items(), key=lambda kv: -kv[1])))
    if a.list:
        for r in rows:
            print(f"{r.lost:4d} {r.gained:4d} {r.max_dx:.2e} {r.rms_dx:.2e} {r.moved:5d} "
                  f"{r.cpu:.3f} {r.reason}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
