"""Does a packing's starting density predict its large avalanches? Per fixed-pressure run.

For each run directory (φ label ``jamming``, one ``N`` per run) and each finished packing: φ at
its first row (``phi_step``, the packing brought to the run's pressure), the change of φ over the
run (last row less first), and of its counted avalanches (plastic, ``ΔH < 0``, between jammed
minima: :func:`jamlab.reproduce.ensembles.avalanche_set`) the largest ``S``, their sum and how
many reach ``--above``. Printed per run: φ₀'s mean and spread, Spearman's ρ of φ₀ against each of
those (scipy's p-value, two-sided, one test of several: not corrected), and the packings of the
``--largest`` avalanches with φ₀ in standard units of the run (``z``) and their change of φ.
``--pool``: the same over all runs of one ``N`` together (the realisations of one study, whose
packings are drawn alike), with the counts of avalanches ≥ ``--above`` in the looser and the
denser half of the packings by φ₀ and the binomial p-value of that split (two-sided, even odds).

    PYTHONPATH=src python scripts/start_density.py data/runs/n500-p1e-5-vg \
        data/runs/n500-p1e-5-vg-s1 data/runs/n500-p1e-5-vg-s2 data/runs/n500-p1e-5-vg-s3 \
        --n 500 --above 1e-6 --pool
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy import stats

from jamlab.reproduce.ensembles import avalanche_set, finished, last_rows
from jamlab.runs import add_run_arguments, open_run, sizes_per_run


class Packings(NamedTuple):
    """Per finished packing of a run: φ at the first and last row, and its counted sizes."""

    phi_start: np.ndarray
    phi_end: np.ndarray
    sizes: tuple


def read_run(run: Path, n: int) -> Packings:
    """:class:`Packings` of the finished samples at ``("jamming", n)`` of a run directory;
    ``ValueError`` for a run without per-row φ (made before trace format 2)."""
    ds = open_run(run)
    if "phi_step" not in ds:
        raise ValueError(f"{run}: no per-row φ (phi_step): not a fixed-pressure run of format 2")
    phi = np.asarray(ds.phi_step.sel(phi="jamming", N=n).values)[finished(ds, "jamming", n)]
    last = last_rows(phi)
    sizes = avalanche_set(ds, "jamming", n).per_sample
    return Packings(phi[:, 0], phi[np.arange(len(last)), last], tuple(sizes))


def summary(p: Packings, above: float) -> dict:
    """Per packing ``S_max`` (0 without avalanches), ``ΣS`` and the count ``≥ above``; Spearman's
    ``(ρ, p)`` of φ₀ against the change of φ and each of those three."""
    smax = np.array([s.max() if s.size else 0.0 for s in p.sizes])
    total = np.array([s.sum() for s in p.sizes])
    count = np.array([int(np.sum(s >= above)) for s in p.sizes])
    out = {"smax": smax, "total": total, "count": count}
    for key, y in (("dphi", p.phi_end - p.phi_start), ("smax", smax), ("total", total),
                   ("count", count)):
        r = stats.spearmanr(p.phi_start, y)
        out[f"rho_{key}"] = (float(r.statistic), float(r.pvalue))
    return out


def halves(phi_start: np.ndarray, count: np.ndarray) -> tuple[int, int, float]:
    """The avalanches counted in the looser half of the packings by φ₀ (the ``⌊k/2⌋`` smallest;
    ties by position), in the rest, and the two-sided binomial p-value of that split with the
    odds of the halves' sizes."""
    order = np.argsort(phi_start, kind="stable")
    loose = np.zeros(phi_start.size, dtype=bool)
    loose[order[: phi_start.size // 2]] = True
    a, b = int(count[loose].sum()), int(count[~loose].sum())
    if a + b == 0:
        return a, b, 1.0
    return a, b, float(stats.binomtest(a, a + b, loose.mean()).pvalue)


def report(name: str, p: Packings, above: float, largest: int) -> dict:
    """Print one run's (or pool's) lines; returns its :func:`summary`."""
    s = summary(p, above)
    z = (p.phi_start - p.phi_start.mean()) / p.phi_start.std(ddof=1)
    dphi = p.phi_end - p.phi_start
    cells = "; ".join(f"{label} {s[key][0]:+.2f} (p {s[key][1]:.2g})" for label, key in (
        ("Δφ", "rho_dphi"), ("S_max", "rho_smax"), ("ΣS", "rho_total"),
        (f"#S ≥ {above:.0e}", "rho_count")))
    print(f"{name}: {p.phi_start.size} packings, φ₀ {p.phi_start.mean():.5f} ± "
          f"{p.phi_start.std(ddof=1):.5f}, Δφ {dphi.mean():+.2e} ± {dphi.std(ddof=1):.1e}; "
          f"Spearman ρ of φ₀ with {cells}")
    for i in np.argsort(-s["smax"], kind="stable")[:largest]:
        print(f"    S_max {s['smax'][i]:.3g}: z(φ₀) {z[i]:+.1f}, Δφ {dphi[i]:+.2e}")
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap)
    ap.add_argument("--above", type=float, default=1e-6, help="S counted per packing (ε)")
    ap.add_argument("--largest", type=int, default=4, help="packings of the largest S_max listed")
    ap.add_argument("--pool", action="store_true", help="also the runs of one N together")
    a = ap.parse_args()
    ns = sizes_per_run(ap, a)
    if not a.above > 0 or a.largest < 0:
        ap.error("--above must be > 0 and --largest >= 0")
    try:
        read = [(run, n, read_run(run, n)) for run, n in zip(a.runs, ns, strict=True)]
    except (ValueError, KeyError, FileNotFoundError) as err:
        ap.error(str(err))
    for run, n, p in read:
        if p.phi_start.size < 3:
            ap.error(f"{run}: {p.phi_start.size} finished packings at N = {n}, need 3")
        report(f"{run.name} (N = {n})", p, a.above, a.largest)
    if a.pool:
        for n in sorted(set(ns)):
            parts = [p for _, m, p in read if m == n]
            pooled = Packings(np.concatenate([p.phi_start for p in parts]),
                              np.concatenate([p.phi_end for p in parts]),
                              tuple(s for p in parts for s in p.sizes))
            s = report(f"pooled, N = {n} ({len(parts)} runs)", pooled, a.above, a.largest)
            loose, dense, pval = halves(pooled.phi_start, s["count"])
            print(f"    avalanches ≥ {a.above:.0e}: {loose} in the looser half of the packings by "
                  f"φ₀, {dense} in the denser (binomial p = {pval:.2g})")


if __name__ == "__main__":
    main()
