"""The shape of avalanches near jamming: the extent of every counted avalanche at fixed pressure,
against its isotropised reference, per N — the fixed-pressure counterpart of
``scripts/steady_anatomy.py`` (whose tables, figure and result files this script shares).

The packings and protocol of ``scripts/avalanche_anatomy.py --states p<P>`` (and of
``docs/anatomy_pressure``): ``jam(N, 3, seed, p_target=P)`` for seeds ``1 … k``, sheared at
fixed pressure ``P`` (``shear(..., pressure=P)``) for ``--steps`` steps of ``--dgamma``, with
``keep_avalanches=True, avalanche_threshold=0`` (every moved particle recorded); the minima
before the plastic steps (``shear``'s ``on_plastic``) give the positions for the isotropised
reference (``steady_anatomy.isotropised``, which checks the extent it recomputes against the
recorded one to 1e-12). Counted: plastic steps between two jammed minima with ``S = −ΔH > 0``.

Printed (``steady_anatomy``'s tables): per N the participation and contacts changed, per decade
of ``S`` their medians, the shapes (``r1/L``, ``r2/r1``, ``r3/r1`` against the isotropised
reference, the thin axis's direction), the orientation tensor of the thin and long axes, and
per decade of ``S`` the radii. ``--check FILE``
compares each sample's counted sizes with the same (N, seed) rows of an ``avalanche_anatomy.py``
``events.npz`` (the committed ``docs/anatomy_pressure/p*/events.npz``), bit for bit.

    PYTHONPATH=src python scripts/pressure_shape.py --pressure 1e-4 --n 250 500 1000 \\
        --samples 40 20 10 --workers 2 --out data/anatomy/p1e-4.npz \\
        --check docs/anatomy_pressure/p1e-4/events.npz
    PYTHONPATH=src python scripts/pressure_shape.py --load data/anatomy/p1e-4.npz
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

# the tables, the figure, the reference and the result files: one implementation
sys.path.insert(0, str(Path(__file__).resolve().parent))
import steady_anatomy as sa  # noqa: E402

DECADES = (-12, -3)
"""The decades of ``S`` (ε) of the per-decade tables and the figure: ``[1e-12, 1e-3)``."""


def one_sample(job: tuple) -> dict:
    """One packing (``job = (N, P, seed, steps, δγ)``) sheared at fixed pressure with every
    plastic step's record (``avalanche_threshold=0``) and the reference radii."""
    from jamlab.spheres import jam
    from jamlab.spheres.aqs import shear

    n, p, seed, steps, dgamma = job
    t0 = time.process_time()
    before: dict[int, tuple] = {}

    def keep(row, b, a):
        # the recorder's frame: the positions before rescaled to the box after the step
        before[row] = (np.asarray(b.positions) * (a.box.length / b.box.length), a.box.length,
                       b.strain)

    trace = shear(jam(n, 3, seed, p_target=p).packing, dgamma, n_steps=steps, pressure=p,
                  keep_avalanches=True, avalanche_threshold=0.0, on_plastic=keep).trace
    rows = sa.counted_rows(trace)
    out = {"n": n, "seed": seed, "rows": rows, **sa.records(trace),
           "converged": bool(np.all(np.asarray(trace.max_force) < 1e-12)),
           "length": float(np.median(trace.fixed_pressure["box_length"]))}
    fields = list(sa.event_fields(trace, before))  # rebuilt and checked once, used thrice
    out[sa.NULL], out["n_moved"] = sa.isotropised(fields, np.random.default_rng(seed), 3)
    out["long_axis"] = sa.long_axes(fields, 3)
    out["scattered_radii"], out["scattered_null"] = scattered(
        fields, np.random.default_rng([seed, 1]))
    out["cpu"] = time.process_time() - t0
    return out


def scattered(fields: list, rng: np.random.Generator) -> tuple:
    """The control of the reference for box-filling events: each counted avalanche's field
    (``steady_anatomy.event_fields``, a list) with its values moved to a random permutation of the
    packing's particles — the same weights spread over the box with no spatial structure, the
    periodic box and the minimum-image centring kept — and ``(its radii, their isotropised
    reference)``. If the reference is fair to a field that fills the box, the control's shape
    lies at its reference (``Δ3 ≈ 0``)."""
    from jamlab.analysis.anatomy import event_extent, isotropised_radii

    radii, null = [], []
    for u, pos, length, strain in fields:
        moved = u[rng.permutation(u.shape[0])]
        radii.append(event_extent(moved, pos, length, strain)[0])
        null.append(isotropised_radii(moved, pos, length, strain, rng))
    return (np.asarray(radii, dtype=np.float64).reshape(-1, 3),
            np.asarray(null, dtype=np.float64).reshape(-1, 3))


