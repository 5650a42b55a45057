"""Above jamming: the avalanches of a fresh quench against those of the steady state.

Every scale of ``jamlab reproduce`` shears ``prepare(N, 3, φ, seed)`` packings (a fresh quench)
from γ = 0 for a strain window of 0.01–0.02 — the paper's protocol. Within that window the
avalanches release mostly the quench's own stored energy, not the shear's work
(docs/reproduce.md, "Above jamming the avalanches give up the preparation's energy"). This
script shears the same packings twice, per ``(N, seed)``:

- *transient*: ``shear(packing, --dgamma, n_steps=--steps)`` from the quench (the report's
  protocol);
- *steady*: first ``shear(packing, --pre-dgamma, gamma_max=--pre-strain)`` (AQS with a coarser
  step, classification off), then the same ``--steps`` steps of ``--dgamma`` from where that
  ends;

and per protocol pools the avalanches by the report's rule
(:func:`jamlab.analysis.avalanche_sizes`: plastic flags, ``ΔE < 0``, both minima jammed),
prints the cut-off's scale ``⟨S²⟩/⟨S⟩`` per N (with several N its σ over packing resamples and
its power β, :func:`jamlab.analysis.fit_cutoff_scaling`), the energy balance
per particle and unit strain (work of the shear
``Σ (γ_n − γ_{n−1}) Σ_{n−1}``, energy the packings give up ``E_0 − E_last``, released by the
avalanches ``Σ S``), ``⟨S⟩`` per N, and τ by the report's fit
(:func:`jamlab.analysis.fit_power_law`, KS-chosen ``x_min``, truncated at the largest size,
bootstrap 95 % interval; all N pooled, and each N alone when there are several) with its σ =
interval width / 3.92. In the steady state the release should equal the work (no stored energy
is left to give up); the question is whether τ then moves towards the predicted 1.

Monodisperse spheres (the paper's system, ``--sizes mono``) order under long shear: at φ = 0.8,
N = 256 most particles are crystalline by γ ≈ 0.6 (docs/reproduce.md, "Are the packings
amorphous?"). So every protocol's window also records the order of its first and last
configuration (:func:`jamlab.analysis.order.bond_order`: ten Wolde's crystalline fraction, and
Steinhardt's ``Q_6``), printed per protocol and N; ``--sizes bidisperse`` (50:50, ratio 1.4)
stays amorphous.

``--workers`` processes (one sample each at a time); ``--out F.npz`` keeps every size and
balance (loadable with ``--load F.npz [G.npz ...]`` to reprint without shearing, each file's
tables in turn; with ``--pool`` the files of each ``--load`` are pooled into one set, e.g. the
runs of one φ at other N, and ``--load`` may be repeated: one set per φ).
``--figure F.png`` draws, one panel per run (or loaded file), each N's
steady-state avalanche rate per particle, unit strain and unit ``ln S``, ``S n(S)``, in log
bins (Poisson errors) with the transient's dashed: a flat curve is τ = 1, a slope ``1 − τ``
is τ (guides for 1 and 1.1).

    PYTHONPATH=src python scripts/steady_unsat.py --phi 0.75 --n 128 256 --samples 120 \\
        --workers 2 --out steady_075.npz
"""

from __future__ import annotations

import argparse
import os
import sys
import textwrap
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

PROTOCOLS = ("transient", "steady")


def counted_sizes(trace) -> np.ndarray:
    """``S = −ΔE`` of the steps of ``trace`` the report counts (row 0 has no step):
    :func:`jamlab.analysis.avalanche_sizes` with the plastic and jammed flags."""
    from jamlab.analysis import avalanche_sizes

    return avalanche_sizes(np.asarray(trace.energy_jump)[1:], np.asarray(trace.plastic)[1:],
                           jammed=np.asarray(trace.jammed))


