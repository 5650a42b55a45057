"""How much of an avalanche's size at fixed pressure is the box's relaxation? Per run, the share
``c / S`` of the counted avalanches, where ``c = ½ K ΔV² / V`` is what the box gives back.

At fixed pressure an avalanche's size is ``S = −ΔH`` (docs/aqs.md). An event that changes the
volume its particles want by ``ΔV`` would, at fixed volume, change the pressure by
``−K ΔV / V``; letting the box follow releases a further ``½ K ΔV² / V`` (``K`` the relaxed
bulk modulus). For an event of given local size that share falls as ``1/V``, so it would make
small avalanches larger in small boxes — one candidate for what thins the smallest avalanches
per particle as N grows at p = 1e-4 (docs/reproduce.md, "What thins the lowest
half-decade"). ``ΔV`` of a counted step is read from the trace's φ (``row_volumes``; the
step's own elastic dilatancy is in it too, so ``c`` is an upper estimate of the box's share).

``K`` is measured on the run's first finished sample: its prepared packing brought to the
run's pressure ``p`` by :func:`jamlab.spheres.barostat.minimize_enthalpy`, then minimised at
``p (1 ± --dp)``: ``K = −Δp / Δ ln V`` (one packing; K of harmonic spheres near jamming varies
little between packings).

Prints per run: N, p, K, and for the counted avalanches (the report's rule,
:func:`jamlab.reproduce.ensembles.counted_steps`) in the band ``--band LO HI`` and below it
(from ``--floor`` to ``LO``): the count, the median and 90 % quantile of ``c / S``, and how many
of the band's avalanches would fall below ``LO`` if ``c`` were taken off their size.

    PYTHONPATH=src python scripts/box_share.py data/runs/n250-p1e-4-vg \\
        data/runs/n2000-p1e-4-vg --band 9.85e-9 3e-8 --floor 1e-9
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def bulk_modulus(packing, pressure: float, dp: float) -> tuple[float, float]:
    """``(K, p)``: ``−Δp / Δ ln V`` from enthalpy minima at ``p (1 ± dp)``, after bringing
    ``packing`` to ``pressure`` (the pressure reached there is returned as ``p``)."""
    from jamlab.spheres.barostat import minimize_enthalpy

    def at(target, start):
        res = minimize_enthalpy(start, target, ftol=1e-13, ptol=1e-9)
        if not res.converged:
            raise RuntimeError(f"the enthalpy minimisation at p = {target:g} did not converge")
        return res

    base = at(pressure, packing)
    lo, hi = at(pressure * (1 - dp), base.packing), at(pressure * (1 + dp), base.packing)
    dlnv = np.log(hi.packing.box.volume) - np.log(lo.packing.box.volume)
    return float(-(hi.pressure - lo.pressure) / dlnv), float(base.pressure)


def run_shares(run: Path, dp: float) -> dict:
    """N, the study's pressure, K, and per counted avalanche ``S`` and ``c``."""
    from jamlab.reproduce.ensembles import counted_steps, finished, row_volumes
    from jamlab.runs import RunDir, SampleKey, open_run
    from jamlab.runs.load import prepared_packing

    ds = open_run(run)
    study = json.loads(ds.attrs["study"])
    if study.get("pressure") is None:
        print(f"error: {run} is not a fixed-pressure run", file=sys.stderr)
        raise SystemExit(2)
    (n,) = [int(v) for v in np.atleast_1d(ds.N.values)]
    ej, counted = counted_steps(ds, "jamming", n)
    volumes = row_volumes(ds, "jamming", n)
    done = np.flatnonzero(finished(ds, "jamming", n))
    first = RunDir(run).sample_path(SampleKey("jamming", n, int(done[0])))
    k, p = bulk_modulus(prepared_packing(first), float(study["pressure"]), dp)
    before, dv = volumes[:, :-1][counted], np.diff(volumes, axis=1)[counted]
    return {"n": n, "pressure": p, "K": k, "S": -ej[counted], "c": 0.5 * k * dv**2 / before}


def summary(sizes: np.ndarray, share: np.ndarray, lo: float, hi: float, floor: float) -> dict:
    """Counts and quantiles of ``c/S`` in the band ``[lo, hi)`` and in ``[floor, lo)``."""
    out = {}
    masks = {"band": (sizes >= lo) & (sizes < hi), "below": (sizes >= floor) & (sizes < lo)}
    for name, m in masks.items():
        r = share[m] / sizes[m]
        out[name] = {
            "count": int(m.sum()),
            "median": float(np.median(r)) if r.size else float("nan"),
            "q90": float(np.quantile(r, 0.9)) if r.size else float("nan"),
        }
    band = (sizes >= lo) & (sizes < hi)
    out["band"]["leave"] = int(np.count_nonzero(sizes[band] - share[band] < lo))
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--band", nargs=2, type=float, default=[9.85e-9, 3e-8])
    ap.add_argument("--floor", type=float, default=1e-9)
    ap.add_argument("--dp", type=float, default=0.05, help="relative pressure step for K")
    a = ap.parse_args(argv)
    lo, hi = a.band
    if not (0 < a.floor < lo < hi) or not (0 < a.dp < 0.5):
        print("error: need 0 < --floor < band low < band high and 0 < --dp < 0.5", file=sys.stderr)
        raise SystemExit(2)
    for run in a.runs:
        if not (run / "manifest.json").is_file():
            print(f"error: {run} is not a run directory (no manifest.json)", file=sys.stderr)
            raise SystemExit(2)
    print("| run | N | p | K | band: count | c/S median | c/S 90 % | would leave the band "
          "| below: count | c/S median | c/S 90 % |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for run in a.runs:
        r = run_shares(run, a.dp)
        s = summary(r["S"], r["c"], lo, hi, a.floor)
        b, w = s["band"], s["below"]
        print(f"| {run.name} | {r['n']} | {r['pressure']:.3g} | {r['K']:.3f} | {b['count']} "
              f"| {b['median']:.2e} | {b['q90']:.2e} | {b['leave']} | {w['count']} "
              f"| {w['median']:.2e} | {w['q90']:.2e} |")
    raise SystemExit(0)


if __name__ == "__main__":
    main()
