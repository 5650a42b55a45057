"""Are a run's packings amorphous? The bond order of every finished sample's prepared packing,
and the avalanches of the amorphous and the ordered ones apart.

For each run directory and each ``(φ label, N)`` in it (``--phi`` keeps some labels), every
finished sample's prepared packing (the start of its shear) gets its bond order
(:func:`jamlab.reproduce.amorphous.prepared_order`, the report's reader, with
:func:`jamlab.analysis.order.bond_order`; bonds: the contacts, or the pairs closer than
``--cutoff · σ_ij``): ten Wolde's crystalline fraction and Steinhardt's ``Q_6``. Near jamming
(``z ≈ 6``) no particle can have ten Wolde's 7 ordered contacts: read such runs with the first
shell, ``--cutoff 1.3``. A sample is *ordered* when its crystalline fraction exceeds
``--ordered`` (default 0.05; an amorphous packing of these sizes has none, a monodisperse
quench's ordered ones range from a few per cent to the whole box). Per ``(φ, N)``: the samples,
the ordered ones (and those above one half), and the avalanches the report counts
(:func:`jamlab.reproduce.ensembles.avalanche_set`) of the amorphous and the ordered samples:
their number per sample and ``⟨S⟩``. Per φ label (all N and runs pooled, as the report pools
them): τ by the report's fit (:func:`jamlab.analysis.fit_power_law`, KS-chosen ``x_min``,
truncated at the largest size, ``--boot`` bootstrap resamples, 95 % interval) of all the
avalanches, of the amorphous samples' and of the ordered samples'; and the amorphous and ordered
ones again in the window of the fit of all (the KS choice of each differs).

    PYTHONPATH=src python scripts/run_order.py OUT/runs/unsat --phi 0.75 0.8
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from jamlab.reproduce.amorphous import ORDERED_FRACTION

GROUPS = ("all", "amorphous", "ordered")


def read(runs: list[Path], labels: list[str] | None, cutoff: float = 1.0) -> list[dict]:
    """Per run, label and N: the samples' order and counted sizes."""
    from jamlab.reproduce.amorphous import prepared_order
    from jamlab.reproduce.ensembles import avalanche_set, finished
    from jamlab.runs import open_run

    out = []
    for run in runs:
        ds = open_run(run)
        for label in [str(x) for x in ds.phi.values]:
            if labels is not None and label not in labels:
                continue
            for n in [int(x) for x in ds.N.values]:
                if not finished(ds, label, n).any():
                    continue
                a = avalanche_set(ds, label, n)
                out.append({"run": run, "label": label, "n": n,
                            "order": prepared_order(ds, run, label, n, cutoff),
                            "sizes": [np.asarray(s) for s in a.per_sample]})
    return out


def fit_cell(sizes: np.ndarray, boot: int, min_tail: int, x_min: float | None = None) -> str:
    """``τ [95 %], tail, x_min`` of the report's fit (``x_min`` fixed where given)."""
    from jamlab.analysis import fit_power_law

    tail = sizes.size if x_min is None else int(np.count_nonzero(sizes >= x_min))
    if tail < min_tail:
        return f"fewer than {min_tail} sizes"
    kw = {"min_tail": min_tail} if x_min is None else {"x_min": x_min}
    f = fit_power_law(sizes, x_max=float(sizes.max()), n_boot=boot, seed=0, **kw)
    return f"{f.tau:.3f} [{f.ci_low:.3f}, {f.ci_high:.3f}], {f.n_tail}, {f.x_min:.3g}"


def tables(cells: list[dict], ordered: float, boot: int, min_tail: int) -> None:
    """The per-``(φ, N)`` table and the fits per φ."""
    print("| φ | N | run | samples | ordered (> 0.5) | crystalline fraction: mean, max "
          "| Q_6 mean | avalanches per sample: amorphous / ordered "
          "| ⟨S⟩ (ε): amorphous / ordered |")
    print("|---|---|---|---|---|---|---|---|---|")
    for c in cells:
        frac = c["order"][:, 0]
        is_ord = frac > ordered
        per = [[s for s, o in zip(c["sizes"], is_ord, strict=True) if o == want]
               for want in (False, True)]
        counts = [f"{sum(s.size for s in g) / len(g):.2f}" if g else "—" for g in per]
        means = [f"{np.concatenate(g).mean():.3g}" if g and sum(s.size for s in g) else "—"
                 for g in per]
        print(f"| {c['label']} | {c['n']} | {Path(c['run']).name} | {frac.size} | "
              f"{int(is_ord.sum())} ({int(np.sum(frac > 0.5))}) | {frac.mean():.3f}, "
              f"{frac.max():.3f} | {c['order'][:, 1].mean():.3f} | {counts[0]} / {counts[1]} | "
              f"{means[0]} / {means[1]} |")
    print("\n| φ | group | samples | avalanches | τ [95 %], tail, x_min (KS) "
          "| in the window of all: τ [95 %], tail |")
    print("|---|---|---|---|---|---|")
    for label in dict.fromkeys(c["label"] for c in cells):
        group_sizes, group_samples = {}, {}
        for g in GROUPS:
            picked = [s for c in cells if c["label"] == label
                      for s, f in zip(c["sizes"], c["order"][:, 0], strict=True)
                      if g == "all" or (f > ordered) == (g == "ordered")]
            group_samples[g] = len(picked)
            group_sizes[g] = np.concatenate(picked) if picked else np.empty(0)
        every = group_sizes["all"]
        x_all = None
        if every.size >= min_tail:
            from jamlab.analysis import fit_power_law

            x_all = fit_power_law(every, x_max=float(every.max()), min_tail=min_tail,
                                  n_boot=0, seed=0).x_min
        for g in GROUPS:
            s = group_sizes[g]
            # the cell without its x_min (the window's): "τ [95 %], tail"
            window = ("—" if g == "all" or x_all is None
                      else fit_cell(s, boot, min_tail, x_all).rsplit(", ", 1)[0])
            print(f"| {label} | {g} | {group_samples[g]} | {s.size} | "
                  f"{fit_cell(s, boot, min_tail)} | {window} |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="run directories")
    ap.add_argument("--phi", nargs="*", default=None, help="φ labels to read (default: all)")
    ap.add_argument("--ordered", type=float, default=ORDERED_FRACTION)
    ap.add_argument("--cutoff", type=float, default=1.0,
                    help="bonds: pairs closer than cutoff · σ_ij (1: the contacts; near jamming, "
                         "where z ≈ 6 < 7 ordered bonds, take the first shell, ≈ 1.3)")
    ap.add_argument("--boot", type=int, default=200)
    ap.add_argument("--min-tail", type=int, default=50)
    a = ap.parse_args(argv)
    for run in a.runs:
        if not (run / "manifest.json").is_file():
            ap.error(f"{run}: not a run directory (no manifest.json)")
    if not 0 <= a.ordered < 1 or a.min_tail < 2 or a.boot < 0 or not a.cutoff >= 1:
        ap.error("need 0 <= --ordered < 1, --min-tail >= 2, --boot >= 0, --cutoff >= 1")
    cells = read(a.runs, a.phi, a.cutoff)
    if not cells:
        ap.error("no finished sample at the labels asked for")
    tables(cells, a.ordered, a.boot, a.min_tail)


if __name__ == "__main__":
    main()
