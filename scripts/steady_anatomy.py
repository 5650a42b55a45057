"""How far the steady state's avalanches reach: the anatomy of every counted avalanche of the
bidisperse glass above jamming, against its size and the box.

The steady protocol of ``scripts/steady_unsat.py`` (``prepare(n, 3, φ, seed, sizes=...)``,
pre-sheared to ``--pre-strain`` in steps of ``--pre-dgamma`` without classification, then
``--steps`` steps of ``--dgamma``), the last run with ``keep_avalanches=True``: every plastic
step's event field (its non-affine displacement without the linear elastic response of the
minimum before; ``docs/criticality.md``, "Avalanche anatomy"). Kept for each *counted*
avalanche (plastic, both minima jammed, ``S = −ΔE > 0``: the steps ``steady_unsat.py``
counts): ``S``, ``N_eff = PR · N`` (participation of the event field), the largest
displacement, the contacts opened and closed, the particles moved by more than 1e-3 mean
diameters, the localized flag (``N_eff ≤ 10``), the elastic fraction subtracted, and the extent
(principal radii of gyration ``r1 ≥ r2 ≥ r3`` weighted by ``|u|⁴``, and the axis of ``r3``:
``jamlab.analysis.anatomy.event_extent``) beside the radii of the same weights and distances
at random directions (:func:`isotropised`), and the box side.

Printed per N: the share of localized events (of the events and of the released energy), the
median ``N_eff`` and ``N_eff / N`` of all counted avalanches and of the largest tenth by ``S``,
and the least-squares slopes of ``ln N_eff`` and of ``ln (contacts changed)`` on ``ln S`` over
``S ≥ --s-min`` (σ from ``--boot`` resamples of the packings); over the sizes, the slope of
``ln`` (the largest tenth's median ``N_eff`` and contacts changed) on ``ln N``; then per N and
decade of ``S`` the medians of ``N_eff``, contacts changed and the largest displacement; then
the shapes (:func:`shapes`): ``r1/L``, ``r2/r1`` and ``r3/r1`` against the isotropised
reference, and the thin axis's direction; per N the distance of the shape from its reference
(:func:`shape_excess`, ``Δ_a`` with σ over packings: the number that compares ensembles); the
orientation tensor of the thin and the long axis (:func:`orientation`; the long axis,
:func:`long_axes`, in files from 2026-12-06 on).
``--check FILE ...`` compares each sample's counted sizes with the same (N, seed) of
``steady_unsat.py`` result files, bit for bit (keeping the anatomy must not change the run, and a
rerun must reproduce the committed data).

    PYTHONPATH=src python scripts/steady_anatomy.py --phi 0.75 --n 128 256 512 --samples 20 \\
        --workers 2 --pre-strain 0.5 --out anatomy_075.npz --check data/steady/bi075_n128_256.npz \\
        data/steady/bi075_n512.npz
    PYTHONPATH=src python scripts/steady_anatomy.py --load anatomy_075.npz
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

# the steady protocol, its arguments, its job runner and its result files: one implementation
sys.path.insert(0, str(Path(__file__).resolve().parent))
import steady_unsat  # noqa: E402

# the anatomy columns kept per counted avalanche (``trace.avalanches``), and S
COLUMNS = ("n_eff", "max_displacement", "n_opened", "n_closed", "n_moved", "localized",
           "elastic_fraction", "radii", "thin_axis")
# per counted avalanche: the radii of its own weights at random directions (the reference)
NULL = "isotropised_radii"
# kept where a script gives them: the trace rows of the counted avalanches, the control of
# ``scripts/pressure_shape.py`` (the field's values scattered over the packing's particles: its
# radii and their isotropised reference), and the long axis (:func:`long_axes`; runs from
# 2026-12-06, a new session, on)
OPTIONAL = ("rows", "scattered_radii", "scattered_null", "long_axis")
# the components of the orientation tensor printed by :func:`orientation`
Q_COMPONENTS = ((0, 0, "xx"), (1, 1, "yy"), (2, 2, "zz"), (0, 1, "xy"), (0, 2, "xz"),
                (1, 2, "yz"))


def counted_rows(trace) -> np.ndarray:
    """Trace rows ``n ≥ 1`` of the counted avalanches: the steps
    :func:`jamlab.analysis.avalanche_sizes` selects with the plastic and jammed flags (the rule of
    ``steady_unsat.counted_sizes``)."""
    from jamlab.analysis.avalanches import classify_steps

    mask = classify_steps(np.asarray(trace.energy_jump)[1:], np.asarray(trace.plastic)[1:],
                          jammed=np.asarray(trace.jammed))
    return np.flatnonzero(mask) + 1


def records(trace) -> dict[str, np.ndarray]:
    """``S`` and the :data:`COLUMNS` of the counted avalanches of a run with
    ``keep_avalanches=True`` (each counted row is a plastic step, so it has a record)."""
    rows = counted_rows(trace)
    av = trace.avalanches
    where = {int(s): k for k, s in enumerate(np.asarray(av["step"]))}
    missing = [int(r) for r in rows if int(r) not in where]
    if missing:
        raise RuntimeError(f"counted steps without an anatomy record: {missing[:5]}")
    k = np.array([where[int(r)] for r in rows], dtype=np.int64)
    out = {"S": -np.asarray(trace.energy_jump, dtype=np.float64)[rows]}
    for c in COLUMNS:
        out[c] = np.asarray(av[c])[k]
    return out


def event_fields(trace, before: dict[int, tuple]):
    """``(u, positions, box side, strain)`` of each counted avalanche in order: the event field
    rebuilt from the trace's stored displacements (a run with ``avalanche_threshold=0``: every
    particle that moved) at the positions of the minimum before (``before[row] = (positions,
    box side, strain)``). The extent recomputed from the field must equal the recorded one
    (``RuntimeError`` otherwise: the field or the positions would not be the recorder's)."""
    from jamlab.analysis.anatomy import event_extent

    av = trace.avalanches
    where = {int(s): k for k, s in enumerate(np.asarray(av["step"]))}
    off = np.asarray(av["moved_offsets"])
    for row in counted_rows(trace):
        k = where[int(row)]
        pos, length, strain = before[int(row)]
        u = np.zeros_like(pos)
        u[av["moved_index"][off[k]:off[k + 1]]] = av["moved_displacement"][off[k]:off[k + 1]]
        if not np.allclose(event_extent(u, pos, length, strain)[0], av["radii"][k],
                           rtol=1e-12, atol=0.0, equal_nan=True):
            raise RuntimeError(f"row {row}: the rebuilt field does not give the recorded extent")
        yield u, pos, length, strain


def isotropised(fields: list, rng: np.random.Generator, dim: int) -> tuple:
    """``(radii, n_moved)`` of the counted avalanches' event fields (:func:`event_fields`, a
    list): the reference radii (:func:`jamlab.analysis.anatomy.isotropised_radii`) of each, and
    the particles with ``|u| >`` :data:`~jamlab.spheres.aqs.anatomy.MOVED_THRESHOLD` (the
    recorder's ``n_moved`` at its default)."""
    from jamlab.analysis.anatomy import isotropised_radii, moved_particles
    from jamlab.spheres.aqs.anatomy import MOVED_THRESHOLD

    radii, moved = [], []
    for u, pos, length, strain in fields:
        radii.append(isotropised_radii(u, pos, length, strain, rng))
        moved.append(moved_particles(u, MOVED_THRESHOLD)[0].size)
    return np.asarray(radii, dtype=np.float64).reshape(-1, dim), np.asarray(moved)


def long_axes(fields: list, dim: int) -> np.ndarray:
    """The long axis (row 0 of :func:`jamlab.analysis.anatomy.principal_axes`) of each counted
    avalanche's event field (:func:`event_fields`, a list), ``(avalanches, dim)``."""
    from jamlab.analysis.anatomy import principal_axes

    axes = [principal_axes(u, pos, length, strain)[1][0] for u, pos, length, strain in fields]
    return np.asarray(axes, dtype=np.float64).reshape(-1, dim)


def one_sample(job: tuple) -> dict:
    """The steady protocol of ``steady_unsat.one_sample`` with the anatomy kept (every moved
    particle's displacement, and the minima before the plastic steps: :func:`isotropised`)."""
    from jamlab.spheres import aqs

    n, _, seed, dgamma, steps, _, _, _ = job
    t0 = time.process_time()
    _, pre = steady_unsat.steady_start(job)
    before = {}

    def keep_before(row, prev, new):
        before[row] = (np.array(prev.positions), prev.box.length, prev.strain)

    run = aqs.shear(pre.packing, dgamma, n_steps=steps, keep_avalanches=True,
                    avalanche_threshold=0.0, on_plastic=keep_before)
    out = {"n": n, "seed": seed, **records(run.trace),
           "converged": bool(np.all(np.asarray(run.trace.max_force) < 1e-12)),
           "length": float(run.packing.box.length)}
    fields = list(event_fields(run.trace, before))  # rebuilt and checked once
    dim = run.packing.positions.shape[1]
    out[NULL], out["n_moved"] = isotropised(fields, np.random.default_rng(seed), dim)
    out["long_axis"] = long_axes(fields, dim)
    out["cpu"] = time.process_time() - t0
    return out


def save(path: Path, results: list[dict]) -> None:
    arrays = {}
    for i, r in enumerate(results):
        arrays[f"s{i}_meta"] = np.array([r["n"], r["seed"], r["cpu"], float(r["converged"]),
                                         r["length"]])
        for c in ("S", *COLUMNS, NULL):
            arrays[f"s{i}_{c}"] = np.asarray(r[c])
        for c in OPTIONAL:
            if c in r:
                arrays[f"s{i}_{c}"] = np.asarray(r[c])
    np.savez(path, **arrays)


def load(path: Path) -> list[dict]:
    z = np.load(path)
    out, i = [], 0
    while f"s{i}_meta" in z:
        meta = z[f"s{i}_meta"]
        n, seed, cpu, conv = meta[:4]
        r = {"n": int(n), "seed": int(seed), "cpu": float(cpu), "converged": bool(conv),
             "length": float(meta[4]) if meta.size > 4 else float("nan")}
        for c in ("S", *COLUMNS, NULL):
            # files written before the extent existed: NaN radii and axes
            r[c] = (z[f"s{i}_{c}"] if f"s{i}_{c}" in z
                    else np.full((z[f"s{i}_S"].size, 3), np.nan))
        for c in OPTIONAL:
            if f"s{i}_{c}" in z:
                r[c] = z[f"s{i}_{c}"]
        out.append(r)
        i += 1
    return out


def log_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of ``ln y`` on ``ln x`` (NaN with fewer than 2 points or one ``x``)."""
    if x.size < 2 or np.ptp(np.log(x)) == 0:
        return float("nan")
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def packing_slope(samples: list[dict], ycol, s_min: float, boot: int,
                  rng: np.random.Generator) -> tuple[float, float, int]:
    """``(slope, σ, points)``: :func:`log_slope` of ``ycol(sample)`` on ``S`` over the samples'
    avalanches with ``S ≥ s_min`` and ``y > 0``; σ the standard deviation over ``boot``
    resamples of the packings (with replacement)."""
    parts = []
    for r in samples:
        s, y = np.asarray(r["S"], float), np.asarray(ycol(r), float)
        keep = (s >= s_min) & (y > 0)
        parts.append((s[keep], y[keep]))

    def slope(idx):
        s = np.concatenate([parts[i][0] for i in idx])
        y = np.concatenate([parts[i][1] for i in idx])
        return log_slope(s, y), s.size

    best, points = slope(range(len(parts)))
    draws = [slope(rng.integers(0, len(parts), len(parts)))[0] for _ in range(boot)]
    draws = np.asarray(draws)
    draws = draws[np.isfinite(draws)]
    sigma = float(np.std(draws, ddof=1)) if draws.size > 1 else float("nan")
    return best, sigma, points


def changes(r: dict) -> np.ndarray:
    """Contacts opened and closed in each counted avalanche of sample ``r``."""
    return np.asarray(r["n_opened"]) + np.asarray(r["n_closed"])


def top_tenth(samples: list[dict], ycol=lambda r: r["n_eff"]) -> np.ndarray:
    """``ycol`` (default ``N_eff``) of the largest tenth of the pooled counted avalanches by
    ``S``."""
    s = np.concatenate([r["S"] for r in samples])
    y = np.concatenate([np.asarray(ycol(r), float) for r in samples])
    if s.size == 0:
        return y
    return y[s >= np.quantile(s, 0.9)]


def top_slope(groups: list[list[dict]], ycol, boot: int,
              rng: np.random.Generator) -> tuple[float, float]:
    """``(slope, σ)`` of ``ln`` (median ``ycol`` of the largest tenth by ``S``,
    :func:`top_tenth`) on ``ln N`` over ``groups`` (the samples of one N each); σ the standard
    deviation over ``boot`` draws that resample each group's packings (with replacement)."""
    x = np.array([g[0]["n"] for g in groups], float)

    def slope(gs):
        return log_slope(x, np.array([np.median(top_tenth(g, ycol)) for g in gs]))

    draws = np.array([slope([[g[i] for i in rng.integers(0, len(g), len(g))] for g in groups])
                      for _ in range(boot)])
    draws = draws[np.isfinite(draws)]
    return slope(groups), float(np.std(draws, ddof=1)) if draws.size > 1 else float("nan")


def table(results: list[dict], s_min: float, boot: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    ns = sorted({r["n"] for r in results})
    print(f"| N (packings) | counted | localized: events / of S | median N_eff (N_eff/N) | "
          f"largest tenth by S: median N_eff (N_eff/N) | median contacts changed: all / largest "
          f"tenth | "
          f"d ln N_eff / d ln S, S ≥ {s_min:g} (points) | d ln(changes) / d ln S |")
    print("|---|---|---|---|---|---|---|---|")
    tops, top_changes = [], []
    for n in ns:
        g = [r for r in results if r["n"] == n]
        s = np.concatenate([r["S"] for r in g])
        ne = np.concatenate([r["n_eff"] for r in g])
        loc = np.concatenate([r["localized"] for r in g]).astype(bool)
        ch = np.concatenate([changes(r) for r in g])
        top = top_tenth(g)
        tops.append(float(np.median(top)) if top.size else float("nan"))
        top_changes.append(float(np.median(top_tenth(g, changes))) if top.size else float("nan"))
        a, sa, m = packing_slope(g, lambda r: r["n_eff"], s_min, boot, rng)
        b, sb, _ = packing_slope(g, changes, s_min, boot, rng)
        shares = (f"{np.mean(loc):.1%} / {np.sum(s[loc]) / np.sum(s):.1%}" if s.size else "—")
        med = f"{np.median(ne):.1f} ({np.median(ne) / n:.3f})" if s.size else "—"
        medtop = f"{tops[-1]:.1f} ({tops[-1] / n:.3f})" if top.size else "—"
        medch = f"{np.median(ch):.0f} / {top_changes[-1]:.0f}" if s.size else "—"
        print(f"| {n} ({len(g)}) | {s.size} | {shares} | {med} | {medtop} | {medch} | "
              f"{a:.3f} ± {sa:.3f} ({m}) | {b:.3f} ± {sb:.3f} |")
    if len(ns) >= 2 and all(np.isfinite(tops + top_changes)):
        groups = [[r for r in results if r["n"] == n] for n in ns]
        parts = []
        for name, ycol in (("N_eff", lambda r: r["n_eff"]), ("contacts changed", changes)):
            b, sb = top_slope(groups, ycol, boot, rng)
            parts.append(f"of ln (median {name}) {b:.3f} ± {sb:.3f}")
        print(f"\nover N = {', '.join(map(str, ns))}, the largest tenth by S (σ: {boot} "
              f"resamples of each N's packings): slope on ln N " + ", ".join(parts))
    bad = sum(not r["converged"] for r in results)
    print(f"\nall minima converged: {bad == 0} ({bad} samples with a minimum at max|F| ≥ 1e-12)")


def pooled_extent(samples: list[dict]) -> tuple[np.ndarray, ...]:
    """``(S, radii, reference radii, thin axes, box sides, finite)`` of the counted avalanches
    pooled over ``samples`` (``finite``: rows whose radii and reference are both finite)."""
    s = np.concatenate([r["S"] for r in samples])
    radii = np.concatenate([np.asarray(r["radii"], float).reshape(-1, 3) for r in samples])
    null = np.concatenate([np.asarray(r[NULL], float).reshape(-1, 3) for r in samples])
    axis = np.concatenate([np.asarray(r["thin_axis"], float).reshape(-1, 3) for r in samples])
    length = np.concatenate([np.full(np.asarray(r["S"]).size, r["length"]) for r in samples])
    finite = np.all(np.isfinite(radii), axis=1) & np.all(np.isfinite(null), axis=1)
    return s, radii, null, axis, length, finite


def shape_rows(samples: list[dict], top: bool = False) -> dict[str, np.ndarray]:
    """Pooled over ``samples`` (the largest tenth by ``S`` if ``top``): ``r1/L`` (largest
    radius over the box side), the ratios ``r2/r1``, ``r3/r1`` of the avalanches and of their
    isotropised references (``null2``, ``null3``), and ``|n|`` the thin axis's components (rows
    with finite radii only)."""
    s, radii, null, axis, length, keep = pooled_extent(samples)
    if top and s.size:
        keep &= s >= np.quantile(s, 0.9)
    radii, null, axis, length = radii[keep], null[keep], axis[keep], length[keep]
    return {"r1L": radii[:, 0] / length, "r1": radii[:, 0], "r2": radii[:, 1] / radii[:, 0],
            "r3": radii[:, 2] / radii[:, 0], "null2": null[:, 1] / null[:, 0],
            "null3": null[:, 2] / null[:, 0], "axis": np.abs(axis)}


def shapes(results: list[dict], boot: int = 500, seed: int = 0) -> None:
    """Per N, all counted avalanches and the largest tenth by ``S``: the medians of ``r1/L``,
    ``r2/r1`` and ``r3/r1`` against those of the isotropised references (the same weights and
    distances at random directions; Mann–Whitney p of ``r3/r1`` below the reference's), and the
    median ``|n_a|`` of
    the thin axis along flow ``x``, gradient ``y`` and vorticity ``z`` (uniform on [0, 1] for no
    preferred direction: median 0.5; KS p of ``|n_y|`` against it); then over the sizes the
    slopes on ``ln N`` of the largest tenth's median radii (σ: ``boot`` resamples of each N's
    packings) and the thin axis pooled over every N."""
    from scipy import stats

    print("\n| N | which (events) | median r1/L | r2/r1: avalanches / isotropised | r3/r1: "
          "avalanches / isotropised (p, one-sided) | thin axis median |n_x|, |n_y|, |n_z| "
          "(KS p of |n_y|) |")
    print("|---|---|---|---|---|---|")
    for n in sorted({r["n"] for r in results}):
        g = [r for r in results if r["n"] == n]
        for top in (False, True):
            v = shape_rows(g, top)
            which = "largest tenth" if top else "all"
            if v["r1"].size < 3:
                print(f"| {n} | {which} ({v['r1'].size}) | — | — | — | — |")
                continue
            p3 = stats.mannwhitneyu(v["r3"], v["null3"], alternative="less").pvalue
            ks = stats.kstest(v["axis"][:, 1], "uniform").pvalue
            ax = " / ".join(f"{np.median(v['axis'][:, a]):.2f}" for a in range(3))
            print(f"| {n} | {which} ({v['r1'].size}) | {np.median(v['r1L']):.3f} | "
                  f"{np.median(v['r2']):.2f} / {np.median(v['null2']):.2f} | "
                  f"{np.median(v['r3']):.2f} / {np.median(v['null3']):.2f} ({p3:.2g}) | "
                  f"{ax} ({ks:.2g}) |")
    ns = sorted({r["n"] for r in results})
    groups = [[r for r in results if r["n"] == n] for n in ns]
    if len(ns) >= 2 and all(shape_rows(g)["r1"].size for g in groups):
        rng = np.random.default_rng(seed)
        parts = []
        for a in range(3):
            b, sb = top_slope(groups, lambda r, a=a: np.asarray(r["radii"], float)[:, a], boot,
                              rng)
            parts.append(f"r{a + 1} {b:.3f} ± {sb:.3f}")
        print(f"\nover N = {', '.join(map(str, ns))}, the largest tenth by S: slope on ln N of "
              f"ln (median radius) " + ", ".join(parts))
        axis = np.concatenate([shape_rows(g)["axis"] for g in groups])
        cells = [f"|n_{c}| {np.median(axis[:, a]):.3f} "
                 f"(KS p {stats.kstest(axis[:, a], 'uniform').pvalue:.2g})"
                 for a, c in enumerate("xyz")]
        print(f"thin axis pooled over N ({axis.shape[0]} avalanches): " + ", ".join(cells))


def shape_excess(results: list[dict], boot: int = 500, seed: int = 0) -> None:
    """Per N: how far the avalanches' shape lies from their isotropised references,
    ``Δ_a = median(r_a/r1) − median(reference r_a/r1)`` for ``a = 2, 3`` (all counted
    avalanches; negative: flatter or thinner than the same weights at random directions), with
    σ the standard deviation over ``boot`` resamples of the packings — the number that compares
    one ensemble's anisotropy with another's (the reference itself depends on ``N_eff``)."""
    rng = np.random.default_rng(seed)

    def excess(g):
        v = shape_rows(g)
        return [float(np.median(v[f"r{a}"]) - np.median(v[f"null{a}"])) for a in (2, 3)]

    print("\n| N (packings) | Δ2 = r2/r1 − isotropised (σ) | Δ3 = r3/r1 − isotropised (σ) |")
    print("|---|---|---|")
    for n in sorted({r["n"] for r in results}):
        g = [r for r in results if r["n"] == n]
        if shape_rows(g)["r1"].size < 3:
            continue
        best = excess(g)
        draws = np.array([excess([g[i] for i in rng.integers(0, len(g), len(g))])
                          for _ in range(boot)])
        sig = np.nanstd(draws, axis=0, ddof=1)
        print(f"| {n} ({len(g)}) | {best[0]:+.3f} ({sig[0]:.3f}) | {best[1]:+.3f} ({sig[1]:.3f}) |")


def orientation(results: list[dict], boot: int = 500, seed: int = 0) -> None:
    """Per N and pooled over the sizes: the orientation tensor ``Q = ⟨n nᵀ⟩ − I/3``
    (:func:`jamlab.analysis.anatomy.orientation_tensor`) of the counted avalanches' thin axis,
    and of the long axis where every sample has it; each component with σ over ``boot``
    resamples of the packings (pooled: each N's packings resampled apart) and ``Q/σ``; and the
    direction in the flow–gradient plane of the xy block's larger eigenvector (degrees from
    ``x`` toward ``y``; 45°: the stretching diagonal of ``x += δγ y``, δγ > 0)."""
    from jamlab.analysis.anatomy import orientation_tensor

    rng = np.random.default_rng(seed)
    cols = [("thin", "thin_axis")]
    if all("long_axis" in r for r in results):
        cols.append(("long", "long_axis"))
    by_n = {n: [r for r in results if r["n"] == n] for n in sorted({r["n"] for r in results})}
    groups = [(str(n), [g]) for n, g in by_n.items()]
    if len(by_n) > 1:
        groups.append(("pooled " + ", ".join(map(str, by_n)), list(by_n.values())))
    print("\n| N | axis (avalanches) | " + " | ".join(f"Q_{c}" for *_, c in Q_COMPONENTS)
          + " | xy-plane direction (°) |")
    print("|---" * (len(Q_COMPONENTS) + 3) + "|")
    for label, parts in groups:
        for name, col in cols:
            # each packing's axes (avalanches, 3), one list per N of the group
            axes = [[np.asarray(r[col], float).reshape(-1, 3) for r in g] for g in parts]

            def tensor(picks, axes=axes):  # picks[k]: the packings taken from the k-th N
                return orientation_tensor(np.concatenate(
                    [axes[k][i] for k, idx in enumerate(picks) for i in idx]))

            q = tensor([range(len(g)) for g in axes])
            draws = np.array([tensor([rng.integers(0, len(g), len(g)) for g in axes])
                              for _ in range(boot)])
            sig = np.nanstd(draws, axis=0, ddof=1)
            count = int(sum(np.all(np.isfinite(a), axis=1).sum() for g in axes for a in g))
            cells = [f"{q[a, b]:+.3f} ± {sig[a, b]:.3f} "
                     + (f"({q[a, b] / sig[a, b]:+.1f}σ)" if sig[a, b] > 1e-9 else "(—)")
                     for a, b, _ in Q_COMPONENTS]
            angle = 0.5 * np.degrees(np.arctan2(2 * q[0, 1], q[0, 0] - q[1, 1]))
            print(f"| {label} | {name} ({count}) | " + " | ".join(cells) + f" | {angle:+.0f} |")
    print("\n(Q = ⟨n nᵀ⟩ − I/3: 0 for no preferred direction; Q_xy > 0 toward the stretching "
          "diagonal (1, 1, 0)/√2; Q_xz, Q_yz vanish by the shear's mirror z → −z)")


def decade_table(results: list[dict], first: int, last: int, pool, cell) -> None:
    """A table per N (rows) and decade of ``S`` (``[10^k, 10^(k+1))`` ε, ``k = first … last −
    1``; columns): ``pool(samples)`` gives the pooled arrays of one N, ``cell(arrays, mask)``
    the text of a decade (``mask`` over the pooled avalanches)."""
    ks = range(first, last)
    print("\n| N | " + " | ".join(f"S in [1e{k}, 1e{k + 1})" for k in ks) + " |")
    print("|---" * (len(ks) + 1) + "|")
    for n in sorted({r["n"] for r in results}):
        g = [r for r in results if r["n"] == n]
        s = np.concatenate([r["S"] for r in g])
        arrays = pool(g)
        cells = [cell(arrays, (s >= 10.0**k) & (s < 10.0 ** (k + 1))) for k in ks]
        print(f"| {n} | " + " | ".join(cells) + " |")


def shape_decades(results: list[dict], first: int = -7, last: int = 0) -> None:
    """Per N and decade of ``S``: the counted avalanches with an extent, and their median ``r1``
    and ``r3`` (mean diameters) and ``r3/r1`` against the isotropised reference's."""

    def cell(arrays, m):
        _, radii, null, _, _, ok = arrays
        m = m & ok
        if not m.any():
            return "0"
        return (f"{m.sum()}: {np.median(radii[m, 0]):.2f} / {np.median(radii[m, 2]):.2f} / "
                f"{np.median(radii[m, 2] / radii[m, 0]):.2f} "
                f"({np.median(null[m, 2] / null[m, 0]):.2f})")

    decade_table(results, first, last, pooled_extent, cell)
    print("\n(each cell: avalanches: median r1 / r3 (mean diameters) / r3/r1 (isotropised))")


def decades(results: list[dict], first: int = -7, last: int = 0) -> None:
    """Per N and decade of ``S`` (:func:`decade_table`): the counted avalanches, and their median
    ``N_eff``, contacts changed and largest displacement."""

    def pool(g):
        return [np.concatenate([r["n_eff"] for r in g]), np.concatenate([changes(r) for r in g]),
                np.concatenate([r["max_displacement"] for r in g])]

    def cell(cols, m):
        if not m.any():
            return "0"
        return (f"{m.sum()}: {np.median(cols[0][m]):.0f} / {np.median(cols[1][m]):.0f} "
                f"/ {np.median(cols[2][m]):.2g}")

    decade_table(results, first, last, pool, cell)
    print("\n(each cell: avalanches: median N_eff / contacts changed / largest displacement, "
          "mean diameters)")


def figure(path: Path, results: list[dict], first: int = -7, last: int = 0,
           title: str = "counted avalanches of the steady state: event field's extent against "
                        "size") -> None:
    """Three panels against ``S``: ``N_eff`` and the contacts changed of every counted avalanche
    (points, one colour per N) with their medians per decade of ``S`` (lines), and the shape
    ``r3/r1`` (:func:`shape_panel`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13.5, 3.9))
    cols = (("N_eff = PR · N", lambda r: np.asarray(r["n_eff"], float)),
            ("contacts opened + closed", lambda r: changes(r).astype(float)))
    edges = 10.0 ** np.arange(first, last + 1)
    shape_panel(axes[2], results, edges)
    for ax, (label, ycol) in zip(axes[:2], cols, strict=True):
        for n in sorted({r["n"] for r in results}):
            g = [r for r in results if r["n"] == n]
            s = np.concatenate([r["S"] for r in g])
            y = np.concatenate([ycol(r) for r in g])
            keep = y > 0
            dots = ax.loglog(s[keep], y[keep], ".", ms=2.5, alpha=0.35)[0]
            mid, med = [], []
            for a, b in zip(edges[:-1], edges[1:], strict=True):
                m = (s >= a) & (s < b) & keep
                if m.sum() >= 3:
                    mid.append(np.sqrt(a * b))
                    med.append(np.median(y[m]))
            ax.loglog(mid, med, "o-", ms=4, lw=1.2, color=dots.get_color(),
                      label=f"N = {n} ({s.size}), median per decade")
        ax.set_xlabel("S (ε)")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"\nfigure: {path}")


def shape_panel(ax, results: list[dict], edges: np.ndarray) -> None:
    """``r3/r1`` of the counted avalanches against ``S``: medians per decade (≥ 3 avalanches),
    solid, and those of their isotropised references, dashed, one colour per N."""
    for n in sorted({r["n"] for r in results}):
        g = [r for r in results if r["n"] == n]
        s, radii, null, _, _, ok = pooled_extent(g)
        mid, med, ref = [], [], []
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            m = (s >= a) & (s < b) & ok
            if m.sum() >= 3:
                mid.append(np.sqrt(a * b))
                med.append(np.median(radii[m, 2] / radii[m, 0]))
                ref.append(np.median(null[m, 2] / null[m, 0]))
        if mid:
            line = ax.semilogx(mid, med, "o-", ms=4, lw=1.2, label=f"N = {n}")[0]
            ax.semilogx(mid, ref, "--", lw=1, color=line.get_color())
    ax.set_ylim(0, 1)
    ax.set_xlabel("S (ε)")
    ax.set_ylabel("r3 / r1 (median per decade)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, title="dashed: isotropised", title_fontsize=7)


def check(results: list[dict], files: list[Path]) -> int:
    """Print how many samples' counted sizes equal those of the same (N, seed) in ``files``
    (``steady_unsat.py`` results), bit for bit; returns the number that differ."""
    ref = {(r["n"], r["seed"]): r["steady"]["sizes"] for f in files for r in steady_unsat.load(f)}
    same = differ = absent = 0
    for r in results:
        key = (r["n"], r["seed"])
        if key not in ref:
            absent += 1
        elif np.array_equal(np.asarray(r["S"]), np.asarray(ref[key])):
            same += 1
        else:
            differ += 1
            print(f"N = {key[0]}, seed {key[1]}: counted sizes differ from the reference "
                  f"({np.asarray(r['S']).size} against {np.asarray(ref[key]).size})")
    print(f"--check: {same} samples identical bit for bit, {differ} differ, {absent} not in "
          f"the reference files")
    return differ


def add_report_arguments(ap: argparse.ArgumentParser, s_min: float, s_min_help: str,
                         check_help: str) -> None:
    """The arguments of the tables and their inputs, shared with ``pressure_shape.py``:
    ``--boot``, ``--s-min``, ``--out``, ``--load``, ``--figure``, ``--check``."""
    ap.add_argument("--boot", type=int, default=500)
    ap.add_argument("--s-min", type=float, default=s_min, help=s_min_help)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--load", type=Path, nargs="+", default=None,
                    help="reprint the tables of these --out files (pooled) instead of shearing")
    ap.add_argument("--figure", type=Path, default=None,
                    help="draw N_eff, the contacts changed and r3/r1 against S (.png/.pdf/.svg)")
    ap.add_argument("--check", type=Path, nargs="+", default=None, help=check_help)


def check_report_arguments(ap: argparse.ArgumentParser, a: argparse.Namespace) -> None:
    """Refuse (``ap.error``: exit code 2) what :func:`add_report_arguments` cannot use."""
    from jamlab.runs import check_figure_path

    check_figure_path(ap, a.figure, [])
    if not a.s_min > 0 or a.boot < 2:
        ap.error("need --s-min > 0 and --boot >= 2")
    for f in (a.load or []) + (a.check or []):
        if not f.is_file():
            ap.error(f"{f}: no such file")


def report(results: list[dict], a: argparse.Namespace, first: int = -7, last: int = 0,
           title: str | None = None, after_shapes=None) -> None:
    """The tables (participation, per decade of ``S`` from ``1e{first}`` to ``1e{last}``,
    shapes and their distance from the reference, radii per decade) and, with ``--figure``, the
    figure (``title``: its heading, default :func:`figure`'s); ``after_shapes(results)``, if
    given, prints its own table after the shapes' distance."""
    table(results, a.s_min, a.boot)
    decades(results, first, last)
    shapes(results, a.boot)
    shape_excess(results, a.boot)
    if after_shapes is not None:
        after_shapes(results)
    orientation(results, a.boot)
    shape_decades(results, first, last)
    if a.figure is not None:
        figure(a.figure, results, first, last, **({} if title is None else {"title": title}))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    steady_unsat.add_protocol_arguments(ap, samples=20, pre_strain=0.5, sizes="bidisperse")
    add_report_arguments(
        ap, 1e-5, "the slopes use S ≥ this (ε): above the counting rule's rise",
        "steady_unsat.py result files: compare the counted sizes, same (N, seed)")
    a = ap.parse_args(argv)
    check_report_arguments(ap, a)
    if a.load is not None:
        results = [r for f in a.load for r in load(f)]
    else:
        results = steady_unsat.run_jobs(ap, a, one_sample)
        if a.out is not None:
            save(a.out, results)
    report(results, a)
    if a.check is not None and check(results, a.check):
        sys.exit(1)


if __name__ == "__main__":
    main()
