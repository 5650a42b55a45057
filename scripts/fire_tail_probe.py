"""FIRE's tail in the constant-volume AQS fallbacks, and whether Newton can finish it.

``cv``: constant-volume AQS (``shear``, the default path) for ``--steps`` steps of ``δγ`` from
``jam(N, 3, seed, p_target=--p-start)`` (``--start jam``; the default 1e-7 is the paper's
protocol at jamming, 1e-5 the pressures the samples reach by dilatancy) or
``prepare(N, 3, 0.8, seed)`` (``--start phi08``); every FIRE run of the stepper (the fallbacks
that carry events, and FIRE's steps in a floppy state) is caught with its start. For each start:
FIRE's iterations and CPU time to ``max|F| < 1e-12``, and to each ``--loose`` level (FIRE is
deterministic: these are prefixes of one run); at each level the energy, the contacts and the
backbone (particles with ≥ d + 1 contacts) and the fixed-pressure relaxer's Newton finish from
there (:class:`jamlab.spheres.newton_relax.NewtonRelaxer` with the loose point as its own
parent, as ``finish_below`` does; accepted or not, its CPU time). With ``--lm K``, a
Levenberg–Marquardt Newton on the full sparse Hessian (CHOLMOD on ``H + μI``, energy descent,
``μ`` ×10 on a rejected step and ÷10 on an accepted one) from the last loose point of the first
``K`` starts, to ``max|F| < 1e-12`` or 300 factorisations.

``restart``: fixed-pressure AQS (``shear_at_pressure``, defaults) from
``benchmarks/bench_pressure.py``'s cached packing; for every inner problem where the relaxer's
Newton iteration failed (it then hands the start to FIRE), FIRE to ``1e-12`` from the start
(what the relaxer does) against FIRE from the point where Newton stopped (the last network
minimum, or the failed iteration's start): iterations, and the two minima's energy and largest
displacement.

``dtmax``: FIRE's largest time step. The inner problems the fixed-pressure relaxer handed to FIRE
in ``--steps`` steps of ``jam(N, 3, seed, p_target=1e-4)`` at p = 1e-4
(``scripts/fire_fallback_probe.py``'s collection), and the first ``--cv-runs`` FIRE runs of the
constant-volume ``cv`` protocol from ``jam(N, 3, seed, 1e-7)``, each minimised to ``1e-12`` with
``FireParameters(dt_max=…)`` for every ``--dt-max``: iterations, CPU time, how many converged
within ``--max-iter``, and the largest energy and position difference from the first value's
minima.

    PYTHONPATH=src python scripts/fire_tail_probe.py cv --start jam --n 1000 --seed 1 --steps 8
    PYTHONPATH=src python scripts/fire_tail_probe.py cv --start phi08 --n 1000 --seed 2 --steps 200
    PYTHONPATH=src python scripts/fire_tail_probe.py restart --n 1000 --seed 3 --steps 40 \\
        --cache CACHE
    PYTHONPATH=src python scripts/fire_tail_probe.py dtmax --n 1000 --seed 1 --steps 40 \\
        --cv-runs 3 --dt-max 0.3 0.4 0.5 0.6
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sps

import jamlab.spheres.aqs.steps as steps_module
import jamlab.spheres.newton_relax as relax_module
from jamlab.spheres.aqs import shear
from jamlab.spheres.aqs.linalg import cholesky
from jamlab.spheres.aqs.network import backbone_mask, contact_list
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.packing import jam, prepare
from jamlab.spheres.potential import Packing, evaluate, hessian

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_pressure.py"
FTOL = 1e-12


def network(packing: Packing) -> tuple[int, int]:
    """``(backbone particles, contacts between them)``."""
    ci, cj, _ = contact_list(packing, NeighborList(packing, skin=RELAX_SKIN))
    bb = backbone_mask(ci, cj, packing.n, packing.dim)
    return int(bb.sum()), int(np.count_nonzero(bb[ci] & bb[cj]))


def newton_finish(loose: Packing) -> tuple[bool, float]:
    """The relaxer's Newton from ``loose`` as its own parent: accepted?, CPU s."""
    relaxer = relax_module.NewtonRelaxer(finish_below=None)
    t = time.process_time()
    out = relaxer.newton_only(loose, FTOL, 1_000_000, None, loose)
    return bool(out.converged), time.process_time() - t


