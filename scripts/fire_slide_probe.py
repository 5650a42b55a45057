"""Fixed pressure: what FIRE does in its longest runs, and a push off the unstable mode tried.

Default: every FIRE run of the Newton relaxer (:mod:`jamlab.spheres.newton_relax`) in the first
``--steps`` steps of a run is caught (its start, tolerance and iterations); the three
longest are replayed from their starts with FIRE stopped after ``K`` iterations, ``K`` on a
geometric grid (FIRE is deterministic, so each is a point of the same trajectory). Printed per
point: ``max|F|``, the energy, the displacement since the previous point and the cosine of its
direction with the previous displacement (near 1: the configuration moves on a straight line).

``--push``: the same steps twice, the second time with the relaxer's refused finish changed —
where Newton refuses FIRE's loose point (``max|F| < finish_below``), the pinned backbone Hessian
there is tested for an unstable mode (:func:`jamlab.spheres.aqs.saddle.saddle_push`, downhill),
the particles pushed along it, FIRE taken to the loose level again and the finish tried again
(at most ``MAX_DESCENTS`` pushes), instead of FIRE on to ``ftol`` at once. Printed: CPU time,
FIRE iterations and plastic steps of both, and the pushes.

    PYTHONPATH=src python scripts/fire_slide_probe.py \\
        --sample RUNS/n250-p1e-6-fix40/samples/phi=jamming/N=250/sample-00000.h5 --steps 100
    PYTHONPATH=src python scripts/fire_slide_probe.py --sample … --steps 200 --push
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_pressure import parse_sample_arguments, sample_start  # noqa: E402

# isort: split
import numpy as np  # noqa: E402

import jamlab.spheres.newton_relax as nr  # noqa: E402
import jamlab.spheres.pressure_shear as pressure_shear  # noqa: E402
from jamlab.spheres.aqs.network import find_backbone  # noqa: E402
from jamlab.spheres.aqs.saddle import MAX_DESCENTS, saddle_push  # noqa: E402
from jamlab.spheres.fire import minimize  # noqa: E402
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList  # noqa: E402

RUNS = 3  # the longest FIRE runs replayed
POINTS = 40  # grid points per replay

PUSHES = {"refused": 0, "pushed": 0, "accepted after a push": 0, "no unstable mode": 0}


def pushed_fire(self, packing, ftol, max_iter, params, t0):
    """``NewtonRelaxer._fire`` with a push off the unstable mode where the finish is refused."""
    if self.finish_below is None or not self.finish_below > ftol:
        return nr.minimize(packing, ftol=ftol, max_iter=max_iter, params=params, skin=RELAX_SKIN)
    loose = nr.minimize(packing, ftol=self.finish_below, max_iter=max_iter, params=params,
                        skin=RELAX_SKIN)
    if not loose.converged:
        return loose
    spent = loose.iterations
    for k in range(MAX_DESCENTS + 1):
        fin = self.newton_only(loose.packing, ftol, max_iter, params, parent=loose.packing)
        if fin is not None and fin.converged:
            self.counters["n_fire_finished_by_newton"] += 1
            PUSHES["accepted after a push"] += k > 0
            return replace(fin, iterations=spent + fin.iterations, time=time.perf_counter() - t0)
        PUSHES["refused"] += 1
        self.fac, self.age = None, 0
        if k == MAX_DESCENTS:
            break
        pk = loose.packing
        nl = NeighborList(pk, skin=RELAX_SKIN)
        push, _ = saddle_push(pk, nl, find_backbone(pk, nl), downhill=True)
        if push is None:
            PUSHES["no unstable mode"] += 1
            break
        PUSHES["pushed"] += 1
        loose = nr.minimize(pk.with_positions(pk.positions + push), ftol=self.finish_below,
                            max_iter=max(0, max_iter - spent), params=params, skin=RELAX_SKIN)
        spent += loose.iterations
        if not loose.converged:
            return replace(loose, iterations=spent)
    fin = nr.minimize(loose.packing, ftol=ftol, max_iter=max(0, max_iter - spent),
                      params=params, skin=RELAX_SKIN)
    return replace(fin, iterations=spent + fin.iterations, time=time.perf_counter() - t0)


def caught_fire_runs(a) -> list[tuple[float, int, object]]:
    """``(ftol, iterations, start)`` of every FIRE run of the Newton relaxer in the first
    ``a.steps`` steps of the run :func:`parse_sample_arguments`'s options name, in order."""
    inner = nr.minimize
    caught: list[tuple[float, int, object]] = []

    def catch(packing, *args, **kwargs):
        res = inner(packing, *args, **kwargs)
        caught.append((kwargs.get("ftol", 1e-12), res.iterations, packing))
        return res

    nr.minimize = catch
    try:
        pressure_shear.shear_at_pressure(sample_start(a), a.dgamma, pressure=a.pressure,
                                         n_steps=a.steps)
    finally:
        nr.minimize = inner
    return caught


def replay(a) -> None:
    caught = caught_fire_runs(a)
    by_tol: dict[float, list[int]] = {}
    for tol, iters, _ in caught:
        by_tol.setdefault(tol, []).append(iters)
    for tol, its in sorted(by_tol.items()):
        print(f"FIRE runs to {tol:g}: {len(its)}, {sum(its)} iterations")
    caught.sort(key=lambda c: -c[1])
    for tol, iters, start in caught[:RUNS]:
        total = minimize(start, ftol=1e-12, skin=RELAX_SKIN).iterations
        print(f"\nFIRE from a start of a run to {tol:g} ({iters} iterations there): {total} "
              f"iterations to 1e-12\n")
        print("| K | max|F| | E | |Δx| since the last point | cos with the last |Δx| |")
        print("|---|---|---|---|---|")
        last, last_d = start.positions, None
        for k in np.unique(np.round(np.geomspace(50, total, POINTS)).astype(int)):
            res = minimize(start, ftol=1e-300, max_iter=int(k), skin=RELAX_SKIN)
            d = start.box.minimum_image(res.packing.positions - last).ravel()
            cos = (float(d @ last_d / (np.linalg.norm(d) * np.linalg.norm(last_d)))
                   if last_d is not None and np.linalg.norm(d) > 0 else float("nan"))
            print(f"| {k} | {res.max_force:.2e} | {res.energy:.10e} | {np.linalg.norm(d):.2e} "
                  f"| {cos:+.3f} |")
            last, last_d = res.packing.positions, d


def compare(a) -> None:
    pk = sample_start(a)
    pressure_shear.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=1)  # compile
    original = nr.NewtonRelaxer._fire
    flags = {}
    for name, method in (("now", original), ("push", pushed_fire)):
        nr.NewtonRelaxer._fire = method
        t = time.process_time()
        run = pressure_shear.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps)
        cpu = time.process_time() - t
        flags[name] = np.asarray(run.columns["plastic"][1:]) > 0.5
        print(f"{name}: {cpu:.1f} CPU s, {int(np.sum(run.columns['iterations']))} FIRE "
              f"iterations, {int(flags[name].sum())} plastic of {a.steps} steps")
    nr.NewtonRelaxer._fire = original
    print("pushes:", PUSHES)
    same = np.array_equal(flags["now"], flags["push"])
    print("same plastic flags" if same else
          f"plastic flags differ from step {int(np.argmax(flags['now'] != flags['push'])) + 1}")


if __name__ == "__main__":
    push = "--push" in sys.argv
    sys.argv = [x for x in sys.argv if x != "--push"]
    args = parse_sample_arguments(__doc__)
    if push:
        compare(args)
    else:
        replay(args)
