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

With ``--runs`` (finished ensemble run directories of ``jamlab run``, e.g. ``--phi jamming
--pressure 1e-4 --n 1000 --gamma-max 0.01 --dgamma 1e-5``): at each N such a directory holds, the
sample time of the default path (``jamlab``) is the mean stored time of its finished samples —
preparation and every step of a whole sample, deferred confirmations included — instead of the
fit's value there; the fit still gives the other N. The run must match the benchmark's protocol,
p, δγ and ``--steps``; the time of a sample is its ``cpu_seconds`` where every finished sample
stored one, else ``seconds``, the worker's wall time (≈ CPU time with one worker per core and
nothing else running).

    python scripts/project_cost.py --average S1.json S2.json --runs RUNS/n1000-p1e-4

With ``--fit-runs`` as well, where the runs hold two N or more for a protocol, the default path's
sample time at every other N is a power law ``t = a N^b`` fitted to the runs' mean sample times
(the exponent printed is then that of a whole sample) instead of the benchmark's fit. For the
constant-volume protocol at jamming the benchmark's few steps are not typical of a sample: the
shear unjams the packing or raises its pressure by decades, and the cost per step changes with
it (``benchmarks/bench_cv_sample.py``).

With ``--cv-samples`` (JSONs of ``benchmarks/bench_cv_sample.py --json``: whole constant-volume
samples of the benchmark's packings, jam + 1000 steps, CPU time), their mean per N counts as a
run's at that N (for ``--fit-runs`` too); a sample stopped at its ``--budget`` counts with the
time it had spent, and the row says the projection is then a lower bound.

With ``--per-step`` (JSONs of ``benchmarks/bench_pressure.py --json``, e.g. 100 steps at N = 2000
and 4000): at each N they hold (and no run does), the default path's time per step is their
measured CPU time per step (deferred confirmations included; the mean over their packings)
instead of the fit's; the preparation is still the fit's.

Without a benchmark JSON (``--runs`` alone, of one protocol, p, δγ and number of steps, at two N
or more), the sample time at every N without a run is the power law through the runs' mean
sample times, as with ``--fit-runs``; ``--sizes`` and ``--samples`` then name the set to price,
e.g. 20 more samples at N = 2000 of the ensembles at p = 1e-6:

    python scripts/project_cost.py --runs RUNS/n250-p1e-6 RUNS/n500-p1e-6 RUNS/n1000-p1e-6 \\
        --sizes 2000 --samples 20
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

TARGET_SAMPLE_S = 120.0  # one 1000-step sample at N = 1000, one core
TARGET_SET_CPU_H = 500.0
MOONSHOT_CPU_H = 100.0


def fail(message: str) -> None:
    """Bad input: one line on stderr, exit code 2."""
    print(f"project_cost.py: {message}", file=sys.stderr)
    raise SystemExit(2)


def power_law(ns: list[int], ts: list[float]) -> tuple[float, float]:
    """``(a, b)`` of ``t = a N^b`` by least squares in log-log (b = 1 for a single point)."""
    x, y = np.log(np.asarray(ns, float)), np.log(np.asarray(ts, float))
    if len(ns) == 1:
        return float(math.exp(y[0] - x[0])), 1.0
    b, log_a = np.polyfit(x, y, 1)
    return float(math.exp(log_a)), float(b)


def same_conditions(path: Path, pressure: float | None, dgamma: float, data: dict) -> None:
    """Fail unless a measurement from ``path`` ran at the benchmark's p (``None``: constant
    volume, no p to compare) and δγ."""
    if pressure is not None and not math.isclose(pressure, data["pressure"]):
        fail(f"{path}: p = {pressure:g}, the benchmark's is {data['pressure']:g}")
    if not math.isclose(dgamma, data["dgamma"]):
        fail(f"{path}: dgamma = {dgamma:g}, the benchmark's is {data['dgamma']:g}")


def measured_samples(runs: list[Path], data: dict, steps: int) -> dict[str, dict[int, float]]:
    """``{protocol: {N: mean seconds per finished sample}}`` of the run directories ``runs``
    (each checked against the benchmark's p, δγ and ``steps``)."""
    from jamlab.runs import open_run  # (only here: the script runs without jamlab otherwise)

    out: dict[str, dict[int, float]] = {}
    for path in runs:
        try:
            ds = open_run(path)
        except (OSError, ValueError) as err:
            fail(f"{path}: not a run directory ({err})")
        study = json.loads(ds.attrs["study"])
        proto = "constant_volume" if study.get("pressure") is None else "fixed_pressure"
        same_conditions(path, study.get("pressure"), study["dgamma"], data)
        n_steps = round(study["gamma_max"] / study["dgamma"])
        if n_steps != steps:
            fail(f"{path}: {n_steps} steps per sample, the projection's are {steps}")
        for n in ds.N.values:
            sel = ds.sel(N=n)
            done = (sel.status.values == "done").ravel()
            # CPU time where every finished sample stored it (wall time is inflated by
            # anything else running on the machine), else the worker's wall time
            cpu = (np.asarray(sel.cpu_seconds.values, dtype=float).ravel()[done]
                   if "cpu_seconds" in sel else np.empty(0))
            if cpu.size and np.isfinite(cpu).all():
                secs, what = cpu, "CPU"
            else:
                secs, what = np.asarray(sel.seconds.values, dtype=float).ravel()[done], "wall"
            if secs.size:
                out.setdefault(proto, {})[int(n)] = float(secs.mean())
                print(f"{path}: N = {int(n)}, {secs.size} finished samples, {secs.mean():.0f} "
                      f"{what} s each on average ({secs.min():.0f}–{secs.max():.0f})")
    return out


def json_file(path: Path) -> dict:
    """A benchmark JSON (``benchmarks/bench_jamming.py --json``; bad input: one line, exit 2)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        fail(f"{path}: not a benchmarks/bench_jamming.py --json file ({err})")
    missing = [k for k in ("results", "pressure", "dgamma") if not isinstance(data, dict)
               or k not in data]
    if missing:
        fail(f"{path}: not a benchmarks/bench_jamming.py --json file (no {', '.join(missing)})")
    return data


def json_list(path: Path, key: str, producer: str) -> list[dict]:
    """The list ``key`` of the JSON file ``path`` written by ``producer --json`` (bad input: one
    line, exit code 2)."""
    try:
        return json.loads(path.read_text())[key]
    except (OSError, ValueError, KeyError) as err:
        fail(f"{path}: not a {producer} --json file ({err})")


def measured_cv_samples(files: list[Path], data: dict,
                        steps: int) -> tuple[dict[int, float], set[int]]:
    """``({N: mean CPU seconds per sample}, {N where a sample was stopped})`` of the whole
    constant-volume samples in the JSONs of ``benchmarks/bench_cv_sample.py --json`` (jam and
    shear, each checked against the benchmark's δγ and ``steps``). A sample stopped at its
    ``--budget`` counts with the time it had spent: the mean there is a lower bound."""
    per_n: dict[int, list[float]] = {}
    stopped: set[int] = set()
    for path in files:
        for smp in json_list(path, "samples", "benchmarks/bench_cv_sample.py"):
            same_conditions(path, None, smp["dgamma"], data)
            if smp["steps"] != steps:
                fail(f"{path}: {smp['steps']} steps per sample, the projection's are {steps}")
            n, cpu = int(smp["N"]), smp["jam_cpu_s"] + smp["shear_cpu_s"]
            per_n.setdefault(n, []).append(cpu)
            cut = smp["steps_done"] < steps
            if cut:
                stopped.add(n)
            print(f"{path}: N = {n}, seed {smp['seed']} ({smp.get('floppy', 'fire')}): "
                  f"{cpu:.0f} CPU s"
                  + (f", stopped after {smp['steps_done']} steps" if cut else ""))
    return {n: float(np.mean(ts)) for n, ts in per_n.items()}, stopped


def measured_steps(files: list[Path], data: dict) -> dict[int, float]:
    """``{N: mean CPU seconds per step}`` of the default path (variant ``newton``) in the JSONs
    of ``benchmarks/bench_pressure.py --json`` (cases at the benchmark's p and δγ; the mean over
    their seeds)."""
    per_n: dict[int, list[float]] = {}
    for path in files:
        for case in json_list(path, "cases", "benchmarks/bench_pressure.py"):
            if "newton" not in case["variants"]:
                continue
            same_conditions(path, case["pressure"], case["dgamma"], data)
            per_n.setdefault(int(case["N"]), []).append(
                case["variants"]["newton"]["ms_per_step"] / 1e3)
    for n, ts in sorted(per_n.items()):
        print(f"per-step time measured at N = {n}: {np.mean(ts):.3f} s ({len(ts)} packings)")
    return {n: float(np.mean(ts)) for n, ts in per_n.items()}


def project(data: dict, sizes: list[int], samples: int, steps: int,
            measured: dict[str, dict[int, float]] | None = None,
            measured_step: dict[int, float] | None = None,
            fit_runs: bool = False) -> list[dict]:
    """One dict per (protocol, code): exponent, sample time at N = 1000, set CPU-hours.
    ``measured``: per protocol, measured seconds per whole sample at some N, taken for the
    default path (``jamlab``) there instead of the fit; ``measured_step``: at fixed pressure,
    measured seconds per step of the default path at some N (the preparation still from the
    fit), where no whole sample was measured. ``fit_runs``: where ``measured`` holds two N or
    more for a protocol, the default path's samples at the other N come from ``t = a N^b``
    fitted to the measured samples (its ``b`` reported) instead of the benchmark's fit."""
    measured = measured or {}
    measured_step = measured_step or {}
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
            # (a code timed at some N only is fitted over those)
            code_ns = [r["N"] for r in results if code in r[proto]]
            step_s = [r[proto][code]["ms_per_step"] / 1e3 for r in results if code in r[proto]]
            a, b = power_law(code_ns, step_s)

            known = measured.get(proto, {}) if code == "jamlab" else {}
            stepped = measured_step if (code == "jamlab" and proto == "fixed_pressure") else {}
            whole = None  # (a, b) of the whole samples measured, with fit_runs
            if fit_runs and len(known) >= 2:
                whole = power_law(sorted(known), [known[n] for n in sorted(known)])
                b, code_ns = whole[1], sorted(known)

            def sample_s(n: float, a=a, b=b, pa=pa, pb=pb, known=known, stepped=stepped,
                         whole=whole) -> float:
                if n in known:
                    return known[n]
                if whole is not None:
                    return whole[0] * n ** whole[1]
                return pa * n**pb + steps * stepped.get(n, a * n**b)

            out.append(projection_row(proto, code, b, sample_s, sizes, samples, code_ns, known,
                                      stepped, whole is not None))
    return out


def projection_row(proto: str, code: str, exponent: float, sample_s, sizes: list[int],
                   samples: int, fitted_ns: list[int], known: dict[int, float],
                   stepped: dict[int, float], fitted_to_runs: bool) -> dict:
    """One row of the projection: ``sample_s(N)`` the seconds of one sample at N, priced over
    ``sizes`` × ``samples``; ``fitted_ns`` the N the law was fitted at (beyond them:
    extrapolated); ``known`` / ``stepped`` the N with measured samples / steps."""
    return {
        "protocol": proto,
        "code": code,
        "exponent": exponent,
        "sample_s_1000": sample_s(1000),
        "cpu_h": sum(samples * sample_s(n) for n in sizes) / 3600.0,
        "extrapolated": max(sizes) > max(fitted_ns) or min(sizes) < min(fitted_ns),
        "measured_n": sorted(n for n in known if n in sizes),
        "measured_step_n": sorted(n for n in stepped if n in sizes and n not in known),
        "fitted_to_runs": fitted_to_runs,
    }


def run_conditions(runs: list[Path]) -> dict:
    """The p (None at constant volume) and δγ of the first of ``runs``, as a benchmark's
    ``{"pressure", "dgamma", "results": []}`` for the checks of :func:`measured_samples`; every
    run must share its protocol (bad input: one line, exit code 2)."""
    from jamlab.runs import RunDir, RunError

    studies = []
    for path in runs:
        try:
            studies.append(RunDir(path).study())  # (the manifest only: no sample is read)
        except RunError as err:
            fail(f"{path}: not a run directory ({err})")
    if len({st.pressure is None for st in studies}) > 1:
        fail("the runs mix constant volume and fixed pressure: project one protocol at a time")
    return {"pressure": studies[0].pressure, "dgamma": studies[0].dgamma, "results": []}


def project_measured(measured: dict[str, dict[int, float]], sizes: list[int],
                     samples: int) -> list[dict]:
    """Without a benchmark: per protocol, the rows of :func:`project` from the whole samples
    ``measured`` alone (``{protocol: {N: mean seconds per sample}}``, two N or more): at a
    measured N its mean, elsewhere ``t = a N^b`` through them."""
    out = []
    for proto, known in measured.items():
        if len(known) < 2:
            fail(f"{proto.replace('_', ' ')}: whole samples at N = {sorted(known)} only; "
                 "without a benchmark the projection needs runs at two N or more")
        ns = sorted(known)
        a, b = power_law(ns, [known[n] for n in ns])

        def sample_s(n: float, a=a, b=b, known=known) -> float:
            return known[n] if n in known else a * n**b

        out.append(projection_row(proto, "jamlab", b, sample_s, sizes, samples, ns, known, {},
                                  True))
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
                fail(f"--average: not every file has the {proto} protocol")
            for code, cell in row[proto].items():
                if not all(code in r[proto] for r in rows):
                    fail(f"--average: not every file has {proto} / {code}")
                cell["ms_per_step"] = float(np.mean([r[proto][code]["ms_per_step"] for r in rows]))
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bench_json", type=Path, nargs="*",
                    help="one or more benchmark JSONs with the same N: a protocol is taken from "
                    "the last file that has it (e.g. an older full run and a newer "
                    "--fixed-pressure-only run); none: project from --runs alone")
    ap.add_argument("--average", action="store_true",
                    help="the files are the same benchmark on packings of different seeds: "
                    "average their times per N (otherwise later files override earlier ones)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[500, 1000, 2000, 4000])
    ap.add_argument("--samples", type=int, default=300)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--per-step", type=Path, nargs="+", default=[],
                    help="JSONs of benchmarks/bench_pressure.py --json: the default path's "
                    "measured time per step replaces the fit at their N (module docstring)")
    ap.add_argument("--runs", type=Path, nargs="+", default=[],
                    help="finished ensemble run directories whose mean time per sample replaces "
                    "the fit of the default path at their N (module docstring)")
    ap.add_argument("--cv-samples", type=Path, nargs="+", default=[],
                    help="JSONs of benchmarks/bench_cv_sample.py --json: whole constant-volume "
                    "samples (jam + 1000 steps) whose mean replaces the fit at their N, as --runs "
                    "(a sample stopped at its budget makes that mean a lower bound)")
    ap.add_argument("--fit-runs", action="store_true",
                    help="where --runs hold two N or more for a protocol, extrapolate the "
                    "default path from a power law fitted to their samples, not the benchmark's "
                    "(module docstring)")
    args = ap.parse_args(argv)
    if args.fit_runs and not (args.runs or args.cv_samples):
        fail("--fit-runs needs --runs or --cv-samples")
    if args.samples < 1 or min(args.sizes) < 1 or args.steps < 1:
        fail("--samples, --sizes and --steps must be positive")
    stopped: set[int] = set()
    if not args.bench_json:
        if not args.runs:
            fail("give a benchmark JSON, or --runs to project from whole samples alone")
        if args.cv_samples or args.per_step or args.average:
            fail("--cv-samples, --per-step and --average need a benchmark JSON")
        data = run_conditions(args.runs)
        rows = project_measured(measured_samples(args.runs, data, args.steps), args.sizes,
                                args.samples)
        measured_from = "whole samples of the runs"
    else:
        files = [json_file(f) for f in args.bench_json]
        data = files[0]
        for other in files[1:]:
            if [r["N"] for r in other["results"]] != [r["N"] for r in data["results"]]:
                fail("the benchmark files measure different N")
            if other["pressure"] != data["pressure"] or other["dgamma"] != data["dgamma"]:
                fail("the benchmark files use different p or dgamma")
        if args.average:
            data = average(files)
        else:
            for other in files[1:]:
                for mine, theirs in zip(data["results"], other["results"], strict=True):
                    mine.update(
                        {k: v for k, v in theirs.items() if k != "jam_s" or "jam_s" not in mine}
                    )
        measured = measured_samples(args.runs, data, args.steps) if args.runs else {}
        if args.cv_samples:
            whole, stopped = measured_cv_samples(args.cv_samples, data, args.steps)
            cv = measured.setdefault("constant_volume", {})
            both = sorted(set(whole) & set(cv))
            if both:
                fail(f"--runs and --cv-samples both hold N = {both}")
            cv.update(whole)
        stepped = measured_steps(args.per_step, data) if args.per_step else None
        rows = project(data, args.sizes, args.samples, args.steps, measured, stepped,
                       args.fit_runs)
        measured_from = f"benchmark at N = {[r['N'] for r in data['results']]}"
    where = ("constant volume" if data["pressure"] is None
             else f"p = {data['pressure']:g} at fixed pressure")
    print(f"measured: {measured_from}; projected N = {args.sizes} × {args.samples} samples × "
          f"{args.steps} steps ({where})")
    paper_set = (sorted(args.sizes), args.samples) == ([500, 1000, 2000, 4000], 300)
    set_name = "paper's set" if paper_set else "this set"
    print()
    print(
        "| protocol | code | t_step ∝ N^b | 1000-step sample at N=1000 | ≤ 2 min? "
        f"| {set_name} (CPU-h) | ≤ 500? | ≤ 100? |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        ok_s = "yes" if r["sample_s_1000"] <= TARGET_SAMPLE_S else "no"
        # (the set targets are the paper's set's: "—" for any other set)
        ok_h = "—" if not paper_set else "yes" if r["cpu_h"] <= TARGET_SET_CPU_H else "no"
        ok_m = "—" if not paper_set else "yes" if r["cpu_h"] <= MOONSHOT_CPU_H else "no"
        ext = " (extrapolated)" if r["extrapolated"] else ""
        if r["measured_n"]:
            ext += f" (whole samples measured at N = {', '.join(map(str, r['measured_n']))})"
        low = sorted(n for n in stopped if n in r["measured_n"] and r["protocol"] ==
                     "constant_volume" and r["code"] == "jamlab")
        if low:
            ext += (f" (a lower bound: samples at N = {', '.join(map(str, low))} stopped at "
                    "their budget)")
        if r["fitted_to_runs"]:
            ext += " (other N: a power law through the measured samples, b per sample)"
        if r["measured_step_n"]:
            ext += (f" (steps measured at N = {', '.join(map(str, r['measured_step_n']))}, "
                    "preparation fitted)")
        print(
            f"| {r['protocol'].replace('_', ' ')} | {r['code']} | b = {r['exponent']:.2f} | "
            f"{r['sample_s_1000'] / 60:,.1f} min | {ok_s} | {r['cpu_h']:,.0f}{ext} | {ok_h} "
            f"| {ok_m} |"
        )


if __name__ == "__main__":
    main()
