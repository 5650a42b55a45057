"""Steps the fixed-pressure flag calls elastic although they released enthalpy for certain.

At fixed pressure a candidate step (trapezoid residual ``r_n = ΔH_n − ½ δγ ΔΣ_n`` above the
floor) whose every inner problem the Newton relaxer solved from the previous minimum's contact
network is called a kink and never redone (``confirm="located"``/``"continued"``: "a jump leaves
the linear-response basin, where Newton fails and FIRE carries the event"). This probe checks that
premise on finished runs, from their stored columns only:

``scan RUN [RUN …]``: every step between two jammed minima that is *not* flagged plastic but
whose released enthalpy is bounded below, ``S ≥ −r_n − ½ δγ |G δγ − ΔΣ_n|``
(:func:`jamlab.spheres.confirm.released_at_least`'s bound, here with ``G`` the sample's median
``ΔΣ_n/δγ`` over unflagged steps), by more than ``--units`` × ``max(threshold, δγ²)`` (the scale
of ``confirm_below``; a candidate above 5 of them is flagged without being redone). Printed per
run: such steps against the flagged ones, and each step.

``probe SAMPLE STEP [STEP …]``: the sample replayed from its prepared packing with its run's
options (:func:`jamlab.runs.prepared_packing`, :func:`shear_at_pressure`); the replay's ``ΔH``
and flags at each step are compared with the stored ones (a replay on another machine parts at
rounding level after the first jump, and then says nothing about the stored step). Each step is
then redone from the replay's minimum before it in ``--substeps`` pieces (one fixed-pressure run
of steps ``δγ/m``): the pieces' ``−ΔH`` and flags, the sum against the single step's, and the
chain end's enthalpy against the single step's. A jump keeps ≈ ``r_n`` in one piece; a kink
spreads ``≲ r_n/m`` over them.

``reflag RUN --out DIR [--samples I …]``: each sample replayed whole with the current code and
its run's options, the replay's flags by the current rule and by the rule before 2026-12-03
(without the steps flagged for the residual their chain's largest piece held when redone in four,
``jamlab.spheres.confirm.residual_held``), one ``.npz`` per sample; ``reflag-compare DIR …``: the
avalanches and the fitted τ of both on the same rows.

    PYTHONPATH=src python scripts/continued_jumps.py scan data/runs/n500-p1e-3-vg --units 5
    PYTHONPATH=src python scripts/continued_jumps.py probe \\
        data/runs/n500-p1e-3-vg/samples/phi=jamming/N=500/sample-00009.h5 886 --substeps 16 64
    PYTHONPATH=src python scripts/continued_jumps.py reflag data/runs/n500-p1e-3-vg --out DIR
    PYTHONPATH=src python scripts/continued_jumps.py reflag-compare DIR
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import h5py
import numpy as np
from scipy import stats

from jamlab.analysis import classify_steps, fit_cutoff_power_law
from jamlab.analysis.avalanches import branch_residual, noise_floor
from jamlab.runs import RunDir, prepared_packing
from jamlab.spheres.confirm import plastic_threshold, released_at_least
from jamlab.spheres.pressure_shear import (
    CONFIRM_BELOW,
    FROM_AQS_OPTION,
    PLASTIC_FLOOR,
    shear_at_pressure,
)

COLUMNS = ("energy", "energy_jump", "stress_jump", "plastic", "jammed", "iterations")


def columns(sample: Path) -> tuple[dict, float]:
    """The stored trace columns of a sample file and its run's plastic threshold."""
    with h5py.File(sample, "r") as h5:
        cols = {k: h5[f"trace/{k}"][()] for k in COLUMNS}
        return cols, float(h5.attrs["shear_plastic_threshold"])