def levenberg_marquardt(start: Packing, max_factorisations: int = 300, mu: float = 1e-6):
    """Module docstring: ``(minimum or last point, factorisations, converged)``."""
    x = start
    ev = evaluate(x)
    e, f, fmax = ev.energy, ev.forces, ev.max_force
    for made in range(max_factorisations):
        if fmax < FTOL:
            return x, made, True
        h = hessian(x)
        chol = cholesky((h + mu * sps.identity(h.shape[0], format="csr")).tocsc(), natural=False)
        if chol is None:
            mu *= 10
            continue
        trial = x.with_positions(x.positions + chol.solve(f.ravel()).reshape(f.shape))
        ev = evaluate(trial)
        tiny = 1e-15 * abs(e)
        if ev.energy < e - tiny or (ev.energy <= e + tiny and ev.max_force < fmax):
            x, e, f, fmax = trial, ev.energy, ev.forces, ev.max_force
            mu = max(mu / 10, 1e-14)
        else:
            mu *= 10
    return x, max_factorisations, fmax < FTOL


def fire_starts(packing: Packing, steps: int, dgamma: float) -> list[Packing]:
    """The starts of the stepper's FIRE runs in ``steps`` steps of constant-volume AQS (``shear``,
    the default path) from ``packing``."""
    starts: list[Packing] = []
    fire = steps_module.minimize

    def caught(start, ftol, max_iter, params=None, neighbors=None, **kw):
        starts.append(start)
        return fire(start, ftol, max_iter, params, neighbors=neighbors, **kw)

    steps_module.minimize = caught
    try:
        shear(packing, dgamma, n_steps=steps)
    finally:
        steps_module.minimize = fire
    return starts


def cv(a: argparse.Namespace) -> None:
    if a.start == "jam":
        packing = jam(a.n, 3, seed=a.seed, p_target=a.p_start).packing
    else:
        packing = prepare(a.n, 3, 0.8, seed=a.seed).packing
    starts = fire_starts(packing, a.steps, a.dgamma)
    print(f"{a.start} N={a.n} seed={a.seed}: {len(starts)} FIRE runs in {a.steps} steps")
    totals = {"fire": 0.0, "hybrid": 0.0}
    for k, start in enumerate(starts):
        t = time.process_time()
        full = minimize(start, FTOL, 1_000_000, skin=RELAX_SKIN)
        t_full = time.process_time() - t
        bb, nc = network(full.packing)
        print(f"  run {k}: FIRE {full.iterations:,} its {t_full:.3f} s, E {full.energy:.4e}; "
              f"its minimum: backbone {bb}, contacts {nc} (isostatic {a_iso(bb)})")
        best = t_full
        for level in a.loose:
            t = time.process_time()
            loose = minimize(start, level, 1_000_000, skin=RELAX_SKIN)
            t_loose = time.process_time() - t
            ok, t_newton = newton_finish(loose.packing)
            bb, nc = network(loose.packing)
            if ok:
                best = min(best, t_loose + t_newton)
            share = loose.iterations / max(full.iterations, 1)
            print(f"     to {level:g}: {loose.iterations:,} its ({share:.0%}), "
                  f"E {loose.energy:.4e}, backbone {bb}, contacts {nc} (isostatic "
                  f"{a_iso(bb)}); Newton finish {'accepted' if ok else 'refused'} "
                  f"({t_newton:.3f} s)")
        totals["fire"] += t_full
        totals["hybrid"] += best
        if k < a.lm:
            t = time.process_time()
            y, made, ok = levenberg_marquardt(loose.packing)
            ey = evaluate(y)
            print(f"     Levenberg-Marquardt from {a.loose[-1]:g}: {made} factorisations, "
                  f"{time.process_time() - t:.2f} s, converged {ok}, max|F| {ey.max_force:.1e}, "
                  f"E - E_FIRE = {(ey.energy - full.energy) / full.energy:+.1e} relative")
    print(f"FIRE to 1e-12: {totals['fire']:.2f} s; best accepted hybrid per run (or FIRE): "
          f"{totals['hybrid']:.2f} s")


def a_iso(backbone: int) -> int:
    """Contacts an isostatic backbone of that many particles has in d = 3: 3 (n − 1)."""
    return 3 * (backbone - 1)


