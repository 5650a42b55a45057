"""Cost of the report's criticality section beside the analysis it joins, on finished runs.

Usage: ``PYTHONPATH=src python benchmarks/bench_reproduce_criticality.py RUNS [--scale quick]``
with ``RUNS`` the run directories of a finished ``jamlab reproduce`` (``OUT/runs``). Prints CPU
and wall seconds of the τ fits (the existing avalanche analysis, for scale), the packing
exponents, the finite-size scaling and the two figures, side by side, and the section's share.
Nothing is run and nothing under ``RUNS`` is written (figures go to a temporary directory).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from jamlab.reproduce import figures
from jamlab.reproduce.criticality import finite_size_scaling, packing_criticality
from jamlab.reproduce.ensembles import RunSet
from jamlab.reproduce.measurements import tau_estimates
from jamlab.reproduce.scales import get_scale


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", type=Path)
    ap.add_argument("--scale", default="quick")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        scale, runs = get_scale(args.scale), RunSet(args.runs)
        runs["jamming"], runs["unsat"]  # opened before the clocks start
        r: dict[str, object] = {}
        steps = {
            "τ fits (existing part)": lambda: r.setdefault(
                "tau", tau_estimates(runs["jamming"], runs["unsat"], scale)),
            "packing exponents": lambda: r.setdefault(
                "crit", packing_criticality(runs["jamming"], runs.path / "jamming", scale)),
            "finite-size scaling": lambda: r.setdefault(
                "fss", finite_size_scaling(runs["jamming"], runs["unsat"], r["tau"], scale)),
            "figure criticality.png": lambda: figures.criticality(r["crit"], out),
            "figure finite_size.png": lambda: figures.finite_size(r["fss"], out),
        }
        rows = []
        for name, step in steps.items():
            t, w = time.process_time(), time.perf_counter()
            step()
            rows.append((name, time.process_time() - t, time.perf_counter() - w))
    print(f"{'step':28s} {'CPU s':>8s} {'wall s':>8s}")
    for name, cpu, wall in rows:
        print(f"{name:28s} {cpu:8.2f} {wall:8.2f}")
    section = sum(r[1] for r in rows[1:])
    print(f"criticality section: {section:.2f} s CPU = {section / rows[0][1]:.2f} × the τ fits")


if __name__ == "__main__":
    main()
