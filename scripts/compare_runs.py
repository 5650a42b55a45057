"""Two run directories of one study (same seeds), compared sample by sample and pooled.

For a change of the code that should alter only some steps (e.g. the fixed-pressure saddle test,
``barostat.leave_saddle``), run the same ``jamlab run`` study with the code before and
after into two directories and compare: per sample, whether the ``plastic`` flags, the
``jammed`` flags and the energies are equal, and at how many steps they differ; pooled over the
samples both hold, the unjammed minima and excluded steps, the number of avalanches (plastic
steps between jammed minima, :func:`jamlab.analysis.avalanches.avalanche_sizes`), the plastic
fraction, ``⟨S⟩``, and the two-sample KS test on the sizes (``scipy.stats.ks_2samp``), all sizes
and those at or above ``--s-min``; with ``--fit-at`` τ with an exponential cut-off at fixed
``S_min`` in each run; the avalanches the two runs share (at the same step of a sample, and of
the same size: do the two follow the same minima?); and the cost of the common samples in each
run (FIRE iterations summed over the trace, machine-independent; the recorded CPU seconds). The
studies must agree but for the sample count, the checkpoint interval and the protocol choices of
``PROTOCOL`` (the box-side rule ``volume_guess``), which are printed.

    PYTHONPATH=src python scripts/compare_runs.py RUN_A RUN_B [--s-min 1.19e-11]
        [--fit-at 1.19e-11 1.11e-10]

``--independent``: two *realisations* of one study, which may differ in the master ``seed`` too
(``jamlab run --seed``): their samples are other packings, so nothing is compared sample by
sample; every finished sample of each run is pooled, and the KS tests get a second p-value from
``--permutations`` exchanges of whole packings between the runs (seed 0): the avalanches of a
packing are not independent, the packings are.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import h5py
import numpy as np
from scipy.stats import ks_2samp

from jamlab.analysis import fit_cutoff_power_law
from jamlab.analysis.avalanches import classify_steps, exclusions

NOT_PHYSICS = ("samples", "checkpoint_every")
PROTOCOL = ("volume_guess",)  # a protocol choice these comparisons are made for: printed


def study_differences(ap: argparse.ArgumentParser, runs: tuple[Path, Path],
                      may_differ: tuple[str, ...]) -> tuple[list[dict], list[str]]:
    """The ``study`` of each run's manifest, and the keys (sorted) outside ``may_differ`` in which
    the two differ; ``ap.error`` (exit 2) for a directory without a manifest."""
    for run in runs:
        if not (run / "manifest.json").is_file():
            ap.error(f"{run} is not a run directory (no manifest.json)")
    study = [json.loads((r / "manifest.json").read_text())["study"] for r in runs]
    return study, sorted(k for k in set(study[0]) | set(study[1])
                         if k not in may_differ and study[0].get(k) != study[1].get(k))


def samples(run: Path) -> dict[str, Path]:
    return {f"{p.parent.name}/{p.stem}": p for p in sorted(run.glob("samples/*/*/sample-*.h5"))}


def read(path: Path) -> dict[str, np.ndarray]:
    """The trace columns compared, and the sample's cost where recorded: ``iterations`` (FIRE's,
    summed over the trace) and ``cpu`` (the sample's ``cpu_seconds``), NaN where absent."""
    with h5py.File(path, "r") as h5:
        out = {k: h5["trace"][k][()] for k in ("energy", "energy_jump", "plastic", "jammed")}
        its = h5["trace"].get("iterations")
        out["iterations"] = float(np.sum(its[()])) if its is not None else np.nan
        out["cpu"] = float(h5.attrs.get("cpu_seconds", np.nan))
    return out


SAME_SIZE = 1e-3  # relative size difference below which an avalanche is the same in both runs


def pair_events(masks: list[np.ndarray], jumps: list[np.ndarray], paired: dict) -> None:
    """Add to ``paired`` the avalanches of one sample in two runs — ``masks``: each run's steps
    that are avalanches (:func:`jamlab.analysis.avalanches.classify_steps`), ``jumps``: its
    ``ΔE`` per step — at the same step in both (and of them, those of the same size to
    ``SAME_SIZE`` relative), in one only. Two runs whose minimisers follow the same minima share
    their events; then an agreement of their statistics says that, and not that the statistics
    are robust to a different path."""
    n = min(len(masks[0]), len(masks[1]))
    ma, mb = masks[0][:n], masks[1][:n]
    both = ma & mb
    sa, sb = -jumps[0][:n][both], -jumps[1][:n][both]
    paired["both"] += int(both.sum())
    paired["same size"] += int(np.sum(np.abs(sa - sb) <= SAME_SIZE * np.abs(sa)))
    paired["a only"] += int(np.sum(ma & ~mb))
    paired["b only"] += int(np.sum(mb & ~ma))


def tally(t: dict[str, np.ndarray], acc: dict) -> tuple[np.ndarray, np.ndarray]:
    """Add one sample's trace ``t`` (:func:`read`) to the pooled counts ``acc``; returns its
    avalanche steps (``classify_steps``) and its ``ΔE`` per step."""
    jammed = t["jammed"].astype(bool)
    # row 0 of the trace is the start: steps 1..M, minima 0..M
    jump, plastic = t["energy_jump"][1:], t["plastic"][1:].astype(bool)
    mask = classify_steps(jump, plastic, jammed=jammed)
    ex = exclusions(jump, jammed, plastic)
    acc["S"].append(-jump[mask])  # the avalanche sizes (jamlab.analysis.avalanches.avalanche_sizes)
    acc["steps"] += ex.n_steps
    acc["plastic"] += int(mask.sum())
    acc["unjammed"] += int(np.sum(~jammed))
    acc["excluded"] += ex.n_steps_excluded
    acc["iterations"].append(t["iterations"])
    acc["cpu"].append(t["cpu"])
    return mask, jump


def packing_ks(a: list[np.ndarray], b: list[np.ndarray],
               permutations: int) -> tuple[float, float, float]:
    """``(D, p, p over packings)``: the two-sample KS statistic of the pooled sizes of the
    packings ``a`` and ``b`` (lists of per-packing arrays, already cut to the sizes compared),
    its p-value for independent avalanches, and the fraction of ``permutations`` random
    exchanges of whole packings between the two groups (sizes kept) with ``D`` at least as large
    (``(1 + hits) / (1 + P)``; NaN for ``P = 0``)."""
    cut = list(a) + list(b)
    k = len(a)

    def stat(order):
        pa = np.concatenate([cut[i] for i in order[:k]])
        pb = np.concatenate([cut[i] for i in order[k:]])
        return ks_2samp(pa, pb).statistic if pa.size and pb.size else 0.0

    obs = ks_2samp(np.concatenate(cut[:k]), np.concatenate(cut[k:]))
    if permutations <= 0:
        return float(obs.statistic), float(obs.pvalue), float("nan")
    rng = np.random.default_rng(0)
    hits = sum(stat(rng.permutation(len(cut))) >= obs.statistic - 1e-12
               for _ in range(permutations))
    return float(obs.statistic), float(obs.pvalue), (1 + hits) / (1 + permutations)


def cost(values: list[float], fmt: str) -> str:
    """Mean over the samples and range, ``–`` where a sample does not record it."""
    v = np.asarray(values, dtype=float)
    if v.size == 0 or np.isnan(v).any():
        return "–"
    return f"{v.mean():{fmt}} ({v.min():{fmt}}–{v.max():{fmt}})"


def sem(x: np.ndarray) -> float:
    """Standard error of the mean; NaN with fewer than two values (undefined, not a warning)."""
    return float(x.std(ddof=1) / np.sqrt(len(x))) if len(x) >= 2 else float("nan")


def mean_pm(x: np.ndarray) -> str:
    """``mean ± sem``, ``–`` without values."""
    return f"{x.mean():.3e} ± {sem(x):.1e}" if len(x) else "–"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--s-min", type=float, default=None,
                    help="also compare the sizes at or above this (ε)")
    ap.add_argument("--fit-at", type=float, nargs="+", default=[],
                    help="τ with an exponential cut-off fitted at these fixed S_min (ε) in each "
                         "run (asymptotic σ; jamlab.analysis.fit_cutoff_power_law)")
    ap.add_argument("--independent", action="store_true",
                    help="two realisations (the seed may differ): pooled, not sample by sample")
    ap.add_argument("--permutations", type=int, default=1000,
                    help="with --independent: exchanges of whole packings for the KS p-values")
    args = ap.parse_args(argv)
    if args.permutations < 0:
        ap.error(f"--permutations must be >= 0, got {args.permutations}")
    # the sample count and the checkpoint interval do not change a sample (a resumed sample
    # equals the uninterrupted one bit for bit)
    may_differ = NOT_PHYSICS + PROTOCOL + (("seed",) if args.independent else ())
    _, differ = study_differences(ap, (args.a, args.b), may_differ)
    if differ:
        ap.error(f"the two runs are of different studies ({', '.join(differ)})")
    from jamlab.runs import RunDir

    for key in PROTOCOL:  # as each run was made (RunDir.study: a manifest from before a choice
        # existed reads as the rule of its time)
        values = [getattr(RunDir(r).study(), key) for r in (args.a, args.b)]
        if values[0] != values[1]:
            print(f"{key}: {values[0]!r} (a), {values[1]!r} (b)")
    sa, sb = samples(args.a), samples(args.b)
    pooled = {name: {"S": [], "steps": 0, "plastic": 0, "unjammed": 0, "excluded": 0,
                     "iterations": [], "cpu": []}
              for name in ("a", "b")}
    if args.independent:
        if not (sa and sb):
            ap.error("a run without a finished sample")
        for name, found in (("a", sa), ("b", sb)):
            for key in found:
                tally(read(found[key]), pooled[name])
        print(f"two realisations: {args.a}: {len(sa)} samples, {args.b}: {len(sb)}")
        return summary(args, pooled, None)
    common = sorted(set(sa) & set(sb))
    if not common:
        ap.error("no sample is in both runs")
    print(f"{len(common)} samples in both ({args.a}: {len(sa)}, {args.b}: {len(sb)})")
    print("| sample | plastic differ at | jammed differ at | energies equal (rows) | "
          "first row that differs | first unjammed row of a | unjammed a / b |")
    print("|---|---|---|---|---|---|---|")
    firsts = []
    paired = {"both": 0, "same size": 0, "a only": 0, "b only": 0}
    for key in common:
        ta, tb = read(sa[key]), read(sb[key])
        n = min(len(ta["energy"]), len(tb["energy"]))
        dp = np.flatnonzero(ta["plastic"][:n] != tb["plastic"][:n])
        dj = np.flatnonzero(ta["jammed"][:n] != tb["jammed"][:n])
        same = int(np.sum(ta["energy"][:n] == tb["energy"][:n]))
        first = np.flatnonzero(ta["energy"][:n] != tb["energy"][:n])
        first = int(first[0]) if first.size else None
        unj = np.flatnonzero(~ta["jammed"].astype(bool))
        unj = int(unj[0]) if unj.size else None
        firsts.append((first, unj))
        print(f"| {key} | {dp.tolist()[:8]}{' …' if len(dp) > 8 else ''} | "
              f"{dj.tolist()[:8]}{' …' if len(dj) > 8 else ''} | {same} of {n} | {first} | {unj} | "
              f"{int(np.sum(~ta['jammed'].astype(bool)))} / "
              f"{int(np.sum(~tb['jammed'].astype(bool)))} |")
        (ma, ja), (mb, jb) = tally(ta, pooled["a"]), tally(tb, pooled["b"])
        pair_events([ma, mb], [ja, jb], paired)
    diverged = [f for f in firsts if f[0] is not None]
    at = sum(1 for f, u in diverged if u is not None and f == u)
    print(f"\n{len(diverged)} samples differ; in {at} the first differing row is the first "
          f"unjammed minimum of a")
    return summary(args, pooled, paired)


