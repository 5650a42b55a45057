"""Two runs of the same packings at different strain steps or box-side rules, packing by packing.

Two run directories of one study that differ only in ``dgamma`` or in the fixed-pressure box-side
rule ``volume_guess`` (the sample seeds, and so the
prepared packings, depend on the sample's index only: ``jamlab.runs.seeds``) shear the same packings
over the same strain window. For each packing in both (finished samples at the ``jamming`` label and
``--n``) and each floor of ``--above``, the avalanches counted by the report's rule
(:func:`jamlab.reproduce.ensembles.avalanche_set`: plastic, ``ΔE < 0``, both minima jammed) with
``S`` at or above the floor, per unit strain, and their summed size per unit strain (the dissipation
above the floor: merging two events in one step leaves it unchanged, missing one lowers it). Printed
per floor: both runs' means over the packings, the mean paired difference (b − a) ± its standard
error over the packings, and the Wilcoxon signed-rank p-value of the paired differences
(``scipy.stats.wilcoxon``; packings differ much more from one another than a packing's two runs,
which is what the pairing removes).

    PYTHONPATH=src python scripts/paired_rates.py RUNS/n250-p1e-6-fix40 \\
        RUNS/n250-p1e-6-dg5e-6 --n 250 --above 1e-11 1e-10 1e-9 1e-8
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from jamlab.reproduce.ensembles import avalanche_set, finished
from jamlab.runs import RunDir, open_run

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare_runs import PROTOCOL, study_differences  # noqa: E402  (scripts run as scripts)

MAY_DIFFER = ("dgamma", "samples", "checkpoint_every", *PROTOCOL)


def per_packing(ds, n: int, floors: list[float]) -> dict:
    """``{sample index: (counts, sums)}`` of the finished samples at ``("jamming", n)``: per
    floor, the number of counted avalanches with ``S ≥ floor`` and the sum of their sizes, each
    divided by the sample's strain window (the ``gamma`` of its last row)."""
    done = finished(ds, "jamming", n)
    index = np.asarray(ds.sample.values)[done]
    gamma = np.asarray(ds.gamma.sel(phi="jamming", N=n).values)[done]
    sizes = avalanche_set(ds, "jamming", n).per_sample
    out = {}
    for row, (i, s) in enumerate(zip(index, sizes, strict=True)):
        strain = float(gamma[row, -1] - gamma[row, 0])
        out[int(i)] = (np.array([np.count_nonzero(s >= f) / strain for f in floors]),
                       np.array([s[s >= f].sum() / strain for f in floors]))
    return out


def paired(a: dict, b: dict, k: int, which: int) -> tuple[np.ndarray, np.ndarray]:
    """The values of floor ``k`` (``which`` 0: counts, 1: sums) of the packings in both."""
    common = sorted(set(a) & set(b))
    return (np.array([a[i][which][k] for i in common]),
            np.array([b[i][which][k] for i in common]))


def wilcoxon_p(x: np.ndarray, y: np.ndarray) -> float:
    """Two-sided Wilcoxon signed-rank p-value of ``y − x``; 1 when every difference is 0."""
    d = y - x
    if not np.any(d != 0):
        return 1.0
    return float(stats.wilcoxon(d).pvalue)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--above", type=float, nargs="+", default=[1e-10])
    args = ap.parse_args()
    if not all(x > 0 for x in args.above):
        ap.error("--above floors must be > 0")
    study, differ = study_differences(ap, (args.a, args.b), MAY_DIFFER)
    if differ:
        ap.error(f"the two runs differ in more than the strain step and the box-side rule "
                 f"({', '.join(differ)})")
    rule = [RunDir(r).study().volume_guess for r in (args.a, args.b)]
    a = per_packing(open_run(args.a), args.n, args.above)
    b = per_packing(open_run(args.b), args.n, args.above)
    common = sorted(set(a) & set(b))
    if len(common) < 2:
        ap.error(f"{len(common)} packing(s) in both runs: need 2 or more")
    print(f"{len(common)} packings in both; a = {args.a} (δγ = {study[0]['dgamma']:g}, "
          f"volume_guess {rule[0]}), b = {args.b} (δγ = {study[1]['dgamma']:g}, volume_guess "
          f"{rule[1]}); per unit strain, mean over the "
          "packings; b − a paired, ± its standard error; Wilcoxon signed-rank p\n")
    print("| S ≥ (ε) | avalanches a | b | b − a | p | ΣS a (ε) | b | b − a | p |")
    print("|---|---|---|---|---|---|---|---|---|")
    for k, floor in enumerate(args.above):
        cells = []
        for which, fmt in ((0, ".1f"), (1, ".3g")):
            x, y = paired(a, b, k, which)
            d = y - x
            cells.append(f"{x.mean():{fmt}} | {y.mean():{fmt}} | {d.mean():+{fmt}} ± "
                         f"{d.std(ddof=1) / np.sqrt(d.size):{fmt}} | {wilcoxon_p(x, y):.3g}")
        print(f"| {floor:.0e} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
