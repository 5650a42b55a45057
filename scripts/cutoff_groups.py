"""Does a cut-off that differs along the strain window or between packings make the tail look
stretched? τ shared, one cut-off per group.

The tables of ``docs/reproduce.md`` fit ``p(S) ∝ S^(−τ) e^(−(S/S_c)^a)`` to all the avalanches
of a run at once, and near jamming the data prefer a stretched cut-off (``a ≈ 0.4``) to the
exponential (``a = 1``); the shape left free widens τ's interval. But a sum of exponential
cut-offs with different ``S_c`` also looks stretched, and ``S_c`` is known to grow along the
strain window (``scripts/strain_window.py``). This script fits, at a fixed floor ``--x-min``
(sizes ``S ≥ x_min`` of the counted avalanches, :func:`jamlab.reproduce.ensembles.counted_steps`),

- **one**: one ``S_c`` for all (``a = 1``: exactly :func:`jamlab.analysis.fit_cutoff_power_law`);
- **shape**: one ``S_c`` and the shape ``a`` free on a grid
  (:func:`jamlab.analysis.cutoff_shape_profile`);
- **parts**: ``τ`` shared, one ``S_c`` per part of ``--parts`` equal parts of the window (steps);
- **samples**: ``τ`` shared, one ``S_c`` per packing;

the group models with ``a = 1`` and with ``a`` free on the same grid (``--null REPS``: each
group model's ΔAIC read against data sets drawn from the single stretched law,
:func:`null_daic`, since a cut-off per group is an incidental parameter and the AIC's penalty
for it is only asymptotic — measured: with a cut-off per packing the best ``a`` goes to the
grid's end 2 even when every packing draws from one law with ``a = 0.5``).

Per model: ``τ`` ± its σ (the curvature of the profile likelihood in ``τ``), the maximised
log-likelihood ``ℓ``, the likelihood ratio against **one** (``χ²`` with the number of extra
cut-offs as degrees of freedom) and Akaike's ``AIC = 2 k − 2 ℓ`` against **shape**. For the
models with the shape free: the 95 % profile-likelihood interval of ``τ`` over the shapes
(σ = its width / 3.92, as the tables of ``docs/reproduce.md`` quote it) and ``2Δℓ`` of the
best shape against ``a = 1``. If the groups explain the shape, the group model with ``a = 1``
is as good as **shape** (ΔAIC ≲ 0) and its own best ``a`` is near 1. Groups without a size at
or above the floor carry no information and are left out (their
count is printed). With ``--pool`` the runs share ``τ`` (the groups are then per run). With
``--skip K`` the first ``K`` steps of every sample are left out (a loading transient).

    PYTHONPATH=src python scripts/cutoff_groups.py data/runs/n1000-p1e-5-vg --n 1000 \\
        --x-min 1.21e-9 --parts 4
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from scipy import optimize, stats

from jamlab.analysis import (
    cutoff_power_law_log_norm,
    cutoff_shape_profile,
    sample_cutoff_power_law,
    shape_free_interval,
)
from jamlab.analysis.cutoff_powerlaw import DEFAULT_STRETCHES
from jamlab.reproduce.ensembles import counted_steps, finished
from jamlab.runs import add_run_arguments, open_run, sizes_per_run

STRETCHES = DEFAULT_STRETCHES
"""The grid of cut-off shapes ``a``: that of :func:`jamlab.analysis.cutoff_shape_profile`."""

TAU_RANGE = (0.0, 2.5)
"""Where the profile likelihood in ``τ`` is searched."""


def group_sizes(sizes: np.ndarray, counted: np.ndarray, by: str, parts: int) -> list[np.ndarray]:
    """The counted sizes of ``(samples, steps)`` arrays, one array per group: per row (``by =
    "samples"``), per part of ``parts`` equal parts of the steps (``"parts"``), or one group
    (``"one"``)."""
    if by == "one":
        return [sizes[counted]]
    if by == "samples":
        return [row[m] for row, m in zip(sizes, counted, strict=True)]
    if by == "parts":
        steps = sizes.shape[1]
        if not 1 <= parts <= steps:
            raise ValueError(f"parts must be in [1, {steps}], got {parts}")
        edges = np.linspace(0, steps, parts + 1).round().astype(int)
        return [sizes[:, a:b][counted[:, a:b]] for a, b in zip(edges[:-1], edges[1:], strict=True)]
    raise ValueError(f"by must be one, samples or parts, got {by!r}")


def _stats(groups: list[np.ndarray], x_min: float, stretch: float) -> list[tuple]:
    """Per group with data at or above ``x_min``: ``(k, Σ log S, Σ S^a, max S)``."""
    out = []
    for g in groups:
        t = np.asarray(g, dtype=np.float64)
        t = t[t >= x_min]
        if t.size:
            out.append((t.size, float(np.log(t).sum()), float((t**stretch).sum()), float(t.max())))
    return out


def _group_nll(log_sc: float, tau: float, k: int, sum_log: float, sum_pow: float,
               x_min: float, stretch: float) -> float:
    sc = math.exp(log_sc)
    return (tau * sum_log + sum_pow * math.exp(-stretch * log_sc)
            + k * cutoff_power_law_log_norm(tau, sc, x_min, stretch))


def _profile(tau: float, st: list[tuple], x_min: float, stretch: float) -> tuple[float, list]:
    """``−ℓ`` maximised over every group's ``log S_c`` at this ``τ``, and the ``log S_c``."""
    total, cuts = 0.0, []
    lo = math.log(x_min) - 5.0
    for k, sl, sp, smax in st:
        hi = math.log(smax) + 7.0
        r = optimize.minimize_scalar(_group_nll, bounds=(lo, hi), method="bounded",
                                     args=(tau, k, sl, sp, x_min, stretch),
                                     options={"xatol": 1e-9})
        total += float(r.fun)
        cuts.append(float(r.x))
    return total, cuts


