"""Is the stretched cut-off significant with whole packings as the independent units?

For the avalanches of finished run directories (φ label ``jamming`` at ``--n``, jammed steps
only, as the report counts them) at or above ``--floor`` (S in ε), the test of the exponential
cut-off ``a = 1`` against ``e^(−(S/S*)^a)`` by :func:`jamlab.analysis.clustered_shape_test`:
each run alone, runs of one ``N`` pooled, and, with two ``N`` or more, the joint model of
``tau_window.py --joint`` (one τ, ``S*(N) ∝ N^β``). Printed per row: the continuous MLE ``â``,
τ there and at ``a = 1``, ``W = 2Δlog L``, the design effect ``λ̂`` (how much the
correlation within a packing inflates ``W``; 1 for independent avalanches), the ``χ²₁`` p-value
of ``W`` (every avalanche independent: the reading of ``tau_window.py --joint-stretch``) and the
adjusted one (``F(1, K − 1)`` of ``W / max(λ̂, 1)``, ``K`` packings), and τ's standard error at
``â`` from the inverse information and from the sandwich over packings.

``--profile A …`` (with two ``N`` or more): also the joint fits of
:func:`jamlab.analysis.joint_shape_profile` at the cut-off shapes ``A`` and 1 (``--boot``
resamples of whole packings each, seed 0), and τ's shape-free 95 % interval
(:func:`jamlab.analysis.joint_shape_free`, bootstrap σ of each shape) twice: with the set of
shapes ``2Δlog L ≤ 3.84`` as in ``tau_window.py --joint-stretch``, and widened for the
correlation within packings, ``2Δlog L / max(λ̂, 1) ≤ 3.84`` with the joint row's ``λ̂``.

``--replicate N=K …`` (with two ``N`` or more): one more joint row, with every packing of size
``N`` counted ``K`` times: a projection of what ``K`` times the packings at that size would give
if the new packings were like the measured ones (the sandwich σ then falls as ``1/√K`` when every
size is replicated alike; replicating one size also re-weights the sizes, so ``â`` and τ move,
which shows how much each size pulls the joint fit). With ``--profile`` the shape-free intervals
are printed for the projected set too. A planning aid, not a measurement.

``--resample N=M …`` (with two ``N`` or more): the same projection without assuming the new
packings are copies of the measured ones. ``--draws`` times (seed ``--seed``), ``M`` packings of
size ``N`` are drawn with replacement from the measured packings of that size and added to them,
and the joint row is fitted again; printed are the median and the 10–90 % range over the draws
of ``â``, ``τ(â)`` and τ's sandwich σ, and the fraction of draws with σ ≤ ``--target``. A
draw whose information matrix is not positive definite at ``â`` has no σ: the σ range is over
the others, their count is printed, and they count as not ≤ ``--target``. The spread is what
the packing-to-packing variation of the measured ones allows; new packings may still differ
from all of them.

``--take K …`` (one per run): read only each run's first ``K`` finished packings (by sample
index; 0 for all), e.g. to remake a projection from a run that has since grown.

``--subsets N=K …``: is one run's shape odd among its size's? ``--draws`` random subsets of
``K`` packings of size ``N`` (without replacement, seed ``--seed``) are fitted alone; printed
are the median and 10–90 % range of ``â`` and ``τ(â)`` over the subsets, and for each run of
that size the fraction of subsets whose ``â`` is at least as far from the median as the run's.

    PYTHONPATH=src python scripts/shape_significance.py data/runs/n250-p1e-5-vg \\
        data/runs/n500-p1e-5-vg data/runs/n1000-p1e-5-vg --n 250 500 1000 --floor 1.05e-9 \\
        --profile 0.15 0.2 0.25 0.3 0.35 0.4 0.5 0.6 0.7 0.85 1.25 1.5 2.0
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from jamlab.analysis import (
    clustered_shape_test,
    joint_shape_free,
    joint_shape_profile,
)
from jamlab.reproduce.measurements import avalanche_set
from jamlab.runs import add_run_arguments, open_run, sizes_per_run


def row(label: str, sizes, floor: float) -> str:
    """One table row of :func:`clustered_shape_test` on ``sizes`` (a list of per-packing arrays,
    or ``{N: list}``)."""
    return result_row(label, sizes, floor)[0]


def result_row(label: str, sizes, floor: float):
    """``(row, the test's result or None)`` (:func:`row`)."""
    try:
        r = clustered_shape_test(sizes, floor)
    except ValueError as err:
        return f"| {label} | {err} |", None
    edge = " (bound)" if r.at_bound else ""
    lam = "unresolved" if math.isnan(r.scale) else f"{r.scale:.2f}"
    return (f"| {label} | {r.samples} | {r.n_tail} | {r.stretch:.2f}{edge} | {r.tau:.3f} | "
            f"{r.tau_null:.3f} | {r.lr:.2f} | {lam} | {r.p_naive:.2g} | {r.p_adjusted:.2g} | "
            f"{r.tau_se:.3f} / {r.tau_se_robust:.3f} |"), r


def replicated(by_n: dict, factors: dict) -> dict:
    """``by_n`` with the packings of each size ``N`` in ``factors`` repeated ``factors[N]``
    times (:func:`main`'s ``--replicate``)."""
    missing = sorted(set(factors) - set(by_n))
    if missing:
        raise ValueError(f"--replicate names sizes without runs: {missing}")
    return {n: list(samples) * factors.get(n, 1) for n, samples in by_n.items()}


def resampled(by_n: dict, adds: dict, rng: np.random.Generator) -> dict:
    """``by_n`` with ``adds[N]`` packings of each size ``N`` in ``adds`` drawn with replacement
    from its measured packings and appended (:func:`main`'s ``--resample``)."""
    missing = sorted(set(adds) - set(by_n))
    if missing:
        raise ValueError(f"--resample names sizes without runs: {missing}")
    out = {}
    for n, samples in by_n.items():
        picks = rng.integers(0, len(samples), adds.get(n, 0))
        out[n] = list(samples) + [samples[i] for i in picks]
    return out


def spread(values, digits: int) -> str:
    """``median [10 %, 90 %]`` of ``values`` to ``digits`` decimals."""
    q = np.percentile(values, [50, 10, 90])
    return f"{q[0]:.{digits}f} [{q[1]:.{digits}f}, {q[2]:.{digits}f}]"


def fitted(sets, floor: float) -> list:
    """:func:`clustered_shape_test` of each set of packings in ``sets`` (taken in turn), those
    whose fit fails left out."""
    results = []
    for packings in sets:
        try:
            results.append(clustered_shape_test(packings, floor))
        except ValueError:
            pass
    return results


def resampled_rows(by_n: dict, adds: dict, floor: float, draws: int, seed: int,
                   target: float) -> list:
    """Print the ``--resample`` projection (module docstring); returns the results of the
    draws whose fit succeeded."""
    rng = np.random.default_rng(seed)
    results = fitted((resampled(by_n, adds, rng) for _ in range(draws)), floor)
    label = ", ".join(f"N = {n} +{m}" for n, m in sorted(adds.items()))
    print(f"\nProjected by resampling packings ({label}; {draws} draws, seed {seed}; "
          "median [10 %, 90 %]):")
    if not results:
        print("- no draw could be fitted")
        return results

    sig = np.array([r.tau_se_robust for r in results])
    known = np.isfinite(sig)
    sandwich = (f"σ_τ sandwich {spread(sig[known], 3)}" if known.any()
                else "σ_τ sandwich undefined")
    if not known.all():  # H not positive definite at â: no error to quote for that draw
        sandwich += f" ({np.count_nonzero(~known)} draws with H not positive definite at â)"
    print(f"- {len(results)} of {draws} draws fitted, {results[0].samples} packings each: "
          f"â {spread([r.stretch for r in results], 2)}, "
          f"τ(â) {spread([r.tau for r in results], 3)}, {sandwich}; "
          f"σ_τ ≤ {target:g} in {np.mean(sig <= target):.0%} of them (undefined counted as not)")
    return results


def subset_rows(samples: list, k: int, floor: float, draws: int, seed: int,
                runs: list) -> list:
    """Print the ``--subsets`` spread (module docstring) of ``draws`` random ``k``-packing
    subsets of ``samples``; ``runs`` are ``(name, â)`` of the runs to place in it. Returns the
    subsets' fitted ``â``."""
    if not 3 <= k <= len(samples):
        raise ValueError(f"--subsets needs 3 <= K <= {len(samples)} packings, got {k}")
    rng = np.random.default_rng(seed)
    fits = fitted(([samples[i] for i in rng.choice(len(samples), k, replace=False)]
                   for _ in range(draws)), floor)
    print(f"\nRandom {k}-packing subsets of the {len(samples)} (draws {draws}, seed {seed}; "
          "median [10 %, 90 %]):")
    if not fits:
        print("- no subset could be fitted")
        return []
    a = np.array([f.stretch for f in fits])
    print(f"- {len(fits)} of {draws} fitted: â {spread(a, 2)}, "
          f"τ(â) {spread([f.tau for f in fits], 3)}")
    middle = np.median(a)
    for name, value in runs:
        far = np.mean(np.abs(a - middle) >= abs(value - middle))
        print(f"- {name}: â {value:.2f}; subsets as far from the median: {far:.0%}")
    return list(a)


def parse_factors(items: list[str], option: str = "--replicate") -> dict:
    """``{N: K}`` from ``["N=K", …]``, K ≥ 1, each N once; ``ValueError`` (naming ``option``)
    otherwise (a repeated N would silently keep only its last K)."""
    out = {}
    for item in items:
        n, sep, k = item.partition("=")
        if not (sep and n.isdigit() and k.isdigit() and int(k) >= 1):
            raise ValueError(f"{option} takes N=K with integers K >= 1, got {item!r}")
        if int(n) in out:
            raise ValueError(f"{option} names N = {int(n)} twice")
        out[int(n)] = int(k)
    return out


def widened(by_n: dict, floor: float, stretches: list, boot: int, scale: float) -> list:
    """Print τ's shape-free interval of the joint fits at ``stretches`` (and 1), with the set of
    shapes as is and widened by the design effect ``scale`` (module docstring); returns the
    two intervals."""
    fits = joint_shape_profile(by_n, floor, stretches, boot)
    print(f"\nShape-free τ of the joint fits (bootstrap σ over packings, {boot} resamples):")
    grid = sorted(fits)
    out = []
    for lam in (1.0, max(scale, 1.0)):
        free = joint_shape_free(fits, lam)
        out.append((free.tau_low, free.tau_high))
        print(f"- 2Δlog L / {lam:.2f} ≤ 3.84: τ in [{free.tau_low:.3f}, {free.tau_high:.3f}] "
              f"(95 %), half-width / 1.96 = {(free.tau_high - free.tau_low) / 3.92:.3f}; a from "
              f"{free.a_low:g} to {free.a_high:g} (grid {grid[0]:g} … {grid[-1]:g})")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap)
    ap.add_argument("--floor", type=float, required=True, help="lower end S of the fits (ε)")
    ap.add_argument("--profile", type=float, nargs="+", default=[],
                    help="cut-off shapes a of the joint profile (two N or more)")
    ap.add_argument("--boot", type=int, default=200, help="bootstrap resamples per shape")
    ap.add_argument("--replicate", nargs="+", default=[], metavar="N=K",
                    help="a projected joint row with each packing of size N counted K times")
    ap.add_argument("--resample", nargs="+", default=[], metavar="N=M",
                    help="projected joint rows with M packings of size N drawn from the measured")
    ap.add_argument("--draws", type=int, default=100, help="draws of --resample and --subsets")
    ap.add_argument("--seed", type=int, default=0,
                    help="seed of the draws of --resample and --subsets")
    ap.add_argument("--target", type=float, default=0.05, help="σ_τ counted by --resample")
    ap.add_argument("--take", type=int, nargs="+", default=[],
                    help="each run's first K finished packings (one per run; 0 for all)")
    ap.add_argument("--subsets", nargs="+", default=[], metavar="N=K",
                    help="the spread of the shape over random K-packing subsets of size N")
    a = ap.parse_args()
    try:
        factors = parse_factors(a.replicate)
        adds = parse_factors(a.resample, "--resample")
        subsets = parse_factors(a.subsets, "--subsets")
    except ValueError as err:
        ap.error(str(err))
    if adds and not set(adds) <= set(a.n):
        ap.error(f"--resample names sizes not in --n: {sorted(set(adds) - set(a.n))}")
    if not set(subsets) <= set(a.n) or (subsets and a.draws < 1):
        ap.error(f"--subsets takes sizes in --n ({sorted(set(a.n))}) and --draws >= 1")
    if adds and (len(set(a.n)) < 2 or a.draws < 1 or not a.target > 0):
        ap.error("--resample needs runs of two N or more, --draws >= 1 and --target > 0")
    if factors and not set(factors) <= set(a.n):
        ap.error(f"--replicate names sizes not in --n: {sorted(set(factors) - set(a.n))}")
    if factors and len(set(a.n)) < 2:
        ap.error("--replicate needs runs of two N or more")
    if a.take and (len(a.take) != len(a.runs) or min(a.take) < 0):
        ap.error(f"--take takes one K >= 0 per run ({len(a.runs)}), got {a.take}")
    sizes_n = sizes_per_run(ap, a)
    if not (math.isfinite(a.floor) and a.floor > 0):
        ap.error(f"--floor must be finite and > 0, got {a.floor}")
    if a.profile and not (all(x > 0 for x in a.profile) and a.boot >= 2
                          and len(set(a.n)) > 1):
        ap.error("--profile needs shapes > 0, --boot >= 2 and runs of two N or more")
    for run in a.runs:
        if not run.is_dir():
            ap.error(f"no run directory {run}")
    read = []  # every run read and its --take checked before anything is printed
    for run, n, take in zip(a.runs, sizes_n, a.take or [0] * len(a.runs), strict=True):
        per_sample = list(avalanche_set(open_run(run), "jamming", n).per_sample)
        if take > len(per_sample):
            ap.error(f"--take {take} for {run}: it has {len(per_sample)} finished packings")
        read.append((run, n, per_sample[:take] if take else per_sample))
    by_n: dict[int, list] = {}
    print(f"Cut-off shape test on S ≥ {a.floor:.3g} ε, whole packings as units\n")
    print("| runs | packings | sizes | â | τ(â) | τ(a = 1) | W | λ̂ | "
          "p, χ²₁ | "
          "p, adjusted | σ_τ at â: H⁻¹ / sandwich |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    shapes: dict[int, list] = {}
    for run, n, per_sample in read:
        by_n.setdefault(n, []).extend(per_sample)
        text, result = result_row(f"{run.name} (N = {n})", per_sample, a.floor)
        print(text)
        if result is not None:
            shapes.setdefault(n, []).append((run.name, result.stretch))
    for n, samples in by_n.items():
        if sum(1 for m in sizes_n if m == n) > 1:
            print(row(f"N = {n} pooled", samples, a.floor))
    for n, k in sorted(subsets.items()):
        try:
            subset_rows(by_n[n], k, a.floor, a.draws, a.seed, shapes.get(n, []))
        except ValueError as err:
            ap.error(str(err))
    if len(by_n) > 1:
        text, joint = result_row(f"joint, N = {sorted(by_n)}, S* ∝ N^β", by_n, a.floor)
        print(text)
        projected = None
        if factors:
            label = ", ".join(f"N = {n} ×{k}" for n, k in sorted(factors.items()))
            copies = replicated(by_n, factors)
            text, projected = result_row(f"joint, projected: {label}", copies, a.floor)
            print(text)
        if adds:
            resampled_rows(by_n, adds, a.floor, a.draws, a.seed, a.target)
        if a.profile and joint is not None:
            widened(by_n, a.floor, a.profile, a.boot, joint.scale)
            if projected is not None:
                print(f"\nProjected ({label}; the bootstrap resamples the copies as packings):")
                widened(copies, a.floor, a.profile, a.boot, projected.scale)


if __name__ == "__main__":
    main()
