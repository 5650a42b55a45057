"""Where along the strain window the avalanches of finished runs happen, and in which state.

The avalanches of a run are pooled over its whole strain window (``γ`` from 0 to
``gamma_max``). That is one ensemble only if the state does not drift along the window. For each
run directory (φ label ``jamming`` at ``--n``, finished samples), the window is cut into
``--parts`` equal parts of steps, and for each part:

- the stress ratio ``μ = σ_xy/p`` (``σ_xy = Σ/V`` with each minimum's box volume,
  :func:`jamlab.reproduce.ensembles.intensive_stress`; ``p`` the recorded pressure of each
  minimum), averaged over the part's minima and then over the samples, ± its standard error over
  the samples;
- the change of ``φ`` over the part, averaged over the samples (at fixed pressure the box
  relaxes: dilatancy shows as ``Δφ < 0``);
- the avalanches counted by the report's rule (:func:`jamlab.reproduce.ensembles.counted_steps`:
  plastic, ``ΔE < 0``, both minima jammed) with ``S`` at or above each floor of ``--above``, summed
  over the samples, with the χ² of their spread over the parts against a constant rate (its p-value
  assumes independent avalanches; a guide, not a test).

    PYTHONPATH=src python scripts/strain_window.py RUNS/n250-p1e-6-fix40 RUNS/n500-p1e-6-fix \\
        RUNS/n1000-p1e-6 --n 250 500 1000 --above 1e-10 1e-8 --fit-at 1e-10 3e-10

With ``--fit-at``, τ with an exponential cut-off at each fixed floor is fitted separately in each
of ``--fit-parts`` (default 2) equal parts of the window, with the difference between the first
and the last part in units of their combined σ: does the exponent drift along the window?
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy import stats

from jamlab.analysis import fit_cutoff_power_law
from jamlab.reproduce.ensembles import counted_steps, finished, intensive_stress
from jamlab.runs import add_run_arguments, open_run, sizes_per_run


def window_parts(ds, n: int, parts: int, floors: list[float]) -> dict:
    """The per-part statistics of the module docstring for the finished samples at
    ``("jamming", n)``: ``mu`` and ``mu_err`` (per part), ``dphi`` (per part), ``counts``
    (``{floor: per part}``), ``samples``, ``steps`` (per sample) and ``edges`` (the first step of
    each part, and the number of steps)."""
    done = finished(ds, "jamming", n)
    if not done.any():
        raise ValueError(f"no finished sample at N = {n}")
    sigma = intensive_stress(ds, "jamming", n)
    pressure = np.asarray(ds.pressure.sel(phi="jamming", N=n).values)[done]
    phi = np.asarray(ds.phi_step.sel(phi="jamming", N=n).values)[done]
    ej, counted = counted_steps(ds, "jamming", n)
    steps = ej.shape[1]
    if not 1 <= parts <= steps:
        raise ValueError(f"parts must be in [1, {steps}], got {parts}")
    edges = np.linspace(0, steps, parts + 1).round().astype(int)
    mu = sigma / pressure
    per_sample = np.array([[mu[i, a:b + 1].mean() for a, b in zip(edges[:-1], edges[1:],
                                                                   strict=True)]
                           for i in range(mu.shape[0])])
    m = per_sample.shape[0]
    mu_err = (per_sample.std(axis=0, ddof=1) / np.sqrt(m) if m > 1
              else np.full(parts, np.nan))
    dphi = np.array([(phi[:, b] - phi[:, a]).mean() for a, b in zip(edges[:-1], edges[1:],
                                                                    strict=True)])
    counts = {}
    for floor in floors:
        hit = counted & (-ej >= floor)
        counts[floor] = np.array([int(hit[:, a:b].sum()) for a, b in zip(edges[:-1], edges[1:],
                                                                          strict=True)])
    return {"mu": per_sample.mean(axis=0), "mu_err": mu_err, "dphi": dphi, "counts": counts,
            "samples": m, "steps": steps, "edges": edges}


def part_sizes(ds, n: int, parts: int) -> list[np.ndarray]:
    """The counted avalanche sizes ``S = −ΔE`` (ε) of the finished samples at ``("jamming", n)``
    in each of ``parts`` equal parts of the steps (the parts of :func:`window_parts`)."""
    if not finished(ds, "jamming", n).any():
        raise ValueError(f"no finished sample at N = {n}")
    ej, counted = counted_steps(ds, "jamming", n)
    steps = ej.shape[1]
    if not 1 <= parts <= steps:
        raise ValueError(f"parts must be in [1, {steps}], got {parts}")
    edges = np.linspace(0, steps, parts + 1).round().astype(int)
    return [-ej[:, a:b][counted[:, a:b]] for a, b in zip(edges[:-1], edges[1:], strict=True)]


def part_fits(sizes: list[np.ndarray],
              floor: float) -> list[tuple[int, float, float, float, float] | None]:
    """Per part: the number of sizes at or above ``floor``, τ ± its asymptotic σ and the cut-off
    ``S_c`` ± its σ of the exponential cut-off fit there
    (:func:`jamlab.analysis.fit_cutoff_power_law`, ``x_min`` fixed at ``floor``); ``None`` where
    the part has too few sizes for a fit."""
    out: list[tuple[int, float, float, float, float] | None] = []
    for s in sizes:
        try:
            fit = fit_cutoff_power_law(s, x_min=floor)
        except ValueError:
            out.append(None)
            continue
        out.append((int(np.count_nonzero(s >= floor)), float(fit.tau), float(fit.tau_stderr),
                    float(fit.x_c), float(fit.x_c_stderr)))
    return out


def uniform_chi2(counts: np.ndarray, edges: np.ndarray) -> tuple[float, float]:
    """χ² of ``counts`` against a rate proportional to each part's number of steps, and its
    p-value (``len(counts) − 1`` degrees of freedom); NaN without counts."""
    total = counts.sum()
    if total == 0 or counts.size < 2:
        return float("nan"), float("nan")
    expected = total * np.diff(edges) / edges[-1]
    chi2 = float(np.sum((counts - expected) ** 2 / expected))
    return chi2, float(stats.chi2.sf(chi2, counts.size - 1))


def part_differences(first, last) -> tuple[str, str]:
    """τ(first) − τ(last) and ln S_c(last) − ln S_c(first), each with its size in units of the
    two parts' combined asymptotic σ (``σ(ln S_c) = σ(S_c)/S_c``); "—" without two fits."""
    if first is None or last is None or first is last:
        return "—", "—"
    d_tau = first[1] - last[1]
    d_log = math.log(last[3] / first[3])
    s_log = math.hypot(first[4] / first[3], last[4] / last[3])
    return (f"{d_tau:+.3f} ({d_tau / math.hypot(first[2], last[2]):+.1f} σ)",
            f"{d_log:+.2f} ({d_log / s_log:+.1f} σ)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap, default_n=500)
    ap.add_argument("--parts", type=int, default=10)
    ap.add_argument("--above", type=float, nargs="+", default=[1e-10],
                    help="floors of S (ε) for the avalanche counts")
    ap.add_argument("--fit-at", type=float, nargs="+", default=[],
                    help="floors of S (ε): τ with an exponential cut-off in each of --fit-parts "
                         "parts of the window")
    ap.add_argument("--fit-parts", type=int, default=2)
    a = ap.parse_args()
    n_of_run = sizes_per_run(ap, a)
    if a.parts < 1:
        ap.error("--parts must be >= 1")
    if not all(x > 0 for x in a.above):
        ap.error("--above floors must be > 0")
    if not all(x > 0 for x in a.fit_at):
        ap.error("--fit-at floors must be > 0")
    if a.fit_parts < 1:
        ap.error("--fit-parts must be >= 1")
    for run, n in zip(a.runs, n_of_run, strict=True):
        w = window_parts(open_run(run), n, a.parts, a.above)
        print(f"\n{run} (N = {n}): {w['samples']} finished samples, {w['steps']} steps each; "
              f"{a.parts} parts\n")
        print("| part (steps) | μ = σ_xy/p | Δφ | " + " | ".join(
            f"avalanches ≥ {x:.0e}" for x in a.above) + " |")
        print("|---|---|---|" + "---|" * len(a.above))
        for k in range(a.parts):
            lo, hi = w["edges"][k], w["edges"][k + 1]
            print(f"| {lo + 1}–{hi} | {w['mu'][k]:.3f} ± {w['mu_err'][k]:.3f} | "
                  f"{w['dphi'][k]:+.2e} | "
                  + " | ".join(str(w["counts"][x][k]) for x in a.above) + " |")
        for x in a.above:
            chi2, p = uniform_chi2(w["counts"][x], w["edges"])
            print(f"avalanches ≥ {x:.0e}: χ² against a constant rate {chi2:.1f} "
                  f"({a.parts - 1} dof), p = {p:.3g} (independent avalanches assumed)")
        if a.fit_at:
            ds = open_run(run)
            sizes = part_sizes(ds, n, a.fit_parts)
            print(f"\nτ, exponential cut-off at fixed floors, in {a.fit_parts} parts of the "
                  "window (sizes in the fit; cut-off S_c in ε)\n")
            print("| floor | " + " | ".join(f"part {k + 1}" for k in range(a.fit_parts))
                  + " | τ: first − last (σ) | ln S_c: last − first (σ) |")
            print("|---|" + "---|" * (a.fit_parts + 2))
            for floor in a.fit_at:
                fits = part_fits(sizes, floor)
                cells = [f"{f[1]:.3f} ± {f[2]:.3f}, S_c {f[3]:.1e} ± {f[4]:.0e} ({f[0]})"
                         if f else "too few" for f in fits]
                print(f"| {floor:.0e} | " + " | ".join(cells) + " | "
                      + " | ".join(part_differences(fits[0], fits[-1])) + " |")


if __name__ == "__main__":
    main()
