"""The plastic flag's confirmation, candidate by candidate: its verdict, and the enthalpy the step
released for certain (``docs/aqs.md``, "jumps the chain missed, and candidates that need no
confirmation").

For each packing of ``benchmarks/bench_pressure.py``'s cache (``jam(N, 3, seed, p_target=min(p,
1e-4))`` brought to ``p``; made there if missing), ``shear_at_pressure`` with every candidate that
can be plastic redone (``confirm_below=math.inf``). A candidate is redone when its residual passes
the run's threshold between two jammed minima and Newton did not continue it; its verdict is
``confirmed`` (True: a jump). Printed per candidate the confirmation called a kink: its residual
``r_n`` in units of ``δγ²`` and of the threshold, and the lower bound of the enthalpy it released,
:func:`jamlab.spheres.confirm.released_at_least`, in units of ``max(threshold, δγ²)``
(the scale of ``confirm_below``). Per case: the candidates redone, the kinks, the largest bound
of a kink, and how many candidates ``confirm_below = 2, 3, 5`` would not redo. ``--json`` keeps
every redone candidate.

    PYTHONPATH=src python scripts/confirm_verdicts.py --n 1000 --pressure 1e-4 --dgamma 1e-5 \
        --steps 300 --seeds 1 2 --cache CACHE
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import time
from pathlib import Path

import numpy as np

from jamlab.analysis.avalanches import branch_residual, jammed_steps, noise_floor
from jamlab.spheres.confirm import released_at_least
from jamlab.spheres.pressure_shear import shear_at_pressure

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_pressure.py"
BANDS = (2.0, 3.0, 5.0)


def redone_candidates(res, dgamma: float) -> list[dict]:
    """Per candidate the full confirmation redid: step, ``r_n``, threshold, the bound and the
    verdict (from the result's public columns, ``threshold``, ``continued`` and ``confirmed``)."""
    g, h, s = res["gamma"], res["enthalpy_jump"], res["stress_jump"]
    steps = np.diff(g)
    resid = branch_residual(h[1:], s[1:], steps)
    thr = res.threshold
    modulus = noise_floor(h[1:], s[1:], steps, jammed=res["jammed"]).modulus
    least = released_at_least(resid, s[1:], steps, modulus)
    redone = jammed_steps(res["jammed"]) & (np.abs(resid) > thr) & ~res.continued[1:]
    scale = max(thr, dgamma**2)
    return [{"step": int(i + 1), "r": float(resid[i]), "threshold": float(thr),
             "scale": float(scale), "least": float(least[i]),
             "jump": bool(res.confirmed[i + 1])} for i in np.flatnonzero(redone)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--pressure", type=float, required=True)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--cache", type=Path, default=Path("bench_pressure_cache"))
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.json is not None and a.json.exists():
        ap.error(f"{a.json} exists; not overwriting it")
    spec = importlib.util.spec_from_file_location("bench_pressure", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    rows: list[dict] = []
    for seed in a.seeds:
        packing = bench.start(a.n, a.pressure, seed, a.cache)
        t = time.process_time()
        res = shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                                confirm_below=math.inf)
        cpu = time.process_time() - t
        cands = redone_candidates(res, a.dgamma)
        kinks = [c for c in cands if not c["jump"]]
        print(f"N={a.n} p={a.pressure:g} dgamma={a.dgamma:g} seed={seed}: {cpu:.1f} CPU s, "
              f"threshold {res.threshold / a.dgamma**2:.2f} dgamma^2, {len(cands)} redone, "
              f"{len(kinks)} kinks, {int(res['plastic'].sum())} plastic", flush=True)
        for c in kinks:
            print(f"   kink at step {c['step']}: r = {c['r'] / a.dgamma**2:+.3f} dgamma^2 = "
                  f"{c['r'] / c['threshold']:+.2f} threshold; released at least "
                  f"{c['least'] / c['scale']:+.2f} max(threshold, dgamma^2)")
        rows += [{"N": a.n, "p": a.pressure, "dgamma": a.dgamma, "seed": seed, **c}
                 for c in cands]
    kinks = [c for c in rows if not c["jump"]]
    largest = max((c["least"] / c["scale"] for c in kinks), default=math.nan)
    spared = " / ".join(str(sum(c["least"] > k * c["scale"] for c in rows)) for k in BANDS)
    bands = " / ".join(f"{k:g}" for k in BANDS)
    print(f"\n| N | p | δγ | runs | redone | kinks | largest bound of a kink / max(thr, δγ²) | "
          f"not redone at K = {bands} |\n|---|---|---|---|---|---|---|---|")
    print(f"| {a.n} | {a.pressure:g} | {a.dgamma:g} | {len(a.seeds)} | {len(rows)} | {len(kinks)} "
          f"| {largest:.2f} | {spared} |")
    if a.json is not None:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