def control(results: list[dict], boot: int) -> None:
    """``steady_anatomy.shape_excess`` of the control (:func:`scattered`), for the samples that
    have it."""
    have = [{**r, "radii": r["scattered_radii"], sa.NULL: r["scattered_null"]}
            for r in results if "scattered_radii" in r]
    if have:
        print("\ncontrol: the same values scattered over the packing's particles (Δ of the "
              "control against its own isotropised reference)")
        sa.shape_excess(have, boot)


def check(results: list[dict], files: list[Path]) -> None:
    """Compare each N's counted avalanches with the same (N, seed) rows of ``files``
    (``avalanche_anatomy.py`` ``events.npz``: rows of plastic steps, counted where ``jammed`` and
    ``S > 0``; made by an earlier code, whose minima differ in the last digits): the counts, the
    (seed, step) pairs counted by both, how many of those sizes agree to 1e-6 relative, and the
    two-sample KS p of the sizes."""
    from scipy import stats

    ref: dict[tuple[int, int], float] = {}
    for f in files:
        with np.load(f) as z:
            ok = z["jammed"].astype(bool) & (z["S"] > 0)
            for n, seed, step, s in zip(z["N"][ok], z["seed"][ok], z["step"][ok], z["S"][ok],
                                        strict=True):
                ref[(int(n), int(seed), int(step))] = float(s)
    print("\n--check against the earlier run: | N | counted here / there | (seed, step) in both | "
          "of those, S within 1e-6 | KS p of S |")
    for n in sorted({r["n"] for r in results}):
        g = [r for r in results if r["n"] == n]
        seeds = {r["seed"] for r in g}
        here = {(n, r["seed"], int(row)): float(s) for r in g
                for row, s in zip(r["rows"], r["S"], strict=True)}
        there = {k: v for k, v in ref.items() if k[0] == n and k[1] in seeds}
        both = here.keys() & there.keys()
        close = sum(abs(here[k] - there[k]) <= 1e-6 * abs(there[k]) for k in both)
        p = (stats.ks_2samp(list(here.values()), list(there.values())).pvalue
             if here and there else float("nan"))
        print(f"| {n} | {len(here)} / {len(there)} | {len(both)} | {close} | {p:.2g} |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--n", type=int, nargs="+", default=[250, 500])
    ap.add_argument("--samples", type=int, nargs="+", default=[40, 20],
                    help="per N (as --n): seeds 1 … k")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--workers", type=int, default=1)
    sa.add_report_arguments(
        ap, 1.2e-8, "the slopes use S ≥ this (ε): the p = 1e-4 comparison floor",
        "avalanche_anatomy.py events.npz files: the counted sizes, same (N, seed)")
    a = ap.parse_args(argv)
    sa.check_report_arguments(ap, a)
    if a.load is not None:
        results = [r for f in a.load for r in sa.load(f)]
        if a.check is not None and any("rows" not in r for r in results):
            ap.error("--check needs the trace rows of the counted avalanches (files of this "
                     "script)")
    else:
        if len(a.samples) != len(a.n):
            ap.error("--samples needs one count per --n")
        if not (a.pressure > 0 and a.dgamma > 0 and a.steps >= 1 and a.workers >= 1
                and min(a.samples) >= 1 and min(a.n) >= 8):
            ap.error("need --pressure, --dgamma > 0, --steps, --workers, --samples >= 1, "
                     "--n >= 8")
        if a.out is not None and a.out.exists():
            ap.error(f"--out {a.out} exists (finished data is never overwritten)")
        jobs = [(n, a.pressure, s, a.steps, a.dgamma)
                for n, k in zip(a.n, a.samples, strict=True) for s in range(1, k + 1)]
        results = sa.steady_unsat.map_jobs(one_sample, jobs, a.workers,
                                           f"p = {a.pressure}, δγ = {a.dgamma}, {a.steps} steps")
        if a.out is not None:
            sa.save(a.out, results)
    sa.report(results, a, *DECADES,
              title="counted avalanches at fixed pressure: event field's extent against size",
              after_shapes=lambda res: control(res, a.boot))
    if a.check is not None:
        check(results, a.check)


if __name__ == "__main__":
    main()
