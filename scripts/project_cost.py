"""Project the cost of the paper's jamming set from measured per-step times.

Input: the JSON of ``benchmarks/bench_jamming.py --json`` (per N: time to jam, time to bring the
packing to p, ms per AQS step for each protocol and code). Per protocol and code, the per-step
time and the per-sample preparation time are fitted as power laws ``t = a N^b`` (least squares
on log t against log N over the measured N; a single N gives b = 1) and evaluated at the
paper's sizes, N = 500, 1000, 2000, 4000 (``--sizes``), 300 samples each (``--samples``), 1000
steps each (``--steps``):

    CPU-h = Σ_N samples × (t_prep(N) + steps × t_step(N)) / 3600.

Targets (issue 18): a 1000-step sample at N = 1000 ≤ 2 min on one core for each protocol; the
paper's set ≤ 500 CPU-h (moonshot ≤ 100). Times measured on a shared machine: indicative; an
extrapolation beyond the measured N says so (``extrapolated``).

    python scripts/project_cost.py jamming_bench.json
    python scripts/project_cost.py --average seed1.json seed2.json   # packings of several seeds

With ``--average`` the files are runs of the same N on different packings (``--seed``): per N,
protocol and code the per-step time, and per N the preparation times, are their means.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

TARGET_SAMPLE_S = 120.0  # one 1000-step sample at N = 1000, one core
TARGET_SET_CPU_H = 500.0
MOONSHOT_CPU_H = 100.0


def power_law(ns: list[int], ts: list[float]) -> tuple[float, float]:
    """``(a, b)`` of ``t = a N^b`` by least squares in log-log (b = 1 for a single point)."""
    x, y = np.log(np.asarray(ns, float)), np.log(np.asarray(ts, float))
    if len(ns) == 1:
        return float(math.exp(y[0] - x[0])), 1.0
    b, log_a = np.polyfit(x, y, 1)
    return float(math.exp(log_a)), float(b)


def project(data: dict, sizes: list[int], samples: int, steps: int) -> list[dict]:
    """One dict per (protocol, code): exponent, sample time at N = 1000, set CPU-hours."""
    results = data["results"]
    ns = [r["N"] for r in results]
    out = []
    for proto, prep_keys in (
        ("constant_volume", ("jam_s",)),
        ("fixed_pressure", ("jam_s", "to_pressure_s")),
    ):
        if not all(proto in r for r in results):
            continue  # (a benchmark of one protocol only)
        codes = sorted({c for r in results for c in r[proto]})
        prep = [sum(r[k] for k in prep_keys) for r in results]
        pa, pb = power_law(ns, [max(p, 1e-3) for p in prep])
        for code in codes:
            step_s = [r[proto][code]["ms_per_step"] / 1e3 for r in results if code in r[proto]]
            a, b = power_law(ns, step_s)

            def sample_s(n: float, a=a, b=b, pa=pa, pb=pb) -> float:
                return pa * n**pb + steps * a * n**b

            cpu_h = sum(samples * sample_s(n) for n in sizes) / 3600.0
            out.append(
                {
                    "protocol": proto,
                    "code": code,
                    "exponent": b,
                    "sample_s_1000": sample_s(1000),
                    "cpu_h": cpu_h,
                    "extrapolated": max(sizes) > max(ns) or min(sizes) < min(ns),
                }
            )
    return out


def average(files: list[dict]) -> dict:
    """One benchmark whose times are the means over ``files`` (same N, p, δγ; packings of
    different seeds): per N the preparation times, per N, protocol and code the ms per step."""
    out = json.loads(json.dumps(files[0]))
    for k, row in enumerate(out["results"]):
        rows = [f["results"][k] for f in files]
        for key in ("jam_s", "to_pressure_s"):
            if all(key in r for r in rows):
                row[key] = float(np.mean([r[key] for r in rows]))
        for proto in ("constant_volume", "fixed_pressure"):
            if proto not in row:
                continue
            if not all(proto in r for r in rows):
                raise SystemExit(f"--average: not every file has the {proto} protocol")
            for code, cell in row[proto].items():
                if not all(code in r[proto] for r in rows):
                    raise SystemExit(f"--average: not every file has {proto} / {code}")
                cell["ms_per_step"] = float(np.mean([r[proto][code]["ms_per_step"] for r in rows]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bench_json", type=Path, nargs="+",
                    help="one or more benchmark JSONs with the same N: a protocol is taken from "
                    "the last file that has it (e.g. an older full run and a newer "
                    "--fixed-pressure-only run)")
    ap.add_argument("--average", action="store_true",
                    help="the files are the same benchmark on packings of different seeds: "
                    "average their times per N (otherwise later files override earlier ones)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[500, 1000, 2000, 4000])
    ap.add_argument("--samples", type=int, default=300)
    ap.add_argument("--steps", type=int, default=1000)
    args = ap.parse_args()
    files = [json.loads(f.read_text()) for f in args.bench_json]
    data = files[0]
    for other in files[1:]:
        if [r["N"] for r in other["results"]] != [r["N"] for r in data["results"]]:
            raise SystemExit("the benchmark files measure different N")
        if other["pressure"] != data["pressure"] or other["dgamma"] != data["dgamma"]:
            raise SystemExit("the benchmark files use different p or dgamma")
    if args.average:
        data = average(files)
    else:
        for other in files[1:]:
            for mine, theirs in zip(data["results"], other["results"], strict=True):
                mine.update(
                    {k: v for k, v in theirs.items() if k != "jam_s" or "jam_s" not in mine}
                )
    rows = project(data, args.sizes, args.samples, args.steps)
    ns = [r["N"] for r in data["results"]]
    print(
        f"measured N = {ns}; projected N = {args.sizes} × {args.samples} samples × "
        f"{args.steps} steps (p = {data['pressure']:g} at fixed pressure)"
    )
    print()
    print(
        "| protocol | code | t_step ∝ N^b | 1000-step sample at N=1000 | ≤ 2 min? "
        "| paper's set (CPU-h) | ≤ 500? | ≤ 100? |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        ok_s = "yes" if r["sample_s_1000"] <= TARGET_SAMPLE_S else "no"
        ok_h = "yes" if r["cpu_h"] <= TARGET_SET_CPU_H else "no"
        ok_m = "yes" if r["cpu_h"] <= MOONSHOT_CPU_H else "no"
        ext = " (extrapolated)" if r["extrapolated"] else ""
        print(
            f"| {r['protocol'].replace('_', ' ')} | {r['code']} | b = {r['exponent']:.2f} | "
            f"{r['sample_s_1000'] / 60:,.1f} min | {ok_s} | {r['cpu_h']:,.0f}{ext} | {ok_h} "
            f"| {ok_m} |"
        )


if __name__ == "__main__":
    main()
