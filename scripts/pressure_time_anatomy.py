"""Fixed-pressure AQS: where the CPU time goes, by enthalpy minimisation.

Every ``minimize_enthalpy`` call of a ``shear_at_pressure`` run (the steps themselves, and the
deferred confirmation's substeps and pieces) is timed (CPU) with the FIRE it ran inside (the
Newton relaxer's fallbacks, the FIRE that finishes a refused Newton, the rattler polish) and
how many relaxer calls (volume iterations) it made. Printed: the elastic minimisations (no FIRE:
Newton throughout) and those with FIRE, split into the steps and the confirmation, and the steps
that needed FIRE without being flagged plastic (rearrangements below the flag's threshold).

The packing is ``bench_pressure.py``'s (``jam(N, 3, seed, p_target=min(p, 1e-4))`` brought to
``p`` by one FIRE step), read from its ``--cache`` or made there; or, with ``--sample FILE``, a
fixed-pressure run's prepared packing sheared as the run did (its first ``--steps`` steps).

    PYTHONPATH=src python scripts/pressure_time_anatomy.py --n 1000 --pressure 1e-4 --seed 3 \\
        --steps 150 --cache CACHE
"""

from __future__ import annotations

import sys
import time
import traceback
from collections import Counter
from pathlib import Path

# bench_pressure first: it sets one thread for the BLAS, OpenMP and numba before numpy loads
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_pressure import parse_sample_arguments, sample_start  # noqa: E402

# isort: split
import numpy as np  # noqa: E402

import jamlab.spheres.barostat as barostat  # noqa: E402
import jamlab.spheres.confirm as confirm  # noqa: E402
import jamlab.spheres.newton_relax as newton_relax  # noqa: E402
import jamlab.spheres.pressure_shear as pressure_shear  # noqa: E402


def main() -> None:
    a = parse_sample_arguments(__doc__)

    records: list[dict] = []
    current: dict = {}
    inner_minimize_enthalpy = barostat.minimize_enthalpy
    inner_fire = newton_relax.minimize
    inner_call = newton_relax.NewtonRelaxer.__call__

    def timed_enthalpy(*args, **kwargs):
        nonlocal current
        names = {f.name for f in traceback.extract_stack()}
        current = {"fire": 0.0, "n_fire": 0, "calls": 0,
                   "source": "confirmation" if "_confirm" in names else "step"}
        t = time.process_time()
        res = inner_minimize_enthalpy(*args, **kwargs)
        current["cpu"] = time.process_time() - t
        records.append(current)
        return res

    def timed_fire(*args, **kwargs):
        t = time.process_time()
        res = inner_fire(*args, **kwargs)
        current["fire"] += time.process_time() - t
        current["n_fire"] += 1
        return res

    def counted_call(self, *args, **kwargs):
        current["calls"] += 1
        return inner_call(self, *args, **kwargs)

    for module in (barostat, pressure_shear, confirm):
        if hasattr(module, "minimize_enthalpy"):
            module.minimize_enthalpy = timed_enthalpy
    newton_relax.minimize = timed_fire
    newton_relax.NewtonRelaxer.__call__ = counted_call

    pk = sample_start(a)
    pressure_shear.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=1)  # compile
    records.clear()
    t = time.process_time()
    run = pressure_shear.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps)
    total = time.process_time() - t
    plastic = int(np.sum(run.columns["plastic"][1:]))
    fire_total = sum(r["fire"] for r in records)
    print(f"N={a.n} p={a.pressure:g} seed={a.seed} {a.steps} steps of {a.dgamma:g}: "
          f"{total:.1f} CPU s, {plastic} plastic; FIRE {fire_total:.1f} s "
          f"({100 * fire_total / total:.0f} %)")
    print("| minimisations | count | CPU s | % of run | FIRE s | relaxer calls each |")
    print("|---|---|---|---|---|---|")
    for source in ("step", "confirmation"):
        for with_fire in (False, True):
            rows = [r for r in records if r["source"] == source and (r["n_fire"] > 0) == with_fire]
            cpu = sum(r["cpu"] for r in rows)
            calls = np.mean([r["calls"] for r in rows]) if rows else float("nan")
            label = f"{source}, {'with FIRE' if with_fire else 'Newton only'}"
            print(f"| {label} | {len(rows)} | {cpu:.1f} | {100 * cpu / total:.0f} | "
                  f"{sum(r['fire'] for r in rows):.1f} | {calls:.2f} |")
    steps_fire = sum(1 for r in records if r["source"] == "step" and r["n_fire"] > 0)
    print(f"steps with FIRE: {steps_fire} of {a.steps}; flagged plastic: {plastic}; so at least "
          f"{steps_fire - plastic} steps needed FIRE below the flag's threshold")
    elastic = [r for r in records if r["source"] == "step" and r["n_fire"] == 0]
    print("Newton-only steps by relaxer calls:", dict(sorted(Counter(r["calls"] for r in elastic)
                                                         .items())))


if __name__ == "__main__":
    main()
