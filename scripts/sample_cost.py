"""Where the CPU time of a fixed-pressure AQS run goes: steps, deferred confirmation, its probes
and pieces, FIRE and the factorisations.

Runs ``shear_at_pressure(packing, δγ, pressure=p, n_steps=…)`` (the default path) on the packing
of ``benchmarks/bench_pressure.py``'s cache (``jam(N, 3, seed, p_target=min(p, 1e-4))`` brought to
p; made and cached there if missing) and prints, in CPU time: the whole run, the stepping (up to
the last step's progress call) and the deferred confirmation of the candidate steps after it;
inside the confirmation its probes (Newton only) and its pieces (the full relaxer: FIRE carries
an event again); FIRE runs (fallbacks and rattler polishes) and factorisations by where they
happen; the relaxer's calls (the steps' and the confirmation's pieces') by their place in their
enthalpy minimisation (the first, at the guessed box side, and the volume steps after it), with
those that fell back to FIRE apart; the plastic flags per block of 100 steps; the run's
counters. ``--json`` keeps it all.

    PYTHONPATH=src python scripts/sample_cost.py --n 1000 --seed 1 --steps 1000 --cache CACHE
    PYTHONPATH=src python scripts/sample_cost.py --n 4000 --seed 1 --steps 100 --cache CACHE
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import json
import time
from pathlib import Path

import numpy as np

import jamlab.spheres.barostat as barostat
import jamlab.spheres.newton_relax as relax_module
import jamlab.spheres.pressure_shear as ps

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_pressure.py"


def instrument() -> tuple[collections.Counter, collections.Counter]:
    """Wrap the relaxer's FIRE and factorisation, and the confirmation's probes and pieces, to
    add their CPU time and calls by where they happen (``main``, ``confirm``, ``probe``,
    ``piece``). Returns ``(seconds, calls)`` keyed by ``(where, what)``."""
    where = ["main"]
    secs: collections.Counter = collections.Counter()
    calls: collections.Counter = collections.Counter()

    def timed(fn, what):
        def wrapper(*a, **k):
            t = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                secs[(where[-1], what)] += time.process_time() - t
                calls[(where[-1], what)] += 1
        return wrapper

    relax_module.factorise = timed(relax_module.factorise, "factorise")
    relax_module.minimize = timed(relax_module.minimize, "fire")

    def scoped(make, name):
        def outer(*a, **k):
            inner = make(*a, **k)

            def run(*b, **kw):
                if where[-1] == "main":  # (the stepping's own use of the same helper)
                    return inner(*b, **kw)
                where.append(name)
                t = time.process_time()
                try:
                    return inner(*b, **kw)
                finally:
                    where.pop()
                    secs[(name, "total")] += time.process_time() - t
                    calls[(name, "total")] += 1
            return run
        return outer

    ps._probe = scoped(ps._probe, "probe")
    ps._advance = scoped(ps._advance, "piece")
    confirm = ps._confirm

    def confirming(*a, **k):
        where.append("confirm")
        t = time.process_time()
        try:
            return confirm(*a, **k)
        finally:
            where.pop()
            secs[("confirm", "total")] += time.process_time() - t
            calls[("confirm", "total")] += 1

    ps._confirm = confirming
    return secs, calls


def instrument_volume_steps() -> collections.Counter:
    """Wrap the Newton relaxer's calls and the enthalpy minimisation to add, for every relaxer
    call made inside an enthalpy minimisation (the steps' and the confirmation's pieces'; its
    probes call the relaxer's Newton alone, not counted), CPU time and calls keyed by
    ``(order, fell back)``: ``order`` 0 for a minimisation's first call, 1
    and 2 for its first two volume steps, 3 for any later one; ``fell back`` whether the call
    handed its problem to FIRE."""
    tally: collections.Counter = collections.Counter()
    order = [0]
    inside = [0]
    enthalpy = barostat.minimize_enthalpy
    call = relax_module.NewtonRelaxer.__call__

    def minimisation(*a, **k):
        order[0] = 0
        inside[0] += 1
        try:
            return enthalpy(*a, **k)
        finally:
            inside[0] -= 1

    def relaxer(self, *a, **k):
        if not inside[0]:
            return call(self, *a, **k)
        before = self.counters["n_fire_fallbacks"]
        t = time.process_time()
        try:
            return call(self, *a, **k)
        finally:
            key = (min(order[0], 3), self.counters["n_fire_fallbacks"] > before)
            tally[key + ("s",)] += time.process_time() - t
            tally[key + ("calls",)] += 1
            order[0] += 1

    barostat.minimize_enthalpy = minimisation  # (the steps', through barostat.minimize_step)
    ps.minimize_enthalpy = minimisation  # (the start's and the confirmation's pieces)
    relax_module.NewtonRelaxer.__call__ = relaxer
    return tally


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--cache", type=Path, default=Path("bench_pressure_cache"))
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    if a.json is not None and a.json.exists():
        ap.error(f"{a.json} exists; not overwriting it")
    spec = importlib.util.spec_from_file_location("bench_pressure", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    packing = bench.start(a.n, a.pressure, a.seed, a.cache)
    secs, calls = instrument()
    tally = instrument_volume_steps()
    stamps: list[float] = []
    t0 = time.process_time()
    r = ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                             progress=lambda i, total: stamps.append(time.process_time() - t0))
    total = time.process_time() - t0
    plastic = np.asarray(r.columns["plastic"], dtype=bool)
    blocks = [int(plastic[1 + i:101 + i].sum()) for i in range(0, a.steps, 100)]
    print(f"N = {a.n}, seed {a.seed}, p = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps: "
          f"{total:.1f} CPU s ({1e3 * total / a.steps:.0f} ms/step, "
          f"{total / a.steps * 1000 / 60:.1f} min per 1000 steps), {int(plastic.sum())} plastic")
    print(f"stepping {stamps[-1]:.1f} s, deferred confirmation {total - stamps[-1]:.1f} s "
          f"({100 * (total - stamps[-1]) / total:.0f} %)")
    for key in sorted(secs):
        print(f"  {key[0]:>8} {key[1]:<10} {calls[key]:6d} calls {secs[key]:8.1f} s")
    names = {0: "first", 1: "volume step 1", 2: "volume step 2", 3: "volume step 3+"}
    print("relaxer calls by their place in their enthalpy minimisation (steps and pieces):")
    for k in range(4):
        for fell in (False, True):
            n = tally[(k, fell, "calls")]
            if n:
                c = tally[(k, fell, "s")]
                print(f"  {names[k]:>15} {'FIRE fallback' if fell else 'Newton':<14} {n:6d} calls "
                      f"{c:8.1f} s ({1e3 * c / n:.1f} ms each)")
    print(f"plastic per block of 100 steps: {blocks}")
    counters = {k: int(v) for k, v in r.attrs.items() if str(k).startswith("n_")}
    print(counters)
    if a.json is not None:
        a.json.write_text(json.dumps({
            "N": a.n, "seed": a.seed, "steps": a.steps, "pressure": a.pressure,
            "dgamma": a.dgamma, "cpu_s": total, "stepping_cpu_s": stamps[-1],
            "plastic_per_100": blocks, "counters": counters,
            "relaxer_calls": [{"order": k[0], "fire_fallback": k[1], "cpu_s": tally[k],
                               "calls": tally[k[:2] + ("calls",)]}
                              for k in sorted(tally) if k[2] == "s"],
            "parts": [{"where": k[0], "what": k[1], "calls": calls[k], "cpu_s": secs[k]}
                      for k in sorted(secs)]}, indent=1))


if __name__ == "__main__":
    main()
