"""AQS at the jamming point, both protocols: time per step and per 1000-step sample, side by side.

Per N (default 250, 500, 1000): one packing ``jam(N, 3, seed, p_target=1e-7)`` (its time is
reported: it is part of every sample's cost), then ``--steps`` steps of ``δγ = 1e-5``:

- constant volume (the paper's protocol) from that packing: jamlab's default path
  (``shear``: lean step / continuation / FIRE fallback, with the plastic classification), jamlab
  plain FIRE (``minimizer="fire", classify=False``), LAMMPS FIRE (``min_style fire``,
  ``min_modify norm max tmax 3``, ``timestep 0.1``, i.e. jamlab's ``Δt_max = 0.3``) to
  ``max|F_i| < 1e-12`` after ``change_box all xy delta δγ·L remap``;
- fixed pressure ``--pressure`` (default 1e-4) from the same packing first brought to p (not
  timed): jamlab ``shear(pressure=p)`` (nested ``minimize_enthalpy`` with the Newton inner
  minimiser, plastic flag confirmed by 16 substeps), the same with plain FIRE inside
  (``minimizer="fire"``) and with ``confirm_substeps=0`` (the cheap flag), against LAMMPS ``fix
  box/relax iso p vmax 1e-6`` with ``min_style cg`` to ``ftol 1e-12`` (``min_style fire`` does
  not relax the box in LAMMPS). LAMMPS's per-step time is the sum of its minimisation "Loop
  time"s (the process start, data file and the initial box relaxation are not counted).

At constant volume the first steps are not typical of a sample: the shear unjams the packing or
dilatancy raises its pressure by decades, and the cost per step falls with it; the 1000-step
projection from ``--steps`` 20 overstated whole samples 4–7× at N = 1000
(``benchmarks/bench_cv_sample.py`` times whole samples, ``docs/aqs.md``).

jamlab times are wall-clock seconds of the stepping loop (``ShearResult.time``) on one core of a
shared machine: indicative (ratios in one run are what counts). ``--json`` writes the numbers for
``scripts/project_cost.py``. LAMMPS: ``$LAMMPS_BIN`` or ``/tmp/lmpvenv/bin/lmp``; without it only
jamlab is timed.

    PYTHONPATH=src nice -n 10 python benchmarks/bench_jamming.py --n 250 500 1000 --steps 20 \\
        --json jamming_bench.json

``--fixed-pressure-only`` / ``--constant-volume-only`` time one protocol; with the latter,
``--codes jamlab …`` times only the named codes (e.g. the default path after a change of it;
with ``--fixed-pressure-only``, ``jamlab_continued`` adds the default with the plastic flag's
``confirm="continued"``, the default before ``located``).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import jamlab.spheres as sp
from jamlab.spheres.aqs import shear
from jamlab.spheres.barostat import minimize_enthalpy
from jamlab.spheres.kernel_choice import calibration
from jamlab.spheres.pressure_shear import shear_at_pressure

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _lammps import find_lammps, harmonic_header, run_script, write_data  # noqa: E402  (benchmarks run as scripts)

DGAMMA = 1e-5
FTOL = 1e-12


def lammps_steps(lmp, packing: sp.Packing, steps: int, pressure: float | None) -> dict:
    """LAMMPS AQS from ``packing``: per-step loop time and mean minimiser iterations."""
    exe, env = lmp
    if pressure is None:
        minimiser = "min_style fire\nmin_modify norm max tmax 3.0"
        relax = ""
    else:
        minimiser = "min_style cg\nmin_modify norm max"
        relax = f"fix br all box/relax iso {pressure!r} vmax 1e-6 nreset 1"
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        write_data(work / "data.txt", packing)
        script = harmonic_header() + f"""{minimiser}
{relax}
thermo_style custom step pe press pxy vol fmax
thermo_modify norm no
thermo 1000000
run 0
minimize 0 {FTOL!r} 1000000 10000000
print "ROW 0 $(press:%.17g) $(vol:%.17g) $(fmax:%.17g)"
variable i loop {steps}
label loop
variable dxy equal {DGAMMA!r}*ly
change_box all xy delta ${{dxy}} remap units box
minimize 0 {FTOL!r} 1000000 10000000
print "ROW $i $(press:%.17g) $(vol:%.17g) $(fmax:%.17g)"
next i
jump SELF loop
"""
        log, wall = run_script(exe, env, script, work)
    loops = [float(x) for x in re.findall(r"Loop time of ([0-9.eE+-]+)", log)]
    iters = [int(x) for x in re.findall(r"Iterations, force evaluations = (\d+)", log)]
    rows = np.array(
        [[float(x) for x in line.split()[1:]] for line in log.splitlines() if line[:4] == "ROW "]
    )
    # loops[0]: "run 0"; loops[1]: the initial minimisation (not timed); then one per step
    return {
        "ms_per_step": 1e3 * float(sum(loops[2:])) / steps,
        "iterations": float(np.mean(iters[1:])) if len(iters) > 1 else float("nan"),
        "pressure_last": float(rows[-1, 1]),
        "fmax_last": float(rows[-1, 3]),
    }


def one_size(n: int, seed: int, steps: int, pressure: float, lmp,
             constant_volume: bool = True, fixed_pressure: bool = True,
             codes: tuple[str, ...] | None = None) -> dict:
    out: dict = {"N": n}
    t0 = time.process_time()
    res = sp.jam(n, 3, seed, p_target=1e-7)
    out["jam_s"] = time.process_time() - t0
    if not res.ok:
        raise RuntimeError(f"jam({n}, seed={seed}) failed: {res.reason}")
    pk = res.packing
    cv: dict = {}
    def wanted(code: str) -> bool:
        return codes is None or code in codes

    if constant_volume:
        if wanted("jamlab"):
            r = shear(pk, DGAMMA, n_steps=steps)
            cv["jamlab"] = {
                "ms_per_step": 1e3 * r.time / steps,
                "iterations": float(np.mean(r.trace.iterations[1:])),
                "unjammed_minima": int(np.count_nonzero(~r.trace.jammed)),
                "plastic": int(r.trace.plastic.sum()),
            }
        if wanted("jamlab_fire"):
            r = shear(pk, DGAMMA, n_steps=steps, minimizer="fire", classify=False)
            cv["jamlab_fire"] = {
                "ms_per_step": 1e3 * r.time / steps,
                "iterations": float(np.mean(r.trace.iterations[1:])),
                "unjammed_minima": int(np.count_nonzero(~r.trace.jammed)),
            }
        if lmp is not None and wanted("lammps_fire"):
            cv["lammps_fire"] = lammps_steps(lmp, pk, steps, None)
    if not fixed_pressure:
        out["constant_volume"] = cv
        return out
    fp: dict = {}
    t0 = time.process_time()
    at_p = minimize_enthalpy(pk, pressure, ftol=FTOL).packing
    out["to_pressure_s"] = time.process_time() - t0
    for code, options in (("jamlab", {}), ("jamlab_continued", {"confirm": "continued"}),
                          ("jamlab_fire", {"minimizer": "fire"})):
        if not wanted(code) or (code == "jamlab_continued" and codes is None):
            continue  # (the continued confirmation only on request)
        r = shear(at_p, DGAMMA, n_steps=steps, pressure=pressure, **options)
        fp[code] = {
            "ms_per_step": 1e3 * r.time / steps,
            "iterations": float(np.mean(r.trace.iterations[1:])),
            "unjammed_minima": int(np.count_nonzero(~r.trace.jammed)),
            "plastic": int(r.trace.plastic.sum()),
        }
    if wanted("jamlab_cheap_flag"):
        rp = shear_at_pressure(at_p, DGAMMA, n_steps=steps, pressure=pressure,
                               confirm_substeps=0)
        fp["jamlab_cheap_flag"] = {
            "ms_per_step": 1e3 * rp.time / steps,
            "iterations": float(np.mean(rp.columns["iterations"][1:])),
            "volume_steps": float(np.mean(rp.columns["volume_steps"][1:])),
        }
    if lmp is not None and wanted("lammps_cg_box_relax"):
        fp["lammps_cg_box_relax"] = lammps_steps(lmp, at_p, steps, pressure)
    if constant_volume:
        out["constant_volume"] = cv
    out["fixed_pressure"] = fp
    return out


def table(results: list[dict], steps: int, pressure: float) -> str:
    lines = [
        f"δγ = {DGAMMA:g}, {steps} steps per case, ftol = {FTOL:g}; per 1000-step sample = "
        "1000 × per step + jam (fixed pressure: + bringing the packing to p)",
        "",
        "| N | protocol | code | ms/step | its/step | s per 1000-step sample | notes |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in results:
        for proto, key, extra in (
            ("constant V", "constant_volume", r["jam_s"]),
            (f"p = {pressure:g}", "fixed_pressure", r["jam_s"] + r.get("to_pressure_s", 0.0)),
        ):
            if key not in r:
                continue
            for code, m in r[key].items():
                notes = []
                if "unjammed_minima" in m:
                    notes.append(f"{m['unjammed_minima']} unjammed minima")
                if "plastic" in m:
                    notes.append(f"{m['plastic']} plastic")
                if "pressure_last" in m:
                    notes.append(f"last p {m['pressure_last']:.3g}, fmax {m['fmax_last']:.1e}")
                sample = 1000 * m["ms_per_step"] / 1e3 + extra
                lines.append(
                    f"| {r['N']} | {proto} | {code} | {m['ms_per_step']:,.1f} | "
                    f"{m['iterations']:,.0f} | {sample:,.0f} | {', '.join(notes)} |"
                )
        to_p = f"; to p: {r['to_pressure_s']:.1f} s" if "to_pressure_s" in r else ""
        lines.append(f"| {r['N']} | | jam(p=1e-7): {r['jam_s']:.1f} s{to_p} | | | | |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[250, 500, 1000])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--no-lammps", action="store_true")
    ap.add_argument("--fixed-pressure-only", action="store_true",
                    help="time only the fixed-pressure protocol (the constant-volume rows are "
                    "left out of the table and the JSON)")
    ap.add_argument("--constant-volume-only", action="store_true",
                    help="time only the constant-volume protocol")
    ap.add_argument("--codes", nargs="+", default=None,
                    choices=("jamlab", "jamlab_fire", "lammps_fire", "jamlab_continued",
                             "jamlab_cheap_flag", "lammps_cg_box_relax"),
                    help="with --constant-volume-only or --fixed-pressure-only: time only these "
                    "codes (the JSON then holds only them; jamlab_continued, the fixed-pressure "
                    "default with confirm='continued', only when named)")
    args = ap.parse_args()
    if args.codes is not None and not (args.constant_volume_only or args.fixed_pressure_only):
        ap.error("--codes needs --constant-volume-only or --fixed-pressure-only")
    lmp = None if args.no_lammps else find_lammps()
    if lmp is None:
        print("LAMMPS not found (or --no-lammps): jamlab only")
    results = []
    for n in args.n:
        results.append(one_size(n, args.seed, args.steps, args.pressure, lmp,
                                not args.fixed_pressure_only, not args.constant_volume_only,
                                None if args.codes is None else tuple(args.codes)))
        print(f"N = {n} done", flush=True)
        if args.json is not None:
            data = {"steps": args.steps, "seed": args.seed, "dgamma": DGAMMA,
                    "pressure": args.pressure}
            data["force_kernel"] = calibration().describe()  # the machine, for the reader
            args.json.write_text(json.dumps({**data, "results": results}, indent=1))
    print(table(results, args.steps, args.pressure))


if __name__ == "__main__":
    main()
