"""Fixed-pressure AQS: the Newton relaxer's attempts that fail, and what they cost.

Every attempt of the relaxer (:meth:`jamlab.spheres.newton_relax.NewtonRelaxer._attempt`) in a
``shear_at_pressure`` run is timed (CPU) with the damped Newton runs it made (one per active
set), their outcome and the factorisations it made. Printed: the attempts by outcome (accepted;
failed, after which FIRE takes the problem; the finishes of FIRE's loose minima), and for the
failed ones why the last Newton run stopped, how many active sets they tried first, and where
their time went.

The packing is ``bench_pressure.py``'s (``jam(N, 3, seed, p_target=min(p, 1e-4))`` brought to
``p``), read from its ``--cache`` or made there; or, with ``--sample FILE``, a fixed-pressure
run's prepared packing sheared as the run did (its first ``--steps`` steps).

    PYTHONPATH=src python scripts/newton_failure_anatomy.py --n 1000 --pressure 1e-4 --seed 3 \\
        --steps 150 --cache CACHE
"""

from __future__ import annotations

import sys
import time
from collections import Counter
from pathlib import Path

# bench_pressure first: it sets one thread for the BLAS, OpenMP and numba before numpy loads
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_pressure import parse_sample_arguments, sample_start  # noqa: E402

# isort: split
import jamlab.spheres.newton_relax as newton_relax  # noqa: E402
from jamlab.spheres.pressure_shear import shear_at_pressure  # noqa: E402


def main() -> None:
    a = parse_sample_arguments(__doc__)

    attempts: list[dict] = []
    current: dict = {}
    inner_newton = newton_relax.damped_newton
    inner_attempt = newton_relax.NewtonRelaxer._attempt
    inner_usable = newton_relax._usable
    inner_evaluate = newton_relax.evaluate

    def timed_newton(*args, **kwargs):
        t = time.process_time()
        res = inner_newton(*args, **kwargs)
        current["runs"].append((res.ok, res.reason or "", res.iterations,
                                time.process_time() - t))
        return res

    def noted_usable(fac):
        ok = inner_usable(fac)
        if not ok:
            current["unusable"] += 1
        return ok

    def noted_evaluate(packing, *args, **kwargs):
        ev = inner_evaluate(packing, *args, **kwargs)
        current["last_max_force"] = float(ev.max_force)
        return ev

    def timed_attempt(self, packing, ftol, max_iter, params, parent, t0):
        nonlocal current
        current = {"runs": [], "unusable": 0, "last_max_force": None,
                   "finish": parent is packing}
        n_fac = self.counters["n_factorisations"]
        t = time.process_time()
        res = inner_attempt(self, packing, ftol, max_iter, params, parent, t0)
        current["cpu"] = time.process_time() - t
        current["factorisations"] = self.counters["n_factorisations"] - n_fac
        current["ok"] = res is not None and res.converged
        current["ftol"] = ftol
        attempts.append(current)
        return res

    newton_relax.damped_newton = timed_newton
    newton_relax.NewtonRelaxer._attempt = timed_attempt
    newton_relax._usable = noted_usable
    newton_relax.evaluate = noted_evaluate

    packing = sample_start(a)
    t = time.process_time()
    res = shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps)
    total = time.process_time() - t
    print(f"N={a.n} p={a.pressure:g} seed={a.seed} {a.steps} steps of {a.dgamma:g}: "
          f"{total:.1f} CPU s, {int(res.columns['plastic'].sum())} plastic")

    def why(x: dict) -> str:
        if not x["runs"]:
            return "no Newton run (no usable factor)"
        ok, reason = x["runs"][-1][:2]
        if not ok:
            return f"Newton: {reason}"
        if x["unusable"]:
            return "the smaller backbone's factor not positive definite"
        if x["last_max_force"] is not None and not x["last_max_force"] < x["ftol"]:
            return "the full evaluation's max|F| >= ftol"
        return "active sets not settled"

    print("| attempts | count | CPU s | % of run | factorisations |")
    print("|---|---|---|---|---|")
    groups = {
        "accepted (from the parent)": [x for x in attempts if x["ok"] and not x["finish"]],
        "failed (FIRE from the affine start)": [x for x in attempts
                                                if not x["ok"] and not x["finish"]],
        "finish of FIRE's loose minimum, accepted": [x for x in attempts
                                                     if x["ok"] and x["finish"]],
        "finish of FIRE's loose minimum, refused": [x for x in attempts
                                                    if not x["ok"] and x["finish"]],
    }
    for name, xs in groups.items():
        cpu = sum(x["cpu"] for x in xs)
        print(f"| {name} | {len(xs)} | {cpu:.2f} | {100 * cpu / total:.0f} | "
              f"{sum(x['factorisations'] for x in xs)} |")
    failed = groups["failed (FIRE from the affine start)"]
    print("\nfailed attempts, why the last Newton run stopped:")
    for reason, count in Counter(why(x) for x in failed).most_common():
        print(f"  {count:4d}  {reason}")
    print("failed attempts by Newton runs (active sets) tried:",
          dict(sorted(Counter(len(x["runs"]) for x in failed).items())))
    print("iterations of the last (failing) Newton run:",
          dict(sorted(Counter(x["runs"][-1][2] for x in failed if x["runs"]).items())))
    last = sum(x["runs"][-1][3] for x in failed if x["runs"])
    earlier = sum(sum(r[3] for r in x["runs"][:-1]) for x in failed)
    rest = sum(x["cpu"] for x in failed) - last - earlier
    print(f"their CPU s: earlier Newton runs (converged on a network that then changed) "
          f"{earlier:.2f}, the failing run {last:.2f}, the rest (factorisations, lists, "
          f"rattlers, evaluations) {rest:.2f}")


if __name__ == "__main__":
    main()
