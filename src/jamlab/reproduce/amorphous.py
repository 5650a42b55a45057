"""Are the report's packings amorphous? The bond order of every prepared packing, and τ of the
amorphous ones alone.

The theory is about glasses; the paper's packings are monodisperse spheres, which can order. A
monodisperse quench at φ = 0.75–0.8 is partly or wholly crystalline in a quarter of the boxes
of N = 128 (docs/reproduce.md, "Are the packings amorphous?"). So, per ensemble (the jamming,
UNSAT and stress–strain runs) and N, every finished sample's prepared packing (the start of its
shear, :func:`jamlab.runs.load.prepared_packing`) gets ten Wolde's crystalline fraction
(:func:`jamlab.analysis.order.bond_order` with the first shell as bonds, pairs closer than
:data:`ORDER_CUTOFF` ``· σ_ij``: with the contacts alone a packing at jamming, ``z ≈ 6``, could
never show ten Wolde's 7 ordered bonds). A sample is *ordered* above :data:`ORDERED_FRACTION`.
The rows give the ordered samples per N, and τ of each avalanche ensemble fitted again on the
avalanches of its amorphous samples alone (the module rule of
:mod:`jamlab.reproduce.measurements`: all N pooled, KS-chosen ``x_min``, bootstrap).

This reads the *prepared* packings; what shear does to them is not in the sample files (a
sample keeps its start, not its minima): long shear orders monodisperse spheres further (the
stress–strain ensemble's γ ≤ 0.15 included; docs/reproduce.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jamlab.paper import PAPER_TAU
from jamlab.report import Comparison, Row
from jamlab.reproduce.ensembles import avalanche_set, finished
from jamlab.reproduce.measurements import fit_tau, predicted_tau, tau_sigma
from jamlab.reproduce.scales import UNSAT_PHI, Scale
from jamlab.reproduce.table import TAU_TITLES, fit_text

__all__ = ["ORDER_CUTOFF", "ORDERED_FRACTION", "SECTION", "SECTION_TEXT", "EnsembleOrder",
           "ensemble_order", "order_checks", "order_rows", "order_data", "prepared_order"]

ORDER_CUTOFF = 1.3
"""Bonds of the order check: pairs closer than ``1.3 σ_ij`` (the first shell: an fcc crystal
compressed to φ = 0.8 has its second neighbours at ≈ 1.38 σ)."""
ORDERED_FRACTION = 0.05
"""A prepared packing with more crystalline particles than this share is *ordered*."""
SECTION = "Are the packings amorphous? (bond order of the prepared packings)"
SECTION_TEXT = (
    "Monodisperse spheres, the paper's system, can crystallise. Each finished sample's prepared "
    "packing (the start of its shear) gets ten Wolde's crystalline fraction (Steinhardt q_6 over "
    f"the first shell, r < {ORDER_CUTOFF:g} σ_ij; a particle with ≥ 7 ordered bonds is "
    f"crystalline); a packing with more than {ORDERED_FRACTION:g} of its particles crystalline "
    "counts as ordered. Beside the counts, τ of each avalanche ensemble fitted again on its "
    "amorphous packings alone (same rule as the main table). Shear orders monodisperse spheres "
    "further, which the sample files (they keep the start) cannot show: docs/reproduce.md, "
    "\"Are the packings amorphous?\".")


@dataclass(frozen=True)
class EnsembleOrder:
    """One ensemble at one φ label: the crystalline fraction of each finished sample's prepared
    packing per N (in the order of the finished samples), and τ of the avalanches of the
    amorphous samples alone (``fit`` None: not an avalanche ensemble, or too few sizes)."""

    run: str
    label: str
    fractions: dict[int, np.ndarray]
    fit: Any = None
    sigma: float = float("nan")
    avalanches: int = 0
    samples: int = 0
    with_tau: bool = False
    seconds: float = 0.0

    def ordered(self, n: int, above: float = ORDERED_FRACTION) -> int:
        """Samples of size ``n`` whose crystalline fraction exceeds ``above``."""
        return int(np.sum(self.fractions[n] > above))

    def measured(self, n: int) -> int:
        """Samples of size ``n`` whose order could be measured (NaN: a box below twice the
        first shell)."""
        return int(np.sum(np.isfinite(self.fractions[n])))

    @property
    def total(self) -> tuple[int, int]:
        """``(ordered, measured)`` over every N."""
        return (sum(self.ordered(n) for n in self.fractions),
                sum(self.measured(n) for n in self.fractions))


def prepared_order(ds: Any, run_path: Path, label: str, n: int,
                   cutoff: float = ORDER_CUTOFF) -> np.ndarray:
    """``(crystalline fraction, Q_6)`` of the prepared packing of each finished sample, rows in
    the order of the finished samples, bonds closer than ``cutoff · σ_ij`` (NaN where the box
    side is below twice that distance, ≈ 20 spheres or fewer)."""
    from jamlab.analysis.order import bond_order
    from jamlab.runs import RunDir
    from jamlab.runs.load import prepared_packing, sample_key

    run = RunDir(run_path)
    out = []
    for index in np.flatnonzero(finished(ds, label, n)):
        p = prepared_packing(run.sample_path(sample_key(label, n, int(index))))
        try:
            o = bond_order(p.positions, p.box.length, p.box.strain, p.diameters, cutoff)
        except ValueError:  # the box is too small for the minimum image of the first shell
            out.append((float("nan"), float("nan")))
            continue
        out.append((o.crystalline_fraction, o.global_q))
    return np.array(out, dtype=float).reshape(-1, 2)


def ensemble_order(ds: Any, run_path: Path, label: str, ns: tuple[int, ...], scale: Scale,
                   with_tau: bool) -> EnsembleOrder:
    """:class:`EnsembleOrder` of ``(label, ns)`` in the run ``ds`` at ``run_path``; with
    ``with_tau`` also τ of the counted avalanches of its amorphous samples (all N pooled)."""
    t0 = time.process_time()
    fractions = {n: prepared_order(ds, run_path, label, n)[:, 0] for n in ns}
    if not with_tau:
        return EnsembleOrder(run_path.name, label, fractions,
                             seconds=time.process_time() - t0)
    kept, samples = [], 0
    for n in ns:
        # a run without steps has no per-sample sizes: every sample then has none
        per_sample = avalanche_set(ds, label, n).per_sample or [np.empty(0)] * fractions[n].size
        for sizes, frac in zip(per_sample, fractions[n], strict=True):
            if frac <= ORDERED_FRACTION:  # measured and amorphous (NaN is neither)
                kept.append(np.asarray(sizes))
                samples += 1
    sizes = np.concatenate(kept) if kept else np.empty(0)
    fit = fit_tau(sizes, scale)
    return EnsembleOrder(run_path.name, label, fractions, fit, tau_sigma(fit), int(sizes.size),
                         samples, True, time.process_time() - t0)


def order_checks(runs: Any, scale: Scale) -> list[EnsembleOrder]:
    """:class:`EnsembleOrder` of the jamming ensemble, each UNSAT φ (with τ of their amorphous
    samples) and the stress–strain ensemble (order only) of the run set ``runs``."""
    root = Path(runs.path)
    wanted = [("jamming", "jamming", scale.jamming_n, True)] + [
        ("unsat", repr(p), scale.unsat_n, True) for p in UNSAT_PHI] + [
        ("stress-strain", repr(scale.stress_phi), (scale.stress_n,), False)]
    return [ensemble_order(runs[name], root / name, label, tuple(ns), scale, tau)
            for name, label, ns, tau in wanted]


def _counts_text(e: EnsembleOrder) -> str:
    def one(n: int) -> str:
        if not e.measured(n):
            return f"N = {n}: not measured (box side below {2 * ORDER_CUTOFF:g} σ)"
        return (f"N = {n}: {e.ordered(n)} of {e.measured(n)} ({e.ordered(n, 0.5)} more than "
                "half crystalline)")
    return "; ".join(one(n) for n in e.fractions)


def order_rows(checks: list[EnsembleOrder]) -> list[Row]:
    """Per ensemble the share of ordered prepared packings; per avalanche ensemble τ of its
    amorphous samples against the paper's fit and the theory."""
    rows = []
    for e in checks:
        ordered, total = e.total
        rows.append(Row(
            quantity=(f"ordered prepared packings, {e.run} run, φ = {e.label} (crystalline "
                      f"fraction > {ORDERED_FRACTION:g}; first shell r < {ORDER_CUTOFF:g} σ_ij)"),
            reference_text="amorphous (the theory's glass)",
            value=ordered / total if total else float("nan"), error=float("nan"),
            value_text=f"{ordered} of {total}" if total else "no finished samples",
            samples=_counts_text(e), section=SECTION))
        if not e.with_tau:
            continue
        paper, paper_err = PAPER_TAU[e.label]
        theory = predicted_tau(e.label)
        rows.append(Row(
            quantity=f"amorphous prepared packings only: {TAU_TITLES[e.label]}",
            reference_text=f"{paper} ± {paper_err} (paper's fit); theory {theory:.5g}",
            value=e.fit.tau if e.fit is not None else float("nan"), error=e.sigma,
            value_text=fit_text(e.fit, e.sigma),
            samples=(f"{e.samples} of {sum(f.size for f in e.fractions.values())} samples, "
                     f"{e.avalanches} avalanches"),
            comparisons=(Comparison("the paper's fit", paper, paper_err),
                         Comparison("theory", theory)),
            section=SECTION))
    return rows


def order_data(checks: list[EnsembleOrder]) -> dict[str, Any]:
    """``order``: per ensemble the crystalline fractions per N and the amorphous τ fit."""
    out = {}
    for e in checks:
        f = e.fit
        out[f"{e.run}:{e.label}"] = dict(
            # NaN (not measured) as None: JSON has no NaN
            crystalline_fraction={str(n): [x if np.isfinite(x) else None for x in v.tolist()]
                                  for n, v in e.fractions.items()},
            ordered={str(n): e.ordered(n) for n in e.fractions},
            tau_amorphous=None if f is None else dict(
                tau=f.tau, sigma=e.sigma, ci_low=f.ci_low, ci_high=f.ci_high, x_min=f.x_min,
                n_tail=f.n_tail, n_avalanches=e.avalanches, samples=e.samples))
    return {"order": out}