def added_flags(sample: Path, confirm_below: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Per step ``n ≥ 1`` of a stored fixed-pressure trace: the stored flags, the steps the rule
    would flag without confirmation (:func:`jamlab.spheres.confirm.plastic_threshold`'s ``sure``,
    recomputed from the stored rows: ``released_at_least`` above ``confirm_below ·
    max(threshold, δγ²)``) that are not flagged, and that bound in those units."""
    with h5py.File(sample, "r") as h5:
        t = {k: h5[f"trace/{k}"][()] for k in ("gamma", "energy_jump", "stress_jump", "plastic",
                                              "jammed")}
    dgamma = float(t["gamma"][1] - t["gamma"][0])
    threshold, passes, sure = plastic_threshold(t["energy_jump"], t["stress_jump"], t["gamma"],
                                                t["jammed"], dgamma, PLASTIC_FLOOR, confirm_below)
    steps = np.diff(t["gamma"])
    nf = noise_floor(t["energy_jump"][1:], t["stress_jump"][1:], steps, jammed=t["jammed"])
    resid = branch_residual(t["energy_jump"][1:], t["stress_jump"][1:], steps)
    units = released_at_least(resid, t["stress_jump"][1:], steps, nf.modulus) / max(
        threshold, dgamma**2)
    return t["plastic"][1:], sure[1:] & ~t["plastic"][1:], units


def scan(runs: list[Path], confirm_below: float) -> None:
    for run in runs:
        found, flagged, steps = [], 0, 0
        for sample in sorted(run.glob("samples/*/*/sample-*[0-9].h5")):
            cols, _ = columns(sample)
            plastic, added, units = added_flags(sample, confirm_below)
            both = cols["jammed"][1:] & cols["jammed"][:-1]
            flagged += int((plastic & both).sum())
            steps += int(both.sum())
            for k in np.flatnonzero(added):
                n = int(k) + 1
                found.append((sample.name, n, units[k], -cols["energy_jump"][n],
                              int(cols["iterations"][n]),
                              "".join("P" if x else "." for x in cols["plastic"][n - 2:n + 3])))
        print(f"{run}: {len(found)} unflagged steps that released more than {confirm_below:g} "
              f"units for certain, against {flagged} flagged, of {steps} steps between jammed "
              "minima")
        for name, n, b, s, its, around in found:
            print(f"  {name} step {n}: bound {b:.1f} units, −ΔH = {s:.3e}, "
                  f"FIRE iterations {its}, flags n−2…n+2 {around}")


def sizes(runs: list[Path], confirm_below: float) -> tuple[np.ndarray, np.ndarray]:
    """The avalanche sizes of the runs by the report's rule (plastic, ``S = −ΔH > 0``, both
    minima jammed: :func:`jamlab.analysis.classify_steps`) with the stored flags, and with the
    flags the rule adds (:func:`added_flags`)."""
    old, new = [], []
    for run in runs:
        for sample in sorted(run.glob("samples/*/*/sample-*[0-9].h5")):
            cols, _ = columns(sample)
            plastic, added, _ = added_flags(sample, confirm_below)
            dh = cols["energy_jump"][1:]
            for flags, out in ((plastic, old), (plastic | added, new)):
                out.append(-dh[classify_steps(dh, flags, jammed=cols["jammed"])])
    return np.concatenate(old), np.concatenate(new)


def compare(runs: list[Path], confirm_below: float, n_boot: int) -> None:
    old, new = sizes(runs, confirm_below)
    fit_old = fit_cutoff_power_law(old, n_boot=n_boot)
    fit_new = fit_cutoff_power_law(new, fit_old.x_min, n_boot=n_boot)
    ks = stats.ks_2samp(old, new)
    print(f"{' '.join(str(r) for r in runs)}: {old.size} → {new.size} avalanches; KS D = "
          f"{ks.statistic:.4f}, p = {ks.pvalue:.3f}; ⟨S⟩ {old.mean():.4e} → {new.mean():.4e}")
    for name, f in (("stored flags", fit_old), ("with the added flags", fit_new)):
        print(f"  {name}: τ = {f.tau:.4f} ± {f.tau_stderr:.4f} (95 % bootstrap "
              f"{f.ci_low:.4f}–{f.ci_high:.4f}), S_min = "
              f"{f.x_min:.3e} ({f.n_tail} sizes), S_c = {f.x_c:.3e}")


def options(study) -> dict:
    """The fixed-pressure options ``jamlab run`` gives ``aqs.shear`` for ``study``."""
    return dict(pressure=study.pressure, ftol=study.force_tol,
                minimizer=FROM_AQS_OPTION["linear"], confirm="located",
                confirm_below=CONFIRM_BELOW, volume_guess=study.volume_guess)


def probe(sample: Path, steps: list[int], substeps: list[int]) -> None:
    study = RunDir(sample.parents[3]).study()
    stored, _ = columns(sample)
    keep = {n - 1 for n in steps} | set(steps)
    minima = {}

    def observe(n, p):
        if n in keep:
            minima[n] = p

    res = shear_at_pressure(prepared_packing(sample), study.dgamma, n_steps=max(steps),
                            observer=observe, save_every=study.checkpoint_every or None,
                            **options(study))
    t = res.trace()
    last = max(steps)
    mine, theirs = np.asarray(t.energy)[: last + 1], stored["energy"][: last + 1]
    if np.array_equal(mine, theirs):
        print(f"{sample}: replay of steps 0–{last} equal to the stored trace")
    else:
        first = int(np.flatnonzero(mine != theirs)[0])
        gap = float(np.max(np.abs(mine - theirs) / np.abs(theirs)))
        print(f"{sample}: replay of steps 0–{last} DIFFERS from the stored trace from row {first}"
              f" (enthalpy: largest relative difference {gap:.1e}; made on another machine?)")
    dg = study.dgamma
    for n in steps:
        dh, ds = float(t.energy_jump[n]), float(t.stress_jump[n])
        r = dh - 0.5 * dg * ds
        h_single = float(t.energy[n])
        print(f" step {n}: replay ΔH {dh:.4e} (stored {stored['energy_jump'][n]:.4e}), "
              f"r_n {r:.3e}, plastic {bool(t.plastic[n])} (stored {bool(stored['plastic'][n])})")
        for m in substeps:
            c = shear_at_pressure(minima[n - 1], dg / m, n_steps=m, **options(study)).trace()
            pieces = -np.asarray(c.energy_jump)[1:]
            res_p = np.asarray(c.energy_jump)[1:] - 0.5 * dg / m * np.asarray(c.stress_jump)[1:]
            k = int(np.argmax(np.abs(res_p)))
            print(f"   {m} pieces: Σ(−ΔH) {pieces.sum():.4e} against the step's {-dh:.4e}; "
                  f"largest piece residual {res_p[k]:.3e} (piece {k + 1}, "
                  f"{abs(res_p[k]) / abs(r):.2f} of r_n); plastic pieces "
                  f"{(np.flatnonzero(np.asarray(c.plastic)[1:]) + 1).tolist()}; "
                  f"H(chain end) − H(single step) {float(c.energy[-1]) - h_single:.3e}")


def reflag(run: Path, samples: list[int] | None, out: Path) -> None:
    """Each sample of ``run`` replayed whole with the current code and its run's options: the
    replay's rows against the stored ones (equal, or the largest relative difference of the
    enthalpy: another machine), its flags against the stored ones, and the replay's time. One
    ``.npz`` per sample in ``out`` (stored and new flags, the chain's ``confirmed`` and ``held``,
    ``ΔH``, ``jammed``, the threshold, the time), read by ``reflag-compare``."""
    study = RunDir(run).study()
    out.mkdir(parents=True, exist_ok=True)
    files = sorted(run.glob("samples/*/*/sample-*[0-9].h5"))
    for sample in files:
        index = int(sample.stem.split("-")[1])
        if samples is not None and index not in samples:
            continue
        target = out / f"{run.name}-{sample.stem}.npz"
        if target.exists():
            continue
        stored, threshold = columns(sample)
        t0 = time.process_time()  # CPU time: a shared machine's load does not enter
        res = shear_at_pressure(prepared_packing(sample), study.dgamma,
                                n_steps=stored["energy"].size - 1,
                                save_every=study.checkpoint_every or None, **options(study))
        seconds = time.process_time() - t0
        mine = np.asarray(res.columns["enthalpy"])
        gap = float(np.max(np.abs(mine - stored["energy"]) / np.abs(stored["energy"])))
        held = res.held if getattr(res, "held", None) is not None else np.zeros(mine.size)
        new = np.asarray(res.columns["plastic"], dtype=bool)
        c = res.columns
        _, _, sure = plastic_threshold(c["enthalpy_jump"], c["stress_jump"], c["gamma"],
                                       c["jammed"], study.dgamma, PLASTIC_FLOOR, CONFIRM_BELOW)
        # the replay's flags by the rule before 2026-12-03: without the steps flagged for the
        # residual their largest piece held (pressure_rows.run_result's by_held)
        by_held = new & ~res.confirmed & ~sure & (held > res.threshold)
        # and those the rule before 2026-12-02 did not flag either (a candidate Newton continued)
        continued_sure = new & sure & res.continued
        np.savez(target, stored=stored["plastic"], new=new, by_held=by_held,
                 continued_sure=continued_sure,
                 confirmed=res.confirmed, held=held, energy_jump=stored["energy_jump"],
                 new_energy_jump=c["enthalpy_jump"], jammed=stored["jammed"],
                 new_jammed=c["jammed"], threshold=res.threshold, stored_threshold=threshold,
                 seconds=seconds, gap=gap)
        added = np.flatnonzero(new & ~stored["plastic"])
        lost = np.flatnonzero(~new & stored["plastic"])
        print(f"{sample.name}: {seconds:.1f} s; enthalpy {'equal' if gap == 0 else f'{gap:.1e}'}"
              f"; flags {int(stored['plastic'].sum())} → {int(new.sum())}, added "
              f"{added.tolist()}, lost {lost.tolist()}", flush=True)


def reflag_compare(outs: list[Path], n_boot: int) -> None:
    """The sizes of the replays saved by ``reflag`` (the report's rule) with the flags of the rule
    before 2026-12-03 and with the current ones, on the replay's own rows (a replay that parted
    from the stored trace — another machine — is compared with itself), the exponential cut-off
    fit at the first's window for both; and, for the replays equal to their stored rows to
    ``1e-12`` relative, whether the rules before give the stored flags (the studies' flags are
    those of the rule before 2026-12-02: without the candidates Newton continued that surely
    released more than ``confirm_below`` units either)."""
    old, new, seconds, gaps, added, same, differ = [], [], [], [], [], 0, []
    for f in sorted(p for d in outs for p in d.glob("*.npz")):
        z = np.load(f)
        dh = z["new_energy_jump"][1:]
        before = z["new"] & ~z["by_held"]
        old.append(-dh[classify_steps(dh, before[1:], jammed=z["new_jammed"])])
        new.append(-dh[classify_steps(dh, z["new"][1:], jammed=z["new_jammed"])])
        seconds.append(float(z["seconds"]))
        gaps.append(float(z["gap"]))
        if float(z["gap"]) <= 1e-12:
            same += 1
            if not np.array_equal(before & ~z["continued_sure"], z["stored"]):
                differ.append(f.stem)
        for n in np.flatnonzero(z["by_held"]):
            added.append((f.stem, int(n), float(-z["new_energy_jump"][n]), float(z["held"][n]),
                          float(z["threshold"])))
    old_s, new_s = np.concatenate(old), np.concatenate(new)
    print(f"{len(seconds)} samples, {np.mean(seconds):.1f} s per replay; {same} replays equal to "
          f"the stored rows to 1e-12 (largest relative difference of any {max(gaps):.1e}), of "
          f"which {len(differ)} with flags of the rules before unlike the stored ones {differ}; "
          f"{old_s.size} → {new_s.size} avalanches ({len(added)} steps added)")
    held_units = np.array([h / t for *_, h, t in added]) if added else np.zeros(0)
    if added:
        sizes = np.array([s for _, _, s, _, _ in added])
        print(f"  added steps: −ΔH {np.min(sizes):.2e}–{np.max(sizes):.2e} (median "
              f"{np.median(sizes):.2e}); held residual {np.min(held_units):.1f}–"
              f"{np.max(held_units):.1f} thresholds (median {np.median(held_units):.1f})")
    ks = stats.ks_2samp(old_s, new_s)
    fit_old = fit_cutoff_power_law(old_s, n_boot=n_boot)
    fit_new = fit_cutoff_power_law(new_s, fit_old.x_min, n_boot=n_boot)
    print(f"  KS D = {ks.statistic:.4f}, p = {ks.pvalue:.3f}; ⟨S⟩ {old_s.mean():.4e} → "
          f"{new_s.mean():.4e}; sizes above S_min = {fit_old.x_min:.2e}: {fit_old.n_tail} → "
          f"{fit_new.n_tail}")
    for name, f in (("stored flags", fit_old), ("new flags", fit_new)):
        print(f"  {name}: τ = {f.tau:.4f} ± {f.tau_stderr:.4f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="mode", required=True)
    s = sub.add_parser("scan")
    s.add_argument("runs", type=Path, nargs="+")
    s.add_argument("--confirm-below", type=float, default=float(CONFIRM_BELOW))
    c = sub.add_parser("compare")
    c.add_argument("runs", type=Path, nargs="+")
    c.add_argument("--confirm-below", type=float, default=float(CONFIRM_BELOW))
    c.add_argument("--n-boot", type=int, default=200)
    p = sub.add_parser("probe")
    p.add_argument("sample", type=Path)
    p.add_argument("steps", type=int, nargs="+")
    p.add_argument("--substeps", type=int, nargs="+", default=[16, 64])
    f = sub.add_parser("reflag")
    f.add_argument("run", type=Path)
    f.add_argument("--samples", type=int, nargs="+")
    f.add_argument("--out", type=Path, required=True)
    g = sub.add_parser("reflag-compare")
    g.add_argument("outs", type=Path, nargs="+")
    g.add_argument("--n-boot", type=int, default=200)
    a = ap.parse_args()
    if a.mode == "reflag":
        reflag(a.run, a.samples, a.out)
    elif a.mode == "reflag-compare":
        reflag_compare(a.outs, a.n_boot)
    elif a.mode == "scan":
        scan(a.runs, a.confirm_below)
    elif a.mode == "compare":
        compare(a.runs, a.confirm_below, a.n_boot)
    else:
        if min(a.steps) < 1 or min(a.substeps) < 2:
            ap.error("steps must be ≥ 1 and substeps ≥ 2")
        probe(a.sample, sorted(a.steps), a.substeps)


if __name__ == "__main__":
    main()