def balance(trace) -> tuple[float, float, float]:
    """``(work, given up, strain)`` of ``trace``: ``Σ (γ_n − γ_{n−1}) Σ_{n−1}``,
    ``E_0 − E_last`` and ``γ_last − γ_0``."""
    g, sig, e = (np.asarray(getattr(trace, k)) for k in ("gamma", "shear_stress", "energy"))
    return float(np.sum(np.diff(g) * sig[:-1])), float(e[0] - e[-1]), float(g[-1] - g[0])


def order_of(packing) -> tuple[float, float]:
    """``(crystalline fraction, Q_6)`` of ``packing`` with the contacts as bonds; ``nan`` where
    the box is too small for the minimum image (fewer than ≈ 20 spheres)."""
    from jamlab.analysis.order import bond_order

    try:
        o = bond_order(packing.positions, packing.box.length, packing.box.strain,
                       packing.diameters)
    except ValueError:
        return float("nan"), float("nan")
    return o.crystalline_fraction, o.global_q


def steady_start(job: tuple):
    """``(start, pre)``: the quench ``prepare(n, 3, phi, seed, sizes=sizes)`` and its pre-shear
    to ``pre_strain`` in steps of ``pre_dgamma`` without classification (the steady window
    starts from ``pre.packing``); ``job`` as :func:`one_sample`'s. Shared with
    ``steady_anatomy.py``."""
    from jamlab.spheres import aqs, prepare

    n, phi, seed, _, _, pre_dgamma, pre_strain, sizes = job
    start = prepare(n, 3, phi, seed, sizes=sizes).packing
    return start, aqs.shear(start, pre_dgamma, gamma_max=pre_strain, classify=False)


def one_sample(job: tuple) -> dict:
    """Both protocols on ``prepare(n, 3, phi, seed, sizes=sizes)``: per protocol the counted
    sizes, the balance and the order at the window's start and end, and the CPU seconds."""
    from jamlab.spheres import aqs

    n, phi, seed, dgamma, steps, pre_dgamma, pre_strain, sizes = job
    t0 = time.process_time()
    start, pre = steady_start(job)
    out = {"n": n, "seed": seed}
    transient = aqs.shear(start, dgamma, n_steps=steps)
    steady = aqs.shear(pre.packing, dgamma, n_steps=steps)
    for name, first, run in zip(PROTOCOLS, (start, pre.packing), (transient, steady),
                                strict=True):
        tr = run.trace
        out[name] = {"sizes": counted_sizes(tr), "balance": balance(tr),
                     "converged": bool(np.all(np.asarray(tr.max_force) < 1e-12)),
                     "order": (*order_of(first), *order_of(run.packing))}
    out["cpu"] = time.process_time() - t0
    return out