def fit_groups(groups: list[np.ndarray], x_min: float, stretch: float = 1.0) -> dict:
    """τ shared by the groups, one cut-off ``S_c`` each, shape ``a = stretch``, at ``S ≥ x_min``:
    ``tau``, ``tau_stderr`` (from the curvature of the profile ``ℓ(τ)``), ``loglik`` (the
    maximised log-likelihood of the sizes, ``Σ log p(S)``), ``cutoffs`` (``S_c`` per group used),
    ``groups_used``, ``groups_empty`` and ``n_tail``."""
    if not (math.isfinite(x_min) and x_min > 0):
        raise ValueError(f"x_min must be finite and > 0, got {x_min!r}")
    st = _stats(groups, x_min, stretch)
    n_tail = sum(s[0] for s in st)
    if n_tail < 10:
        raise ValueError(f"need at least 10 sizes at or above x_min={x_min:g}, got {n_tail}")

    def f(tau: float) -> float:
        return _profile(tau, st, x_min, stretch)[0]

    grid = np.linspace(TAU_RANGE[0] + 0.05, TAU_RANGE[1] - 0.05, 25)
    vals = [f(t) for t in grid]
    i = int(np.argmin(vals))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    r = optimize.minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 1e-7})
    tau = float(r.x)
    h = 1e-3
    curv = (f(tau + h) - 2.0 * float(r.fun) + f(tau - h)) / h**2
    nll, cuts = _profile(tau, st, x_min, stretch)
    return {"tau": tau, "tau_stderr": 1.0 / math.sqrt(curv) if curv > 0 else math.nan,
            "loglik": -nll, "cutoffs": [math.exp(c) for c in cuts], "groups_used": len(st),
            "groups_empty": len(groups) - len(st), "n_tail": n_tail}


def best_shape(groups: list[np.ndarray], x_min: float,
               stretches: tuple[float, ...] = STRETCHES) -> dict:
    """:func:`fit_groups` on each ``a`` of the grid: the ``a`` of the largest ``ℓ`` and that fit
    (``a``, ``fit``; every fit by ``a`` in ``fits``), ``lr_exponential = 2 (ℓ_best − ℓ(a = 1))``
    and the 95 % profile-likelihood
    interval of ``τ`` with the shape free (``tau_low``, ``tau_high``:
    :func:`jamlab.analysis.shape_free_interval`, the rule of
    :func:`jamlab.analysis.cutoff_shape_profile`)."""
    fits = {a: fit_groups(groups, x_min, a) for a in stretches}
    a = max(fits, key=lambda s: fits[s]["loglik"])
    best = fits[a]["loglik"]
    lr = 2.0 * (best - fits[1.0]["loglik"]) if 1.0 in fits else math.nan
    low, high = shape_free_interval([f["tau"] for f in fits.values()],
                                    [f["tau_stderr"] for f in fits.values()],
                                    [f["loglik"] for f in fits.values()])
    return {"a": a, "fit": fits[a], "fits": fits, "lr_exponential": lr, "tau_low": low,
            "tau_high": high}