def restart(a: argparse.Namespace) -> None:
    import jamlab.spheres.pressure_shear as ps

    spec = importlib.util.spec_from_file_location("bench_pressure", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    packing = bench.start(a.n, a.pressure, a.seed, a.cache)
    last: dict = {}
    damped = relax_module.damped_newton

    def watched(start, *args, **kw):
        out = damped(start, *args, **kw)
        last.update(start=start, end=out.packing, ok=out.ok, reason=out.reason)
        return out

    attempt = relax_module.NewtonRelaxer._attempt
    rows: list[tuple] = []

    def attempted(self, packing, ftol, max_iter, params, parent, t0):
        last.clear()
        out = attempt(self, packing, ftol, max_iter, params, parent, t0)
        if (out is None or not out.converged) and last.get("ok") is False \
                and packing is not parent:
            runs = [minimize(p, FTOL, 1_000_000, params, skin=RELAX_SKIN)
                    for p in (packing, last["start"], last["end"])]
            e0 = runs[0].energy
            shift = [float(np.max(np.abs(r.packing.box.minimum_image(
                r.packing.positions - runs[0].packing.positions)))) for r in runs[1:]]
            rows.append((last["reason"], *(r.iterations for r in runs),
                         *((r.energy - e0) / abs(e0) for r in runs[1:]), *shift))
        return out

    relax_module.damped_newton = watched
    relax_module.NewtonRelaxer._attempt = attempted
    try:
        ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps)
    finally:
        relax_module.damped_newton = damped
        relax_module.NewtonRelaxer._attempt = attempt
    print(f"N={a.n} p={a.pressure:g} seed={a.seed}, {a.steps} steps: {len(rows)} inner problems "
          "where Newton failed; FIRE iterations from the start / from the failed iteration's "
          "start / from where it stopped; relative energy and largest displacement of the "
          "latter two minima against the first")
    for row in rows:
        print(f"  {row[0][:40]:40s} {row[1]:6d} {row[2]:6d} {row[3]:6d}   dE {row[4]:+.1e} "
              f"{row[5]:+.1e}   dx {row[6]:.1e} {row[7]:.1e}")
    its = np.array([r[1:4] for r in rows], dtype=float)
    if rows:
        print(f"total iterations: {its[:, 0].sum():,.0f} / {its[:, 1].sum():,.0f} / "
              f"{its[:, 2].sum():,.0f}")


def dtmax(a: argparse.Namespace) -> None:
    import fire_fallback_probe

    groups = {
        "fixed pressure, the relaxer's FIRE fallbacks": [
            start for start, _ in
            fire_fallback_probe.collect(a.n, 1e-4, a.dgamma, a.steps, a.seed)],
        "constant volume at jamming": fire_starts(
            jam(a.n, 3, seed=a.seed, p_target=1e-7).packing, a.cv_runs, a.dgamma)[:a.cv_runs],
    }
    for name, starts in groups.items():
        print(f"{name}: {len(starts)} starts (N = {a.n}, seed {a.seed})")
        first = None
        for value in a.dt_max:
            params = FireParameters(dt_max=value)
            t = time.process_time()
            runs = [minimize(s, FTOL, a.max_iter, params, skin=RELAX_SKIN) for s in starts]
            cpu = time.process_time() - t
            first = runs if first is None else first
            pairs = list(zip(runs, first, strict=True))
            de = max(abs(r.energy - f.energy) / abs(f.energy) for r, f in pairs)
            dx = max(float(np.max(np.abs(r.packing.box.minimum_image(
                r.packing.positions - f.packing.positions)))) for r, f in pairs)
            its = sum(r.iterations for r in runs)
            print(f"  dt_max {value:g}: {its:,} iterations, {cpu:.2f} s, "
                  f"converged {sum(r.converged for r in runs)}/{len(runs)}; against dt_max "
                  f"{a.dt_max[0]:g}: energy {de:.1e} relative, positions {dx:.1e}", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    c = sub.add_parser("cv")
    c.add_argument("--start", choices=("jam", "phi08"), default="jam")
    c.add_argument("--p-start", type=float, default=1e-7,
                   help="the jammed start's pressure (--start jam)")
    c.add_argument("--n", type=int, default=1000)
    c.add_argument("--seed", type=int, default=1)
    c.add_argument("--steps", type=int, default=8)
    c.add_argument("--dgamma", type=float, default=1e-5)
    c.add_argument("--loose", type=float, nargs="+", default=[1e-8, 1e-9, 1e-10])
    c.add_argument("--lm", type=int, default=0, metavar="K")
    r = sub.add_parser("restart")
    r.add_argument("--n", type=int, default=1000)
    r.add_argument("--seed", type=int, default=3)
    r.add_argument("--steps", type=int, default=40)
    r.add_argument("--pressure", type=float, default=1e-4)
    r.add_argument("--dgamma", type=float, default=1e-5)
    r.add_argument("--cache", type=Path, default=Path("bench_pressure_cache"))
    t = sub.add_parser("dtmax")
    t.add_argument("--n", type=int, default=1000)
    t.add_argument("--seed", type=int, default=1)
    t.add_argument("--steps", type=int, default=40)
    t.add_argument("--cv-runs", type=int, default=3)
    t.add_argument("--dgamma", type=float, default=1e-5)
    t.add_argument("--dt-max", type=float, nargs="+", default=[0.3, 0.4, 0.5, 0.6])
    t.add_argument("--max-iter", type=int, default=2_000_000)
    a = ap.parse_args(argv)
    {"cv": cv, "restart": restart, "dtmax": dtmax}[a.command](a)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
