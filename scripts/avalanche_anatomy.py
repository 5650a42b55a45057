"""Avalanche anatomy of a small AQS ensemble: classes, their share of the power law, finite size.

    PYTHONPATH=src nice -n 10 python scripts/avalanche_anatomy.py --sizes 128 256 --seeds 1 2 3 \
        --steps 300 --dgamma 1e-4 --out-dir /tmp/anatomy

Per size N, state ('jamming': ``jam(N, 3, seed, p_target=1e-7)`` sheared at constant volume;
'phi0.8': ``prepare(N, 3, 0.8, seed)``; 'p<P>', e.g. 'p1e-4': ``jam(N, 3, seed, p_target=P)``
sheared at fixed pressure P, the packings of ``scripts/finite_size_pressure.py``) and seed:
``shear(..., keep_avalanches=True)`` with a hook marking whether the minima before and after
each plastic step are jammed (``jamlab.spheres.rigidity.is_jammed``; the trace's ``jammed``
column is used instead if the trace has one; at fixed pressure, where ``after_step`` does not
exist, always). At fixed pressure S = −ΔH (the enthalpy jump) and no figure is drawn (the
event fields are kept in the trace only above the displacement threshold). Only plastic steps
between two jammed minima count; S = −ΔE. The anatomy (PR·N, class, max |u|, figures) is that of the
event field: the step's non-affine displacement minus the linear elastic response of the minimum
before (``docs/criticality.md``); ``elastic_fraction`` is what was subtracted. Prints per state
the histogram of S per class (localized / extended, PR·N ≤ 10; and 'bucklers/rattlers only'),
the fraction of events and of total S per class, and ⟨S⟩, S_c = ⟨S²⟩/⟨S⟩ against N. Saves the
pooled rows (``events.npz``) and a figure of the largest extended and the largest localized
avalanche.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from jamlab.analysis.anatomy import event_field, nonaffine_displacements
from jamlab.analysis.finite_size import cutoff_size
from jamlab.analysis.powerlaw import mle_tau
from jamlab.plots.anatomy import avalanche_figure
from jamlab.spheres import jam, prepare
from jamlab.spheres.aqs import shear
from jamlab.spheres.aqs.anatomy import elastic_nonaffine_response
from jamlab.spheres.contacts import backbone_mask, contacts
from jamlab.spheres.rigidity import is_jammed


def fixed_pressure(state: str) -> float | None:
    """The pressure of a state 'p<P>' (``None`` for the constant-volume states)."""
    if state in ("jamming", "phi0.8"):
        return None
    if not state.startswith("p"):
        raise SystemExit(f"unknown state {state!r}: 'jamming', 'phi0.8' or 'p<pressure>'")
    return float(state[1:])


def run_one(n, state, seed, steps, dgamma):
    p = fixed_pressure(state)
    if p is not None:
        res = shear(jam(n, 3, seed, p_target=p).packing, dgamma, n_steps=steps, pressure=p,
                    keep_avalanches=True)  # fmt: skip
        av = res.trace.avalanches
        jm = np.asarray(res.trace.jammed, dtype=bool)
        return av, jm[av["step"] - 1] & jm[av["step"]], {}
    if state == "jamming":
        packing = jam(n, 3, seed, p_target=1e-7).packing
    else:
        packing = prepare(n, 3, 0.8, seed).packing
    flags: dict[int, tuple[bool, bool]] = {}
    fields: dict[int, tuple] = {}
    count = [0]

    def hook(before, after, step):
        count[0] += 1
        if step.plastic:
            flags[count[0]] = (bool(is_jammed(before)), bool(is_jammed(after)))
            u = nonaffine_displacements(
                before.positions, after.positions, after.box.length, before.strain, after.strain
            )
            ci, cj, _ = contacts(before)
            keep = backbone_mask(ci, cj, before.n, before.dim + 1)
            el = elastic_nonaffine_response(before, after.strain - before.strain, keep)
            u, _ = event_field(u, el, keep)
            fields[count[0]] = (np.array(before.positions), u, after.box.length)

    res = shear(packing, dgamma, n_steps=steps, keep_avalanches=True, after_step=hook)
    av = res.trace.avalanches
    if "jammed" in res.trace.columns():
        jm = np.asarray(res.trace.columns()["jammed"], dtype=bool)
        jam_ok = jm[av["step"] - 1] & jm[av["step"]]
    else:
        jam_ok = np.array([all(flags[int(s)]) for s in av["step"]], dtype=bool)
    return av, jam_ok, fields


def timed_run(task):
    t0 = time.process_time()
    return (*run_one(*task), time.process_time() - t0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--states", nargs="+", default=["jamming", "phi0.8"])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--dgamma", type=float, default=1e-4)
    ap.add_argument("--out-dir", default="avalanche_anatomy")
    ap.add_argument("--floor", type=float, default=1.2e-8,
                    help="Fit each class's tau above this S (the p = 1e-4 comparison floor).")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--samples", type=int, nargs="+", default=None,
                    help="Per size (as --sizes): seeds 1..k, instead of --seeds.")
    ap.add_argument(
        "--report-only", action="store_true", help="Only print the report of OUT_DIR/events.npz."
    )
    args = ap.parse_args()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if args.report_only:
        with np.load(out / "events.npz") as f:
            report({k: f[k] for k in f.files}, args)
        return
    rows = {
        k: []
        for k in (
            "N",
            "state",
            "seed",
            "step",
            "S",
            "n_eff",
            "localized",
            "only_br",
            "n_opened",
            "n_closed",
            "max_u",
            "elastic_fraction",
            "jammed",
        )
    }
    best: dict[str, tuple] = {}
    if args.samples is not None and len(args.samples) != len(args.sizes):
        raise SystemExit("--samples needs one count per size")
    counts = args.samples or [None] * len(args.sizes)
    seeds = {n: list(range(1, k + 1)) if k else args.seeds
             for n, k in zip(args.sizes, counts, strict=True)}  # fmt: skip
    tasks = [(n, state, seed, args.steps, args.dgamma)
             for state in args.states for n in args.sizes for seed in seeds[n]]  # fmt: skip
    with ProcessPoolExecutor(max_workers=args.workers) as ex:
        for (n, state, seed, *_), (av, jam_ok, fields, cpu) in zip(
            tasks, ex.map(timed_run, tasks), strict=True
        ):
            k = av["step"].size
            print(
                f"{state} N={n} seed={seed}: {k} plastic, {int(jam_ok.sum())} jammed, "
                f"{cpu:.1f} s CPU",
                flush=True,
            )
            S = -av["energy_jump"]
            for key, val in (
                ("N", [n] * k),
                ("state", [state] * k),
                ("seed", [seed] * k),
                ("step", av["step"]),
                ("S", S),
                ("n_eff", av["n_eff"]),
                ("localized", av["localized"]),
                ("only_br", av["only_bucklers_rattlers"]),
                ("n_opened", av["n_opened"]),
                ("n_closed", av["n_closed"]),
                ("max_u", av["max_displacement"]),
                ("elastic_fraction", av["elastic_fraction"]),
                ("jammed", jam_ok),
            ):
                rows[key].extend(list(val))
            # saved after every run: a run cut short still has its finished samples
            np.savez(out / "events.npz", **{k: np.asarray(v) for k, v in rows.items()})
            for i in np.flatnonzero(jam_ok):
                if int(av["step"][i]) not in fields:  # fixed pressure: no fields (docstring)
                    continue
                cls = "localized" if av["localized"][i] else "extended"
                if cls not in best or S[i] > best[cls][0]:
                    best[cls] = (
                        S[i],
                        fields[int(av["step"][i])],
                        state,
                        n,
                        seed,
                        float(av["n_eff"][i]),
                    )
    arr = {k: np.asarray(v) for k, v in rows.items()}
    np.savez(out / "events.npz", **arr)
    for cls, (s, (pos, u, L), state, n, seed, neff) in best.items():
        avalanche_figure(
            pos,
            u,
            L,
            out / f"avalanche_{cls}.png",
            title=f"{cls}: {state} N={n} seed={seed}, S={s:.3g}, PR·N={neff:.1f}",
            label=(r"$\log_{10}|u^{\mathrm{ev}}_i|$: event field, elastic response "
                   r"subtracted (units of $\sigma$)"),
        )
    report(arr, args)


def counted(a: dict[str, np.ndarray]) -> np.ndarray:
    """The rows counted as avalanches: plastic steps between two jammed minima with S > 0."""
    return a["jammed"].astype(bool) & (a["S"] > 0)


def report(a, args) -> None:
    ok = counted(a)
    print(f"\nplastic steps {a['S'].size}, between jammed minima with S > 0: {int(ok.sum())}")
    bins = np.logspace(-12, 0, 13)
    for state in args.states:
        m = ok & (a["state"] == state)
        st = a["state"] == state
        jm = st & a["jammed"].astype(bool)
        print(
            f"\n== {state}: {int(st.sum())} plastic steps, {int(jm.sum())} between jammed minima, "
            f"of which {int((jm & (a['S'] <= 0)).sum())} with S <= 0 (dropped): "
            f"{int(m.sum())} avalanches =="
        )
        classes = {
            "localized": m & a["localized"].astype(bool),
            "extended": m & ~a["localized"].astype(bool),
            "bucklers/rattlers only": m & a["only_br"].astype(bool),
        }
        print("histogram of S, bins " + " ".join(f"{b:.0e}" for b in bins))
        for name, c in classes.items():
            h, _ = np.histogram(a["S"][c], bins=bins)
            print(f"  {name:24s} " + " ".join(f"{v:5d}" for v in h))
        tot_n, tot_s = max(int(m.sum()), 1), max(float(a["S"][m].sum()), 1e-300)
        print(
            "class                  events  fraction  fraction of S  med PR·N  med opened+closed"
            "  med elastic_fraction"
        )
        ef = a["elastic_fraction"] if "elastic_fraction" in a else np.full(a["S"].size, np.nan)
        for name, c in classes.items():
            med = float(np.median(a["n_eff"][c])) if c.any() else float("nan")
            nch = a["n_opened"][c] + a["n_closed"][c]
            mch = float(np.median(nch)) if c.any() else float("nan")
            mef = float(np.median(ef[c])) if c.any() else float("nan")
            print(
                f"  {name:22s} {int(c.sum()):6d} {c.sum() / tot_n:9.3f} "
                f"{a['S'][c].sum() / tot_s:14.3f} {med:9.1f} {mch:9.0f} {mef:12.2e}"
            )
        print("per decade of S: avalanches, localized share, median PR·N, median opened+closed")
        for lo in bins[:-1]:
            d = m & (a["S"] >= lo) & (a["S"] < 10 * lo)
            if d.any():
                nch = a["n_opened"][d] + a["n_closed"][d]
                print(f"  [{lo:.0e}, {10 * lo:.0e})  {int(d.sum()):5d}  "
                      f"{a['localized'][d].astype(bool).mean():6.3f}  "
                      f"{np.median(a['n_eff'][d]):7.1f}  {np.median(nch):5.0f}")
        for name, c in classes.items():
            tail = a["S"][c & (a["S"] >= args.floor)]
            if tail.size >= 10:
                tau, err = mle_tau(tail, args.floor)
                print(f"  tau ({name}, pure power law above S = {args.floor:g}): "
                      f"{tau:.3f} ± {err:.3f} ({tail.size} events)")
        print("N     events   <S>         S_c=<S^2>/<S>   <S>/N       median PR·N")
        for n in args.sizes:
            mn = m & (a["N"] == n)
            s = a["S"][mn]
            if s.size:
                print(
                    f"{n:<5d} {s.size:6d}   {s.mean():.3e}   {cutoff_size(s):.3e}"
                    f"       {s.mean() / n:.3e}   {np.median(a['n_eff'][mn]):.1f}"
                )


if __name__ == "__main__":
    main()