def compare(groups_by_model: dict[str, list[np.ndarray]], x_min: float) -> list[dict]:
    """The rows printed for one data set: model, shape, τ ± σ, ℓ, parameters, LR against **one**
    with its p, ΔAIC against **shape**."""
    one = fit_groups(groups_by_model["one"], x_min, 1.0)
    prof = cutoff_shape_profile(np.concatenate(groups_by_model["one"]), x_min, STRETCHES)
    best = max(prof.logliks)
    aic_shape = 2 * 3 - 2 * best
    rows = [{"model": "one", "a": 1.0, "tau": one["tau"], "sigma": one["tau_stderr"],
             "loglik": one["loglik"], "k": 2, "lr": math.nan, "p": math.nan, "groups": 1,
             "n_tail": one["n_tail"]},
            {"model": "shape", "a": prof.best, "tau": prof.tau_best, "sigma": prof.tau_best_stderr,
             "loglik": best, "k": 3, "lr": 2 * (best - one["loglik"]),
             "p": float(stats.chi2.sf(2 * (best - one["loglik"]), 1)), "groups": 1}]
    for name in ("parts", "samples"):
        if name not in groups_by_model:
            continue
        g = groups_by_model[name]
        free = best_shape(g, x_min)
        for label, fit, a in (("a = 1", free["fits"][1.0], 1.0),
                              ("a free", free["fit"], free["a"])):
            k = fit["groups_used"] + 1 + (1 if label == "a free" else 0)
            lr = 2 * (fit["loglik"] - one["loglik"])
            rows.append({"model": f"{name}, {label}", "a": a, "tau": fit["tau"],
                         "sigma": fit["tau_stderr"], "loglik": fit["loglik"], "k": k, "lr": lr,
                         "p": float(stats.chi2.sf(lr, k - 2)), "groups": fit["groups_used"],
                         "empty": fit["groups_empty"]})
            if label == "a = 1":
                rows[-1]["cutoffs"] = fit["cutoffs"]
            if label == "a free":
                rows[-1]["interval"] = (free["tau_low"], free["tau_high"])
                rows[-1]["lr_exponential"] = free["lr_exponential"]
    rows[1]["interval"] = (prof.tau_low, prof.tau_high)
    rows[1]["lr_exponential"] = prof.lr_exponential
    for r in rows:
        r["daic"] = 2 * r["k"] - 2 * r["loglik"] - aic_shape
    return rows


def null_daic(groups_by_model: dict[str, list[np.ndarray]], x_min: float, reps: int,
              seed: int = 0) -> dict[str, np.ndarray]:
    """ΔAIC against **shape** of every model of :func:`compare`, on ``reps`` data sets drawn from
    the best single stretched law (the **shape** fit: its ``τ``, ``S_c`` and ``a``;
    :func:`jamlab.analysis.sample_cutoff_power_law`), with the observed number of sizes at or
    above ``x_min`` in every group; the groups of each grouping are a random partition of one
    drawn pool (the null: the cut-off does not differ between groups). The AIC's penalty is
    only asymptotic when every group brings its own cut-off (incidental parameters), so the
    observed ΔAIC is read against this distribution: ``p = (1 + #(null ≤ observed))/(1 +
    reps)``. ``{model: array of reps}``; ``numpy.random.default_rng(seed)``."""
    pool = np.concatenate(groups_by_model["one"])
    prof = cutoff_shape_profile(pool, x_min, STRETCHES)
    k = prof.stretches.index(prof.best)
    tau, x_c, a = prof.taus[k], prof.x_cs[k], prof.best
    counts = {name: [int((np.asarray(g) >= x_min).sum()) for g in groups]
              for name, groups in groups_by_model.items() if name != "one"}
    rng = np.random.default_rng(seed)
    out: dict[str, list[float]] = {}
    for _ in range(reps):
        draw = sample_cutoff_power_law(prof.n_tail, tau, x_c, x_min, rng, stretch=a)
        sim: dict[str, list[np.ndarray]] = {"one": [draw]}
        for name, c in counts.items():
            sim[name] = np.split(rng.permutation(draw), np.cumsum(c)[:-1])
        for row in compare(sim, x_min):
            out.setdefault(row["model"], []).append(row["daic"])
    return {m: np.asarray(v) for m, v in out.items()}