def summary(args: argparse.Namespace, pooled: dict, paired: dict | None) -> int:
    """Print the pooled table, the shared events (``paired``; None for two realisations), the KS
    tests and the fits; returns the exit code."""
    sizes = {k: np.concatenate(v["S"]) for k, v in pooled.items()}
    print()
    print("| run | steps | unjammed minima | excluded steps | avalanches | plastic fraction | "
          "⟨S⟩ (ε) | FIRE iterations per sample | CPU s per sample |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, run in (("a", args.a), ("b", args.b)):
        acc = pooled[name]
        print(f"| {run} | {acc['steps']} | {acc['unjammed']} | {acc['excluded']} | "
              f"{acc['plastic']} | {acc['plastic'] / acc['steps']:.4f} | "
              f"{mean_pm(sizes[name])} | "
              f"{cost(acc['iterations'], '.0f')} | {cost(acc['cpu'], '.1f')} |")
    if paired is not None:
        print(f"\nthe same events? avalanches at the same step of the same sample in both runs: "
              f"{paired['both']}, of which {paired['same size']} of the same size to "
              f"{SAME_SIZE:g} relative; in a only: {paired['a only']}, in b only: "
              f"{paired['b only']}")
    perms = args.permutations if paired is None else 0
    extra = f" ({perms} exchanges of whole packings)" if perms else ""

    def ks_text(s_min):
        """The KS line of the sizes ``≥ s_min``, cut once, with how many each run has."""
        a, b = ([x[x >= s_min] for x in pooled[k]["S"]] for k in ("a", "b"))
        d, p, pp = packing_ks(a, b, perms)
        counts = f"{sum(x.size for x in a)} / {sum(x.size for x in b)} avalanches"
        return counts, f"D = {d:.4f}, p = {p:.3f}" + (
            f", over packings p = {pp:.3f}" if perms else "")

    print(f"\ntwo-sample KS on all sizes{extra}: {ks_text(-np.inf)[1]}")
    if args.s_min is not None:
        print(f"S ≥ {args.s_min:g}: " + ", ".join(ks_text(args.s_min)))
    for x_min in args.fit_at:
        row = []
        for name in ("a", "b"):
            tail = sizes[name][sizes[name] >= x_min]
            if tail.size < 10:
                row.append(f"{name}: {tail.size} sizes, no fit")
                continue
            fit = fit_cutoff_power_law(sizes[name], x_min=x_min)
            row.append(f"{name}: τ = {fit.tau:.3f} ± {fit.tau_stderr:.3f} ({tail.size} sizes, "
                       f"S_c = {fit.x_c:.2e})")
        print(f"exponential cut-off at S ≥ {x_min:g}: " + "; ".join(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
