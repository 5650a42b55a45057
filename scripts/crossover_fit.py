"""A crossover from the UNSAT exponent to τ_J, fitted to the avalanches of fixed-pressure runs.

The mean-field picture above jamming (SPEC §1): the Parisi function is that of jamming down to
a scale set by the distance from jamming and regular (UNSAT-like, ``τ = 1``) below it, so the
jumps of a packing at pressure ``p`` should follow ``S^(−1)`` below a crossover size ``S*`` and
``S^(−τ)`` above it, up to the finite-size cut-off. This script fits that description,

    P(S) ∝ S^(−τ₀) (1 + S/S*)^(τ₀ − τ) e^(−S/S_c)   on S ≥ S_min,   τ₀ = 1 (``--tau0``),

by maximum likelihood in ``(τ, S*, S_c)`` (normaliser by Simpson's rule in ``log S`` on 4001
points, checked against ``scipy.integrate.quad`` at every optimum: the script stops if they
differ by more than 1e-8), with the 95 % profile-likelihood interval of ``τ`` (``S*`` and
``S_c`` re-optimised on a grid of ``τ``), and beside it the best stretched cut-off
(:func:`jamlab.analysis.cutoff_shape_profile`, the report's third row) on the same window: both
models have three free parameters, so their log-likelihoods compare directly.

Windows (``S ≥ S_min``): the report's cut-off row (its KS rule) and each ``--smin``.

    PYTHONPATH=src python scripts/crossover_fit.py RUNS/pressure-1e-04 --n 500 1000
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import integrate, optimize

from jamlab.analysis import CHI2_1_95, cutoff_shape_profile
from jamlab.reproduce.ensembles import avalanche_set
from jamlab.reproduce.measurements import fit_tau_cutoff
from jamlab.reproduce.scales import SCALES
from jamlab.runs import open_run

_POINTS = 4001


def log_density(s: np.ndarray, tau0: float, tau: float, log_star: float, log_c: float):
    """``log`` of the unnormalised density at ``s``."""
    ls = np.log(s)
    return -tau0 * ls + (tau0 - tau) * np.logaddexp(0.0, ls - log_star) - np.exp(ls - log_c)


def log_norm(s_min: float, tau0: float, tau: float, log_star: float, log_c: float) -> float:
    """``log ∫_{S_min}^∞`` of the density, by Simpson's rule in ``u = log S`` up to 60 ``S_c``
    (where ``e^(−S/S_c)`` is below 1e-26)."""
    lo = math.log(s_min)
    u = np.linspace(lo, max(log_c + math.log(60.0), lo + 1.0), _POINTS)
    g = log_density(np.exp(u), tau0, tau, log_star, log_c) + u
    m = float(g.max())
    w = np.exp(g - m)
    h = u[1] - u[0]
    return m + math.log(h / 3 * (w[0] + w[-1] + 4 * w[1:-1:2].sum() + 2 * w[2:-1:2].sum()))


def quad_log_norm(s_min: float, tau0: float, tau: float, log_star: float, log_c: float):
    """The same integral by adaptive quadrature in ``u`` (the check)."""
    lo = math.log(s_min)
    hi = max(log_c + math.log(60.0), lo + 1.0)
    ref = float(log_density(np.array([s_min]), tau0, tau, log_star, log_c)[0]) + lo
    val, _ = integrate.quad(
        lambda u: math.exp(float(log_density(np.array([math.exp(u)]), tau0, tau, log_star,
                                             log_c)[0]) + u - ref),
        lo, hi, limit=400, epsabs=0.0, epsrel=1e-12, points=[log_star, log_c])
    return ref + math.log(val)


def loglik(tail: np.ndarray, s_min: float, tau0: float, tau: float, ls: float, lc: float):
    return float(log_density(tail, tau0, tau, ls, lc).sum()
                 - tail.size * log_norm(s_min, tau0, tau, ls, lc))


def fit(tail: np.ndarray, s_min: float, tau0: float, tau_fixed: float | None = None):
    """``(ℓ, τ, log S*, log S_c)`` at the maximum (over ``τ`` too unless ``tau_fixed``)."""
    lo, hi = math.log(s_min), math.log(float(tail.max()))

    def nll(x):
        tau, ls, lc = (tau_fixed, *x) if tau_fixed is not None else x
        if not -1.0 < tau < 4.0 or not lo - 10 < ls < hi + 10 or not lo < lc < hi + 15:
            return 1e300
        return -loglik(tail, s_min, tau0, tau, ls, lc)

    best = None
    for ls in np.linspace(lo, hi, 5):
        for lc in (hi - 1.0, hi + 1.0, hi + 3.0):
            for t in ((1.3, 1.6) if tau_fixed is None else (None,)):
                x0 = [ls, lc] if tau_fixed is not None else [t, ls, lc]
                r = optimize.minimize(nll, x0, method="Nelder-Mead",
                                      options=dict(xatol=1e-7, fatol=1e-9, maxiter=8000,
                                                   maxfev=16000))
                if best is None or r.fun < best.fun:
                    best = r
    x = (tau_fixed, *best.x) if tau_fixed is not None else tuple(best.x)
    return -float(best.fun), *(float(v) for v in x)


def report(s: np.ndarray, s_min: float, tau0: float, name: str) -> None:
    tail = np.sort(s[s >= s_min])
    ll, tau, ls, lc = fit(tail, s_min, tau0)
    simpson, ref = log_norm(s_min, tau0, tau, ls, lc), quad_log_norm(s_min, tau0, tau, ls, lc)
    if abs(simpson - ref) > 1e-8:
        raise SystemExit(f"{name}: Simpson's normaliser {simpson} and quad's {ref} differ")
    grid = np.round(np.arange(tau - 0.5, tau + 0.51, 0.05), 3)
    prof = [(t, fit(tail, s_min, tau0, float(t))[0]) for t in grid if -1.0 < t < 4.0]
    inside = [t for t, v in prof if 2.0 * (ll - v) <= CHI2_1_95]
    edge = bool(inside) and (inside[0] == prof[0][0] or inside[-1] == prof[-1][0])
    shape = cutoff_shape_profile(tail, s_min)
    best_shape = max(shape.logliks)
    print(f"| {name} | S ≥ {s_min:.3g} ({tail.size}) | {tau:.3f} | "
          + (f"{min(inside):.2f} – {max(inside):.2f}" + (" (grid's end)" if edge else "")
             if inside else "—")
          + f" | {math.exp(ls):.2g} | {math.exp(lc):.2g} | a = {shape.best:g}: "
            f"{shape.tau_best:.3f} [{shape.tau_low:.2f}, {shape.tau_high:.2f}] | "
            f"{2.0 * (ll - best_shape):+.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--n", type=int, nargs="+", default=[1000], help="sizes N, each on its own")
    ap.add_argument("--pooled", action="store_true", help="also the sizes of all --n pooled")
    ap.add_argument("--tau0", type=float, default=1.0, help="the exponent below S* (τ_UNSAT)")
    ap.add_argument("--smin", type=float, nargs="*", default=[])
    a = ap.parse_args()
    scale = replace(SCALES["medium"], n_boot=0)
    print(f"τ₀ = {a.tau0:g} below S*; 2Δlog L: the crossover model against the best "
          "stretched cut-off (both three free parameters)\n")
    print("| run, N | window (sizes) | τ above S* | 95 % profile interval | S* | S_c | "
          "best stretched cut-off: τ [interval] | 2Δlog L |")
    print("|---|---|---|---|---|---|---|---|")
    for run in a.runs:
        ds = open_run(run)
        sets = {n: avalanche_set(ds, "jamming", n).sizes for n in a.n if n in ds.N.values}
        if a.pooled and len(sets) > 1:
            sets["pooled"] = np.concatenate(list(sets.values()))
        for n, s in sets.items():
            cut = fit_tau_cutoff(s, scale)
            for s_min in ([cut.x_min] if cut is not None else []) + list(a.smin):
                if np.count_nonzero(s >= s_min) >= 50:
                    report(s, s_min, a.tau0, f"{run.name}, N = {n}")


if __name__ == "__main__":
    main()
