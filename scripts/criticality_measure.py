"""Regenerate the jamming-criticality measurements of ``docs/criticality.md`` with one command.

    PYTHONPATH=src nice -n 10 python scripts/criticality_measure.py \
        [--data /work/data/criticality] [--n1000 24] [--n4000 10] [--n256 20] [--generate]

1. (``--generate``) jams the missing packings with ``jamlab.spheres.packing.jam`` (d = 3,
   ``p_target = 1e-7``, ``ftol = 1e-12``), seeds 1…k, into ``DATA/nNNN/jam_nNNN_sS.h5``, with
   the current ``jam`` at every N (the stored N = 4000 packings were made with the old
   ``search="halve"``, since removed from ``jam``: regenerating them gives packings of today's
   protocol, not those files). Existing files are kept, so an interrupted run resumes. Each N = 1000
   packing takes ~0.5–2 min, each N = 4000 one 5–16 min on a shared core.
2. Measures ``θ_e``, ``θ_l``, ``γ`` per N and for all N = 1000 packings with the stated window
   rule (``jamlab.analysis.criticality.DEFAULT_RULES``), the window-CDF fit and, as cross-checks,
   the plain log-log CDF fit and the truncated-power-law MLE on the same windows, the same fits on
   one fixed window per exponent for every N, local exponents on one-decade windows, the
   finite-size cut-offs, and the force resolution ``ftol/⟨f⟩``.
3. (``--precision K``) polishes K of the N = 1000 packings to ``ftol = 1e-14`` and reports how
   the smallest forces, the contact count and the exponents change.
4. Writes ``docs/figures/criticality_*.png`` and ``docs/criticality_results.json`` and prints a
   summary.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import time
from pathlib import Path

import h5py
import numpy as np

from jamlab.analysis.criticality import (
    DEFAULT_RULES,
    REFERENCE,
    choose_window,
    counts,
    criticality_samples,
    fit_exponent,
    local_exponents,
    measure_exponents,
    packing_observables,
    smallest_per_packing,
)
from jamlab.plots.criticality import plot_distributions, plot_finite_size, plot_local_exponents
from jamlab.spheres.io import read_packing, write_packing
from jamlab.spheres.packing import jam, relax
from jamlab.theory import tau_jamming

ROOT = Path(__file__).resolve().parent.parent
FIXED = {"theta_e": (0.02, 0.1), "theta_l": (0.02, 0.05), "gamma": (1e-4, 1e-2)}
"""One window per exponent for every N (the comparison across N)."""
SPANS = {"theta_e": (1e-4, 1.0), "theta_l": (1e-4, 1.0), "gamma": (1e-7, 1e-1)}


def generate(data: Path, n: int, seeds: int) -> None:
    for seed in range(1, seeds + 1):
        path = data / f"n{n}" / f"jam_n{n}_s{seed}.h5"
        if path.exists():
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        t0 = time.process_time()
        res = jam(n, 3, seed, p_target=1e-7, ftol=1e-12)
        write_packing(path, res.packing, **res.attrs())
        print(
            f"jammed N={n} seed={seed} ok={res.ok} p={res.state.pressure:.3e} "
            f"cpu={time.process_time() - t0:.0f}s",
            flush=True,
        )


def load(data: Path, n: int, limit: int):
    paths = sorted(
        glob.glob(str(data / f"n{n}" / f"jam_n{n}_s*.h5")),
        key=lambda p: int(Path(p).stem.split("_s")[-1]),
    )[:limit]
    obs, meta = [], []
    for p in paths:
        with h5py.File(p, "r") as h5:
            a = dict(h5.attrs)
        if not bool(a.get("ok", True)):
            print(f"skipping {p}: ok=False ({a.get('reason', '')})")
            continue
        pk = read_packing(p)
        o = packing_observables(pk.positions, pk.box.length, pk.strain)
        obs.append(o)
        meta.append(
            dict(
                path=p,
                pressure=float(a["pressure"]),
                ftol=float(a.get("param_ftol", 1e-12)),
                phi_j=float(a.get("phi_j", math.nan)),
                mean_force=o.mean_force,
                isostatic_excess=o.isostatic_excess,
                search=str(a.get("param_search", "")),
            )
        )
    return obs, meta


def fits_table(obs, n_boot: int) -> dict:
    rule = measure_exponents(obs, n_boot=n_boot)
    out = {"rule": {k: f.as_dict() for k, f in rule.items()}}
    for method in ("plain", "mle"):
        m = measure_exponents(
            obs, windows={k: f.window for k, f in rule.items()}, method=method, n_boot=n_boot
        )
        out[method] = {k: f.as_dict() for k, f in m.items()}
    fixed = {}
    for name, samples in criticality_samples(obs).items():
        try:
            f = fit_exponent(samples, FIXED[name], n_boot=n_boot)
        except ValueError as exc:
            fixed[name] = {"error": str(exc)}
            continue
        fixed[name] = (f.negated() if name == "gamma" else f).as_dict()
    out["fixed"] = fixed
    return out, rule


def precision_check(data: Path, k: int, n_boot: int) -> dict:
    """Polish ``k`` N = 1000 packings to ftol = 1e-14 and compare."""
    paths = sorted(
        glob.glob(str(data / "n1000" / "jam_n1000_s*.h5")),
        key=lambda p: int(Path(p).stem.split("_s")[-1]),
    )[:k]
    rows, before, after = [], [], []
    for p in paths:
        pk = read_packing(p)
        a = packing_observables(pk.positions, pk.box.length, pk.strain)
        t0 = time.process_time()
        r = relax(pk, ftol=1e-14, max_iter=2_000_000)
        b = packing_observables(r.packing.positions, r.packing.box.length, r.packing.strain)
        before.append(a)
        after.append(b)
        fa, fb = np.sort(a.scaled_force), np.sort(b.scaled_force)
        same = a.n_contacts == b.n_contacts and np.array_equal(a.contact_i, b.contact_i)
        rel = float(np.max(np.abs(fa - fb) / fa)) if same else math.nan
        rows.append(
            dict(
                path=p,
                converged=bool(r.converged),
                cpu=time.process_time() - t0,
                contacts_before=a.n_contacts,
                contacts_after=b.n_contacts,
                same_network=bool(same),
                smallest_before=fa[:3].tolist(),
                smallest_after=fb[:3].tolist(),
                max_rel_change_of_any_force=rel,
                max_abs_change_over_mean=(float(np.max(np.abs(fa - fb))) if same else math.nan),
            )
        )
        print(f"polished {p}: {rows[-1]}", flush=True)
    fits = {}
    for label, obs in (("ftol_1e-12", before), ("ftol_1e-14", after)):
        m = measure_exponents(obs, windows=FIXED, n_boot=n_boot)
        fits[label] = {k: f.as_dict() for k, f in m.items()}
    return {"packings": rows, "fixed_window_fits": fits}


def gap_diagnostics(data: Path, n: int, limit: int, n_boot: int) -> dict:
    """γ on the fixed window for: backbone gaps (the definition), all pairs with rattlers,
    rattler pairs only, backbone pairs without a buckler, and packings split at p = 8e-8."""
    paths = sorted(
        glob.glob(str(data / f"n{n}" / f"jam_n{n}_s*.h5")),
        key=lambda p: int(Path(p).stem.split("_s")[-1]),
    )[:limit]
    sets: dict[str, list] = {
        k: []
        for k in (
            "backbone",
            "with_rattlers",
            "rattler_pairs",
            "no_buckler_pairs",
            "p_below_8e-8",
            "p_above_8e-8",
        )
    }
    for path in paths:
        with h5py.File(path, "r") as h5:
            pressure = float(h5.attrs["pressure"])
        pk = read_packing(path)
        o = packing_observables(pk.positions, pk.box.length, pk.strain)
        w = packing_observables(pk.positions, pk.box.length, pk.strain, include_rattlers=True)
        buck = np.zeros(o.n, dtype=bool)
        buck[o.buckler_ids] = True
        sets["backbone"].append(o.gap)
        sets["with_rattlers"].append(w.gap)
        sets["rattler_pairs"].append(w.gap[~(o.backbone[w.gap_i] & o.backbone[w.gap_j])])
        sets["no_buckler_pairs"].append(o.gap[~(buck[o.gap_i] | buck[o.gap_j])])
        sets["p_below_8e-8" if pressure < 8e-8 else "p_above_8e-8"].append(o.gap)
    out = {}
    for key, samples in sets.items():
        if len(samples) < 2:
            continue
        f = fit_exponent(samples, FIXED["gamma"], n_boot=n_boot).negated()
        out[key] = f.as_dict()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("/work/data/criticality"))
    ap.add_argument("--n256", type=int, default=20)
    ap.add_argument("--n1000", type=int, default=24)
    ap.add_argument("--n4000", type=int, default=10)
    ap.add_argument("--generate", action="store_true")
    ap.add_argument("--precision", type=int, default=0)
    ap.add_argument("--n-boot", type=int, default=1000)
    ap.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    ap.add_argument("--results", type=Path, default=ROOT / "docs" / "criticality_results.json")
    args = ap.parse_args()
    sizes = {256: args.n256, 1000: args.n1000, 4000: args.n4000}
    if args.generate:
        for n, k in sizes.items():
            generate(args.data, n, k)
    groups, metas, results = {}, {}, {"by_n": {}}
    for n, k in sizes.items():
        obs, meta = load(args.data, n, k)
        if obs:
            groups[n], metas[n] = obs, meta
    for n, obs in groups.items():
        table, _ = fits_table(obs, args.n_boot)
        samples = criticality_samples(obs)
        results["by_n"][str(n)] = table | {
            "counts": counts(obs),
            "pressure_range": [
                min(m["pressure"] for m in metas[n]),
                max(m["pressure"] for m in metas[n]),
            ],
            "phi_j_mean": float(np.mean([m["phi_j"] for m in metas[n]])),
            "isostatic_excess": sorted({m["isostatic_excess"] for m in metas[n]}),
            "searches": sorted({m["search"] for m in metas[n]}),
            "force_resolution_max": max(m["ftol"] / m["mean_force"] for m in metas[n]),
            "smallest_extended_force_median": float(
                np.median(smallest_per_packing(samples["theta_e"]))
            ),
            "smallest_gap_median": float(np.median(smallest_per_packing(samples["gamma"]))),
            "rule_windows": {k: list(choose_window(samples[k], DEFAULT_RULES[k])) for k in samples}
            if len(obs) > 1
            else {},
        }
    local = {
        name: {
            n: local_exponents(criticality_samples(g)[name], *SPANS[name], n_boot=300)
            for n, g in groups.items()
        }
        for name in SPANS
    }
    results["local"] = {
        name: {
            str(n): {
                "lo": le.lo.tolist(),
                "value": le.value.tolist(),
                "ci_low": le.ci_low.tolist(),
                "ci_high": le.ci_high.tolist(),
                "n_in_window": le.n_in_window.tolist(),
            }
            for n, le in by.items()
        }
        for name, by in local.items()
    }
    main_n = 1000 if 1000 in groups else max(groups)
    _, rule_main = fits_table(groups[main_n], args.n_boot)
    fits_by_n = {
        n: measure_exponents(g, windows=FIXED, n_boot=args.n_boot) for n, g in groups.items()
    }
    args.figures.mkdir(parents=True, exist_ok=True)
    plot_distributions(
        groups, rule_main, args.figures / "criticality_distributions.png", fit_n=main_n
    )
    plot_local_exponents(local, rule_main, args.figures / "criticality_local_exponents.png")
    plot_finite_size(groups, fits_by_n, args.figures / "criticality_finite_size.png")
    results["gap_diagnostics"] = {
        str(n): gap_diagnostics(args.data, n, sizes[n], args.n_boot) for n in groups
    }
    if args.precision:
        results["precision"] = precision_check(args.data, args.precision, args.n_boot)
    results["reference"] = REFERENCE
    results["fixed_windows"] = FIXED
    results["rules"] = {k: [r.per_packing, r.upper] for k, r in DEFAULT_RULES.items()}
    results["tau_j"] = {
        str(n): {
            "from_theta_e": tau_jamming(t["rule"]["theta_e"]["value"]),
            "from_gamma": 1 + t["rule"]["gamma"]["value"],
        }
        for n, t in results["by_n"].items()
    }
    args.results.write_text(json.dumps(results, indent=1, default=float) + "\n")
    for n, t in results["by_n"].items():
        c = t["counts"]
        print(
            f"N={n}: {c['packings']} packings, {c['contacts']} contacts "
            f"({c['localized_contacts']} localized), {c['gaps']} gaps; "
            f"p in {t['pressure_range']}; resolution ftol/<f> <= {t['force_resolution_max']:.1e}"
        )
        for kind in ("rule", "plain", "mle", "fixed"):
            line = "  ".join(
                f"{k}={f['value']:.3f} [{f['ci95'][0]:.3f},{f['ci95'][1]:.3f}] "
                f"on [{f['window'][0]:.2g},{f['window'][1]:.2g}]"
                if "value" in f
                else f"{k}: -"
                for k, f in t[kind].items()
            )
            print(f"  {kind:5s} {line}")
    for n, diag in results["gap_diagnostics"].items():
        print(
            f"N={n} gamma on {FIXED['gamma']}: "
            + "  ".join(f"{k}={cell(f, False)}" for k, f in diag.items())
        )
    print(markdown(results))
    print(markdown_local(results))
    print(f"wrote {args.results} and {args.figures}/criticality_*.png")


def cell(f: dict, window: bool = True, low_format: str = ".2g") -> str:
    """A table cell for one exponent fit ``{"value", "ci95", "window"}`` (the ``--json`` form):
    ``value [lo, hi]``, and ``on [w0, w1]`` with ``window`` (``w0`` as ``low_format``)."""
    if "value" not in f:
        return "–"
    lo, hi = f["ci95"]
    text = f"{f['value']:.3f} [{lo:.3f}, {hi:.3f}]"
    if window:
        text += f" on [{f['window'][0]:{low_format}}, {f['window'][1]:.2g}]"
    return text


def markdown_local(results: dict) -> str:
    """The local-exponent tables of docs/criticality.md (θ and γ, ± half the 95 % interval)."""
    out = []
    for names in (("theta_e", "theta_l"), ("gamma",)):
        cols = [(name, n) for name in names for n in results["local"][name]]
        sign = {name: -1.0 if name == "gamma" else 1.0 for name in names}
        rows: dict[float, list[str]] = {}
        for k, (name, n) in enumerate(cols):
            d = results["local"][name][n]
            for lo, v, a, b in zip(d["lo"], d["value"], d["ci_low"], d["ci_high"], strict=True):
                if v is None or not math.isfinite(v):
                    continue
                cell = f"{sign[name] * v:.2f} ± {abs(b - a) / 2:.2f}"
                rows.setdefault(round(lo, 12), [""] * len(cols))[k] = cell
        out.append("| window | " + " | ".join(f"{a} N = {n}" for a, n in cols) + " |")
        out.append("|---" * (len(cols) + 1) + "|")
        for lo in sorted(rows):
            out.append(f"| [{lo:.0e}, {lo * 10:.0e}] | " + " | ".join(rows[lo]) + " |")
        out.append("")
    return "\n".join(out)


def markdown(results: dict) -> str:
    """The table of docs/criticality.md."""
    lines = [
        "| N | packings, backbone contacts (localized), gaps | exponent | rule window, `cdf` | "
        "`plain` | `mle` | fixed window, `cdf` | reference |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for n, t in results["by_n"].items():
        c = t["counts"]
        what = f"{c['packings']}, {c['contacts']} ({c['localized_contacts']}), {c['gaps']}"
        for k, name in enumerate(("theta_e", "theta_l", "gamma")):
            lines.append(
                f"| {n if k == 0 else ''} | {what if k == 0 else ''} | {name} | "
                f"{cell(t['rule'][name])} | {cell(t['plain'][name], False)} | "
                f"{cell(t['mle'][name], False)} | {cell(t['fixed'][name], False)} | "
                f"{results['reference'][name]} |"
            )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