def run_groups(runs: list[Path], ns: list[int], parts: int,
               skip: int = 0) -> dict[str, list[np.ndarray]]:
    """The groups of every run (concatenated over runs: a pooled fit shares τ, and every run has
    its own parts and packings), from the steps after the first ``skip`` of each sample (the
    parts then divide what is left)."""
    out: dict[str, list[np.ndarray]] = {"one": [], "parts": [], "samples": []}
    for run, n in zip(runs, ns, strict=True):
        ds = open_run(run)
        if not finished(ds, "jamming", n).any():
            raise ValueError(f"{run}: no finished sample at N = {n}")
        ej, counted = counted_steps(ds, "jamming", n)
        if not 0 <= skip < ej.shape[1]:
            raise ValueError(f"skip must be in [0, {ej.shape[1]}), got {skip}")
        sizes, counted = -ej[:, skip:], counted[:, skip:]
        out["one"].append(sizes[counted])
        out["parts"] += group_sizes(sizes, counted, "parts", parts)
        out["samples"] += group_sizes(sizes, counted, "samples", parts)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap)
    ap.add_argument("--x-min", type=float, required=True, help="the floor of S (ε)")
    ap.add_argument("--parts", type=int, default=4, help="parts of the strain window")
    ap.add_argument("--pool", action="store_true", help="one τ for all the runs")
    ap.add_argument("--null", type=int, default=0, metavar="REPS",
                    help="data sets drawn from the single stretched law, for the p of each "
                         "ΔAIC (null_daic)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--skip", type=int, default=0,
                    help="leave out the first SKIP steps of every sample (a loading transient)")
    a = ap.parse_args()
    ns = sizes_per_run(ap, a)
    if not (math.isfinite(a.x_min) and a.x_min > 0):
        ap.error("--x-min must be finite and > 0")
    if a.parts < 1:
        ap.error("--parts must be >= 1")
    if a.null < 0 or a.skip < 0:
        ap.error("--null and --skip must be >= 0")
    sets = [(a.runs, ns)] if a.pool else [([r], [n]) for r, n in zip(a.runs, ns, strict=True)]
    for runs, n in sets:
        try:
            groups = run_groups(runs, n, a.parts, a.skip)
            groups["one"] = [np.concatenate(groups["one"])]
            rows = compare(groups, a.x_min)
            null = null_daic(groups, a.x_min, a.null, a.seed) if a.null else {}
        except ValueError as e:
            raise SystemExit(f"error: {e}") from None
        names = " + ".join(f"{r} (N = {m})" for r, m in zip(runs, n, strict=True))
        print(f"\n{names}: S ≥ {a.x_min:.3g} ε, {rows[0]['n_tail']} sizes, {a.parts} parts of "
              f"the strain window" + (f" after its first {a.skip} steps" if a.skip else "")
              + "\n")
        head = f" under the single stretched law ({a.null} data sets): median, p" if null else ""
        print("| model | groups (empty) | a | τ ± σ | ℓ | parameters | 2Δℓ against one (p) "
              f"| ΔAIC against shape{head} |")
        print("|---|---|---|---|---|---|---|---|")
        for r in rows:
            lr = "—" if math.isnan(r["lr"]) else f"{r['lr']:.1f} ({r['p']:.2g})"
            extra = ""
            if r["model"] in null and r["model"] not in ("one", "shape"):
                v = null[r["model"]]
                pv = (1 + int((v <= r["daic"]).sum())) / (1 + v.size)
                extra = f"; {np.median(v):+.1f}, p {pv:.2g}"
            shape = ""
            if "interval" in r:
                lo, hi = r["interval"]
                shape = (f"; shape free: [{lo:.3f}, {hi:.3f}] (σ {(hi - lo) / 3.92:.3f}), "
                         f"exponential 2Δℓ {r['lr_exponential']:.1f}")
            print(f"| {r['model']} | {r['groups']} ({r.get('empty', 0)}) | {r['a']:g} | "
                  f"{r['tau']:.3f} ± {r['sigma']:.3f}{shape} | {r['loglik']:.2f} | {r['k']} | "
                  f"{lr} | {r['daic']:+.1f}{extra} |")
        for r in rows:
            if r["model"] == "parts, a = 1":
                print("\nS_c per part (a = 1, ε): " + ", ".join(f"{c:.3g}" for c in r["cutoffs"]))


if __name__ == "__main__":
    main()
