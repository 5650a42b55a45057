"""Does the gap exponent γ depend on the preparation protocol? (``docs/criticality.md``, issue 19)

    PYTHONPATH=src nice -n 10 python scripts/gamma_protocol.py [--generate] \
        [--data /work/data/gamma_protocol] [--reference /work/data/criticality/n1000] \
        [--seeds 40] [--protocols quench066 dilute060 ...] [--json OUT.json]

1. (``--generate``) jams the missing packings of each protocol (N = 1000, d = 3,
   ``p_target = 1e-7``, ``ftol = 1e-12``, seeds 1…k) into ``DATA/<protocol>/jam_n1000_sS.h5``,
   seed by seed across the protocols (so an interrupted run leaves balanced sets); existing files
   are kept. The protocols differ only in :func:`jamlab.spheres.packing.jam` parameters; with the
   same seed every protocol starts from the *same* uniformly random positions (rescaled to its
   ``φ_init``):

   - ``quench066``: ``jam``'s defaults, ``φ_init = 0.66`` (a quench just above ``φ_J``, then
     small decompressions to ``p ≈ 1e-7``): the protocol of ``docs/criticality.md`` and the
     baseline of the paired differences. The script checks that these packings are the stored
     ones of ``docs/criticality.md`` (``--reference``, same seeds; made by an earlier version of
     the code) and prints the largest position difference;
   - ``dilute060``: ``φ_init = 0.60``: the quench ends unjammed (zero energy) and the search
     compresses affinely, ``φ → φ (1 + 0.01·2^k)`` (0.606, 0.618, 0.643, …), minimising after
     each step, until the packing jams, then decompresses to ``p ≈ 1e-7``;
   - ``deep080``, ``deep090``: ``φ_init = 0.80``, ``0.90``: a quench deep in the jammed phase
     (``p ~ 1e-1``), then decompressions by at most a factor 10 in pressure per step down to
     ``p ≈ 1e-7``;
   - ``slow060``: ``φ_init = 0.60``, ``compress_factor = 1.001``: the same as ``dilute060`` with
     ten times smaller *first* compression steps (0.6006, 0.6018, 0.6042, …). ``jam`` doubles the
     step after every unjammed minimum, so near ``φ_J`` the step is still about half the distance
     already covered: ``jam`` cannot express a compression that is slow *at* ``φ_J``.

2. Measures, for each protocol and the reference, on the same code as
   ``scripts/criticality_measure.py`` (``jamlab.analysis.criticality``, window-CDF fit, bootstrap
   over packings, 95 % intervals): ``γ`` on the window rule's window (its own lower end: 5 gaps
   per packing), on the fixed window ``[1e-4, 1e-2]`` and on the decades ``[1e-4, 1e-3]``,
   ``[1e-3, 1e-2]``, ``[1e-2, 1e-1]``; ``θ_e`` on the rule's window and on ``[0.02, 0.1]``;
   ``φ_J`` (mean ± sd over packings) and the pressure range; and the paired difference
   ``γ(protocol) − γ(quench066)`` on the fixed window (same seeds resampled together).

3. Prints the markdown table of ``docs/criticality.md`` ("Does γ depend on the protocol?") and
   writes ``--json`` if given.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import h5py
import numpy as np
from scipy.stats import t as student_t

from criticality_measure import cell  # (scripts/ is on the path of a script)
from jamlab.analysis.criticality import (
    DEFAULT_RULES,
    REFERENCE,
    choose_window,
    counts,
    criticality_samples,
    fit_exponent,
    packing_observables,
)
from jamlab.spheres.io import read_packing, write_packing
from jamlab.spheres.packing import jam

N = 1000
P_TARGET = 1e-7
FTOL = 1e-12
PROTOCOLS: dict[str, dict[str, float]] = {
    "quench066": {"phi_init": 0.66},
    "dilute060": {"phi_init": 0.60},
    "deep080": {"phi_init": 0.80},
    "deep090": {"phi_init": 0.90},
    "slow060": {"phi_init": 0.60, "compress_factor": 1.001},
}
"""The ``jam`` parameters of each generated protocol (the rest are ``jam``'s defaults)."""
BASELINE = "quench066"
GAMMA_WINDOWS = {
    "fixed": (1e-4, 1e-2),
    "dec_1e-4": (1e-4, 1e-3),
    "dec_1e-3": (1e-3, 1e-2),
    "dec_1e-2": (1e-2, 1e-1),
}
THETA_E_FIXED = (0.02, 0.1)


def packing_path(root: Path, seed: int) -> Path:
    return root / f"jam_n{N}_s{seed}.h5"


def generate(data: Path, protocols: list[str], seeds: int) -> None:
    """Jam every missing packing, seed by seed across the protocols."""
    for seed in range(1, seeds + 1):
        for name in protocols:
            path = packing_path(data / name, seed)
            if path.exists():
                continue
            path.parent.mkdir(parents=True, exist_ok=True)
            t0 = time.process_time()
            res = jam(N, 3, seed, p_target=P_TARGET, ftol=FTOL, **PROTOCOLS[name])
            cpu = time.process_time() - t0
            write_packing(path, res.packing, **res.attrs(), cpu_seconds=cpu, protocol_name=name)
            print(
                f"{name} seed={seed} ok={res.ok} phi_J={res.phi_j:.6f} "
                f"p={res.state.pressure:.3e} minimisations={res.n_minimizations} "
                f"restarts={res.n_restarts} cpu={cpu:.0f}s",
                flush=True,
            )


def load(root: Path, seeds: int) -> tuple[list, list[dict]]:
    """Observables and attributes of seeds 1…k under ``root`` (missing or not ok: an error)."""
    obs, meta = [], []
    for seed in range(1, seeds + 1):
        path = packing_path(root, seed)
        if not path.exists():
            raise ValueError(f"missing packing {path} (run --generate)")
        with h5py.File(path, "r") as h5:
            a = dict(h5.attrs)
        if not bool(a.get("ok", True)):
            raise ValueError(f"{path} is not ok: {a.get('reason', '')}")
        pk = read_packing(path)
        o = packing_observables(pk.positions, pk.box.length, pk.strain)
        obs.append(o)
        meta.append(
            dict(
                seed=seed,
                phi_j=float(a["phi_j"]),
                pressure=float(a["pressure"]),
                isostatic_excess=int(o.isostatic_excess),
                cpu=float(a.get("cpu_seconds", math.nan)),
                minimizations=int(a.get("n_minimizations", -1)),
                restarts=int(a.get("n_restarts", -1)),
            )
        )
    return obs, meta


def compare_to_stored(generated: Path, stored: Path, seeds: int) -> dict:
    """Largest ``|Δx|`` and ``|Δφ_J|`` between the generated baseline packings and the stored ones
    of ``docs/criticality.md`` with the same seeds (those present in ``stored``)."""
    dx, dphi, compared = 0.0, 0.0, []
    for seed in range(1, seeds + 1):
        a, b = packing_path(generated, seed), packing_path(stored, seed)
        if not b.exists():
            continue
        pa, pb = read_packing(a), read_packing(b)
        dx = max(dx, float(np.max(np.abs(pa.positions - pb.positions))))
        dphi = max(dphi, abs(pa.phi - pb.phi))
        compared.append(seed)
    return {"seeds": compared, "max_abs_dx": dx, "max_abs_dphi": dphi}


def _fit(samples, window, n_boot: int, negate: bool) -> dict:
    try:
        f = fit_exponent(samples, window, n_boot=n_boot)
    except ValueError as exc:
        return {"error": str(exc)}
    return (f.negated() if negate else f).as_dict()


def measure(obs, meta, n_boot: int) -> dict:
    s = criticality_samples(obs)
    rule = {k: choose_window(s[k], DEFAULT_RULES[k]) for k in ("gamma", "theta_e")}
    gamma = {"rule": _fit(s["gamma"], rule["gamma"], n_boot, True)}
    for key, w in GAMMA_WINDOWS.items():
        gamma[key] = _fit(s["gamma"], w, n_boot, True)
    theta_e = {
        "rule": _fit(s["theta_e"], rule["theta_e"], n_boot, False),
        "fixed": _fit(s["theta_e"], THETA_E_FIXED, n_boot, False),
    }
    phi = np.array([m["phi_j"] for m in meta])
    return {
        "gamma": gamma,
        "theta_e": theta_e,
        "phi_j": {"mean": float(phi.mean()), "sd": float(phi.std(ddof=1)), "values": phi.tolist()},
        "pressure_range": [min(m["pressure"] for m in meta), max(m["pressure"] for m in meta)],
        "isostatic_excess": sorted({m["isostatic_excess"] for m in meta}),
        "counts": counts(obs),
        "packings": meta,
    }


def paired_difference(gaps_a, gaps_b, window, n_boot: int, seed: int = 0) -> dict:
    """``γ_a − γ_b`` on ``window`` with a bootstrap that resamples the seeds of both sets together
    (packing k of a and of b start from the same random positions); interval as
    :func:`fit_exponent`'s (``t_{0.975, m−1} √(m/(m−1)) s_boot``)."""
    m = len(gaps_a)
    if len(gaps_b) != m:
        raise ValueError("paired sets must have the same seeds")

    def g(samples) -> float:
        return -fit_exponent(samples, window, n_boot=0).value

    value = g(gaps_a) - g(gaps_b)
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(n_boot):
        idx = rng.integers(0, m, m)
        try:
            boot.append(g([gaps_a[i] for i in idx]) - g([gaps_b[i] for i in idx]))
        except ValueError:
            continue
    half = float(student_t.ppf(0.975, m - 1)) * math.sqrt(m / (m - 1)) * float(np.std(boot, ddof=1))
    return {"value": value, "ci95": [value - half, value + half], "window": list(window)}


def gamma_against_phi_j(protocols: dict) -> dict:
    """Weighted least-squares line ``γ = a + b φ_J`` through the protocols' ``γ`` on the fixed
    window (weights ``1/σ²``, ``σ`` = half the 95 % interval / 1.96) against their mean ``φ_J``:
    the slope ``b`` with its standard error and ``χ²`` per degree of freedom of the line and of a
    constant."""
    x = np.array([r["phi_j"]["mean"] for r in protocols.values()])
    y = np.array([r["gamma"]["fixed"]["value"] for r in protocols.values()])
    sig = np.array(
        [np.diff(r["gamma"]["fixed"]["ci95"])[0] / (2 * 1.96) for r in protocols.values()]
    )
    w = 1.0 / sig**2
    design = np.stack([np.ones_like(x), x - x.mean()], axis=1)
    cov = np.linalg.inv(design.T @ (design * w[:, None]))
    coef = cov @ (design.T @ (w * y))
    chi2_line = float(np.sum(w * (y - design @ coef) ** 2))
    const = float(np.sum(w * y) / np.sum(w))
    chi2_const = float(np.sum(w * (y - const) ** 2))
    k = len(x)
    return {
        "slope": float(coef[1]),
        "slope_se": float(math.sqrt(cov[1, 1])),
        "weighted_mean_gamma": const,
        "chi2_per_dof_line": chi2_line / max(k - 2, 1),
        "chi2_per_dof_constant": chi2_const / max(k - 1, 1),
    }


def _cell(f: dict, window: bool = False) -> str:
    return cell(f, window, low_format=".1e")


def markdown(results: dict) -> str:
    lines = [
        "| protocol | φ_J (mean ± sd) | p range | γ rule window | γ [1e-4, 1e-2] | "
        "γ [1e-4, 1e-3] | γ [1e-3, 1e-2] | γ [1e-2, 1e-1] | θ_e rule window | θ_e [0.02, 0.1] | "
        "Δγ vs quench066 on [1e-4, 1e-2] (paired) |",
        "|---" * 11 + "|",
    ]
    for name, r in results["protocols"].items():
        g, t = r["gamma"], r["theta_e"]
        diff = results["paired_difference"].get(name)
        lines.append(
            f"| {name} | {r['phi_j']['mean']:.4f} ± {r['phi_j']['sd']:.4f} | "
            f"{r['pressure_range'][0]:.1e} – {r['pressure_range'][1]:.1e} | "
            f"{_cell(g['rule'], True)} | {_cell(g['fixed'])} | {_cell(g['dec_1e-4'])} | "
            f"{_cell(g['dec_1e-3'])} | {_cell(g['dec_1e-2'])} | {_cell(t['rule'], True)} | "
            f"{_cell(t['fixed'])} | {_cell(diff) if diff else '—'} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("/work/data/gamma_protocol"))
    ap.add_argument("--reference", type=Path, default=Path("/work/data/criticality/n1000"))
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--protocols", nargs="+", default=list(PROTOCOLS), choices=list(PROTOCOLS))
    ap.add_argument("--generate", action="store_true")
    ap.add_argument("--n-boot", type=int, default=1000)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    if args.seeds < 2:
        ap.error("--seeds must be >= 2 (bootstrap over packings)")
    if args.json is not None and args.json.exists():
        ap.error(f"{args.json} exists; not overwriting it")
    if args.generate:
        generate(args.data, args.protocols, args.seeds)
    if BASELINE not in args.protocols:
        ap.error(f"--protocols must include the baseline {BASELINE}")
    try:
        loaded = {name: load(args.data / name, args.seeds) for name in args.protocols}
    except ValueError as exc:
        ap.error(str(exc))
    results: dict = {
        "n": N,
        "seeds": args.seeds,
        "gamma_mean_field": REFERENCE["gamma"],
        "protocols": {},
        "paired_difference": {},
    }
    for name, (obs, meta) in loaded.items():
        results["protocols"][name] = measure(obs, meta, args.n_boot) | {"params": PROTOCOLS[name]}
    results["same_as_stored"] = compare_to_stored(args.data / BASELINE, args.reference, args.seeds)
    ref_gaps = criticality_samples(loaded[BASELINE][0])["gamma"]
    for name in (n for n in loaded if n != BASELINE):
        gaps = criticality_samples(loaded[name][0])["gamma"]
        results["paired_difference"][name] = paired_difference(
            gaps, ref_gaps, GAMMA_WINDOWS["fixed"], args.n_boot
        )
    for name, r in results["protocols"].items():
        print(
            f"{name}: {r['counts']['packings']} packings, {r['counts']['gaps']} gaps, "
            f"phi_J = {r['phi_j']['mean']:.5f} ± {r['phi_j']['sd']:.5f}, "
            f"isostatic excess {r['isostatic_excess']}, "
            f"cpu/packing {[round(m['cpu']) for m in r['packings']]}"
        )
    results["gamma_against_phi_j"] = gamma_against_phi_j(results["protocols"])
    print(f"gamma on [1e-4, 1e-2] against phi_J: {results['gamma_against_phi_j']}")
    print(f"{BASELINE} vs the stored packings of docs/criticality.md: {results['same_as_stored']}")
    print(markdown(results))
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=1, default=float) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