def table(results: list[dict], boot: int, min_tail: int, x_mins: tuple = (),
          x_maxs: tuple = ()) -> None:
    """The balance and the cut-off's scale per N and protocol (with more than one N its σ and
    its power of N, β, by :func:`jamlab.analysis.fit_cutoff_scaling`), τ per protocol (all N
    pooled and, with more than one N, each N alone), and τ of both at each fixed ``x_min`` of
    ``x_mins`` (the same window for both: the KS choice of each differs), truncated at each
    set's largest size or, one table each, at every ``x_max`` of ``x_maxs``."""
    from jamlab.analysis import cutoff_size, fit_cutoff_scaling, fit_power_law

    sizes_n = sorted({r["n"] for r in results})
    # the cut-off's scale per N; with two N or more its σ and β by fit_cutoff_scaling (packing
    # resamples), with one N only the value (the fit needs two sizes)
    by_n = {(name, n): [r[name]["sizes"] for r in results if r["n"] == n]
            for name in PROTOCOLS for n in sizes_n}
    scales = {key: (cutoff_size(np.concatenate(packs)), float("nan"))
              for key, packs in by_n.items()}
    scaling = {}
    for name in PROTOCOLS:
        mine = {n: by_n[name, n] for n in sizes_n}
        if sum(any(p.size for p in packs) for packs in mine.values()) > 1:
            f = scaling[name] = fit_cutoff_scaling(mine, n_boot=max(boot, 2), seed=0)
            scales.update({(name, int(n)): (float(c), float(e))
                           for n, c, e in zip(f.n, f.cutoff, f.cutoff_err, strict=True)})
    print("| protocol | N (samples) | avalanches | ⟨S⟩ (ε) | ⟨S²⟩/⟨S⟩ (ε) ± σ | work | given up "
          "| released | released / work | all minima converged |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in PROTOCOLS:
        for n in sizes_n:
            rs = [r for r in results if r["n"] == n]
            s = np.concatenate([r[name]["sizes"] for r in rs])
            w, g, gam = np.array([r[name]["balance"] for r in rs]).sum(axis=0)
            exposure = n * gam
            mean = f"{s.mean():.3g}" if s.size else "—"
            scale, err = scales[name, n]
            scale = f"{scale:.3g}" + (f" ± {err:.2g}" if np.isfinite(err) else "")
            print(f"| {name} | {n} ({len(rs)}) | {s.size} | {mean} | {scale} | "
                  f"{w / exposure:.3g} | {g / exposure:.3g} | {s.sum() / exposure:.3g} | "
                  f"{s.sum() / w:.2f} | {all(r[name]['converged'] for r in rs)} |")
    print("\n(work, given up, released: ε per particle per unit strain)\n")
    for name, f in scaling.items():
        print(f"{name}: ⟨S²⟩/⟨S⟩ ∝ N^β, β = {f.beta:.2f} ± {f.beta_err:.2f} "
              f"(jamlab.analysis.fit_cutoff_scaling, {f.n.size} sizes)")
    if scaling:
        print()
    from jamlab.reproduce.amorphous import ORDERED_FRACTION as above

    print(f"| protocol | N | crystalline fraction at the window's start: mean, max, samples "
          f"> {above:g} | at its end: mean, max, samples > {above:g} | Q_6 start → end (mean) |")
    print("|---|---|---|---|---|")
    for name in PROTOCOLS:
        for n in sizes_n:
            o = np.array([r[name]["order"] for r in results if r["n"] == n], dtype=float)
            cells = [f"{np.mean(o[:, k]):.3f}, {np.max(o[:, k]):.3f}, "
                     f"{int(np.sum(o[:, k] > above))}" for k in (0, 2)]
            print(f"| {name} | {n} | {cells[0]} | {cells[1]} | "
                  f"{np.mean(o[:, 1]):.3f} → {np.mean(o[:, 3]):.3f} |")
    # all N pooled, then (with more than one N) each N alone: does τ move with N?
    groups = [("all", results)]
    if len(sizes_n) > 1:
        groups += [(str(n), [r for r in results if r["n"] == n]) for n in sizes_n]
    pooled = {(name, label): np.concatenate([r[name]["sizes"] for r in rs])
              for name in PROTOCOLS for label, rs in groups}
    print()
    print("| protocol | N | τ (95 %) | σ | x_min (ε) | tail |")
    print("|---|---|---|---|---|---|")
    for name in PROTOCOLS:
        for label, _ in groups:
            s = pooled[name, label]
            if s.size < min_tail:
                print(f"| {name} | {label} | no data (fewer than {min_tail} avalanches) "
                      "| | | |")
                continue
            fit = fit_power_law(s, x_max=float(s.max()), min_tail=min_tail, n_boot=boot,
                                seed=0)
            lo, hi = fit.ci_low, fit.ci_high
            print(f"| {name} | {label} | {fit.tau:.3f} [{lo:.3f}, {hi:.3f}] | "
                  f"{(hi - lo) / 3.92:.3f} | {fit.x_min:.3g} | {fit.n_tail} |")
    if not x_mins:
        return
    for x_max in x_maxs or (None,):
        print("\n(each fit truncated at " + ("its set's largest size" if x_max is None else
                                            f"x_max = {x_max:.3g} ε") + ")")
        print("| x_min (ε), fixed | N | " + " | ".join(f"τ {name} (95 %), tail, KS distance"
                                                     for name in PROTOCOLS) + " |")
        print("|---|---|" + "---|" * len(PROTOCOLS))
        for x_min in x_mins:
            for label, _ in groups:
                cells = []
                for name in PROTOCOLS:
                    s = pooled[name, label]
                    top = float(s.max(initial=0.0)) if x_max is None else x_max
                    if x_min >= top or np.count_nonzero((s >= x_min) & (s <= top)) < min_tail:
                        cells.append(f"no data (fewer than {min_tail} sizes)")
                        continue
                    fit = fit_power_law(s, x_min=x_min, x_max=top, n_boot=boot, seed=0)
                    cells.append(f"{fit.tau:.3f} [{fit.ci_low:.3f}, {fit.ci_high:.3f}], "
                                 f"{fit.n_tail}, {fit.ks_distance:.3f}")
                print(f"| {x_min:.3g} | {label} | " + " | ".join(cells) + " |")


def rate_density(results: list[dict], name: str, n: int, bins_per_decade: int = 4
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(S, S n(S), error)`` of protocol ``name`` at size ``n``: the counted avalanches of
    every sample of that N in log bins (:func:`jamlab.analysis.histograms.log_histogram` on
    its universal grid), ``S n(S)`` the number per particle, unit strain and unit ``ln S`` at
    the bin's geometric centre ``S`` (counts / (N · strain sheared · Δln S)), Poisson error;
    empty bins left out."""
    from jamlab.analysis.histograms import log_histogram

    rs = [r for r in results if r["n"] == n]
    s = np.concatenate([r[name]["sizes"] for r in rs] or [np.empty(0)])
    exposure = n * sum(r[name]["balance"][2] for r in rs)
    if s.size == 0 or not exposure > 0:
        return np.empty(0), np.empty(0), np.empty(0)
    h = log_histogram(s, bins_per_decade=bins_per_decade)
    width = np.log(h.edges[1:] / h.edges[:-1])
    keep = h.counts > 0
    c = h.counts[keep]
    return (h.centres[keep], c / (exposure * width[keep]),
            np.sqrt(c) / (exposure * width[keep]))


def figure(path: Path, panels: list[tuple[str, list[dict]]]) -> None:
    """One panel per ``(title, results)``: each N's steady ``S n(S)`` (module docstring),
    the transient's dashed, and guides of slope 0 (τ = 1) and −0.1 (τ = 1.1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.9), squeeze=False,
                             sharey=True)
    for ax, (title, results) in zip(axes[0], panels, strict=True):
        spans = []
        for n in sorted({r["n"] for r in results}):
            x, y, e = rate_density(results, "steady", n)
            if x.size == 0:
                continue
            bar = ax.errorbar(x, y, yerr=e, fmt="o-", ms=3, lw=1, capsize=2,
                              label=f"N = {n}, steady")
            xt, yt, _ = rate_density(results, "transient", n)
            ax.loglog(xt, yt, "--", lw=0.8, color=bar[0].get_color(), alpha=0.7,
                      label=f"N = {n}, transient")
            spans.append((x, y))
        if spans:
            lo, hi = min(x.min() for x, _ in spans), max(x.max() for x, _ in spans)
            x0, y0 = np.sqrt(lo * hi), float(np.median(np.concatenate([y for _, y in spans])))
            g = np.geomspace(lo, hi)
            ax.loglog(g, y0 * (g / x0) ** 0.0, "k:", lw=1, label="τ = 1")
            ax.loglog(g, y0 * (g / x0) ** -0.1, "k-.", lw=1, label="τ = 1.1")
            ax.legend(fontsize=6)
        else:
            ax.text(0.5, 0.5, "no counted steady-state avalanche", ha="center",
                    transform=ax.transAxes, fontsize=8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(textwrap.fill(title, 50), fontsize=8)  # a pooled set names every file
        ax.set_xlabel("S (ε)")
    axes[0, 0].set_ylabel("S n(S): per particle, unit strain, unit ln S")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"\nfigure: {path}")


def save(path: Path, results: list[dict]) -> None:
    """Every sample's sizes and balances in one ``.npz``."""
    arrays = {}
    for i, r in enumerate(results):
        arrays[f"s{i}_meta"] = np.array([r["n"], r["seed"], r["cpu"]])
        for name in PROTOCOLS:
            arrays[f"s{i}_{name}_sizes"] = r[name]["sizes"]
            arrays[f"s{i}_{name}_balance"] = np.array(r[name]["balance"])
            arrays[f"s{i}_{name}_converged"] = np.array(r[name]["converged"])
            arrays[f"s{i}_{name}_order"] = np.array(r[name]["order"])
    np.savez(path, **arrays)


def load(path: Path) -> list[dict]:
    """The results :func:`save` wrote."""
    z = np.load(path)
    out, i = [], 0
    while f"s{i}_meta" in z:
        n, seed, cpu = z[f"s{i}_meta"]
        r = {"n": int(n), "seed": int(seed), "cpu": float(cpu)}
        for name in PROTOCOLS:
            r[name] = {"sizes": z[f"s{i}_{name}_sizes"],
                       "balance": tuple(z[f"s{i}_{name}_balance"]),
                       "converged": bool(z[f"s{i}_{name}_converged"]),
                       # files of the first version carry no order: nan
                       "order": tuple(z[f"s{i}_{name}_order"]) if f"s{i}_{name}_order" in z
                       else (np.nan,) * 4}
        out.append(r)
        i += 1
    return out


def add_protocol_arguments(ap: argparse.ArgumentParser, *, samples: int, pre_strain: float,
                           sizes: str) -> None:
    """The protocol's arguments (φ, N, seeds, strain steps, pre-shear, sizes, workers), with the
    defaults that differ between this script and ``steady_anatomy.py`` given."""
    ap.add_argument("--phi", type=float, default=0.75)
    ap.add_argument("--n", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--samples", type=int, default=samples)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--dgamma", type=float, default=1e-4)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--pre-dgamma", type=float, default=1e-3)
    ap.add_argument("--pre-strain", type=float, default=pre_strain)
    ap.add_argument("--sizes", default=sizes, choices=["mono", "bidisperse"],
                    help="diameters of the prepared packings (SPEC §5)")
    ap.add_argument("--workers", type=int, default=1)


def run_jobs(ap: argparse.ArgumentParser, a: argparse.Namespace, sample) -> list[dict]:
    """``sample(job)`` for every (N, seed) of the arguments of :func:`add_protocol_arguments`
    (refused with ``ap.error`` where they are out of range, or ``a.out`` exists), on
    ``a.workers`` processes one job at a time, in order; the run's cost printed to stderr."""
    if not (0.5 < a.phi < 1.0) or a.samples < 1 or a.steps < 1 or a.workers < 1:
        ap.error("need 0.5 < --phi < 1, --samples, --steps and --workers >= 1")
    if not (0 < a.dgamma < a.pre_strain and 0 < a.pre_dgamma < a.pre_strain):
        ap.error("need 0 < --dgamma, --pre-dgamma < --pre-strain")
    if any(n < 8 for n in a.n):
        ap.error("--n: at least 8 spheres")
    if a.out is not None and a.out.exists():
        ap.error(f"--out {a.out} exists (finished data is never overwritten)")
    jobs = [(n, a.phi, s, a.dgamma, a.steps, a.pre_dgamma, a.pre_strain, a.sizes)
            for n in a.n for s in range(a.first_seed, a.first_seed + a.samples)]
    return map_jobs(sample, jobs, a.workers,
                    f"φ = {a.phi}, δγ = {a.dgamma}, {a.steps} steps, steady after "
                    f"{a.pre_strain} in steps of {a.pre_dgamma}; sizes {a.sizes}")


def map_jobs(sample, jobs: list, workers: int, protocol: str) -> list[dict]:
    """``sample(job)`` for every job, in order, on ``workers`` processes one job at a time (in
    this process if 1); the results' CPU time (their ``cpu``), the wall time and ``protocol``
    printed to stderr."""
    t0 = time.time()
    if workers == 1:
        results = [sample(j) for j in jobs]
    else:
        with ProcessPoolExecutor(workers) as ex:
            results = list(ex.map(sample, jobs, chunksize=1))
    print(f"{len(results)} samples, {sum(r['cpu'] for r in results):.0f} CPU s, "
          f"{time.time() - t0:.0f} s wall; {protocol}\n", file=sys.stderr)
    return results


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_protocol_arguments(ap, samples=120, pre_strain=0.2, sizes="mono")
    ap.add_argument("--boot", type=int, default=200)
    ap.add_argument("--min-tail", type=int, default=50)
    ap.add_argument("--x-min", type=float, nargs="*", default=[],
                    help="also τ of both protocols at these fixed x_min (ε)")
    ap.add_argument("--x-max", type=float, nargs="*", default=[],
                    help="with --x-min: those fits truncated at these x_max (ε) instead of at "
                         "the largest size, a table each")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--load", type=Path, nargs="+", action="append", default=None,
                    help="reprint the tables of these --out files instead of shearing "
                         "(repeatable: with --pool, one set per --load)")
    ap.add_argument("--pool", action="store_true",
                    help="pool the files of each --load (one φ, other N or seeds): one table "
                         "and one panel per --load")
    ap.add_argument("--figure", type=Path, default=None,
                    help="draw S n(S) per N, one panel per run or loaded file (.png/.pdf/.svg)")
    a = ap.parse_args(argv)
    from jamlab.runs import check_figure_path

    check_figure_path(ap, a.figure, [])
    if any(not x > 0 for x in a.x_min + a.x_max):
        ap.error("--x-min and --x-max need values > 0")
    if a.x_max and not a.x_min:
        ap.error("--x-max truncates the fits of --x-min: give --x-min too")
    if a.min_tail < 2:
        ap.error("--min-tail: at least 2 (a power-law fit needs two sizes)")
    if a.pool and a.load is None:
        ap.error("--pool pools the files of --load")
    if a.load is not None:
        files = [f for group in a.load for f in group]
        missing = [f for f in files if not f.is_file()]
        if missing:
            ap.error(f"--load {missing[0]}: no such file")
        if not a.pool:
            sets = [(f.stem, load(f)) for f in files]
        else:  # one set per --load
            sets = []
            for group in a.load:
                results = [r for f in group for r in load(f)]
                seen = [(r["n"], r["seed"]) for r in results]
                if len(set(seen)) < len(seen):
                    ap.error("--pool: a sample (N, seed) is in more than one file of a --load")
                sets.append((" + ".join(f.stem for f in group), results))
        for name, results in sets:
            if len(sets) > 1:
                print(f"\n## {name}\n")
            table(results, a.boot, a.min_tail, tuple(a.x_min), tuple(a.x_max))
        if a.figure is not None:
            figure(a.figure, sets)
        return
    results = run_jobs(ap, a, one_sample)
    if a.out is not None:
        save(a.out, results)
    table(results, a.boot, a.min_tail, tuple(a.x_min), tuple(a.x_max))
    if a.figure is not None:
        figure(a.figure, [(f"φ = {a.phi}, {a.sizes}", results)])


if __name__ == "__main__":
    main()
