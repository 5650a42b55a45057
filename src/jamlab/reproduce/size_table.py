"""The report's row and JSON data of τ's size dependence in one window: a
:class:`jamlab.analysis.SizeDifference` (τ of the largest and the smallest N pooled by a cut-off
row, each alone at that row's ``x_min``, σ of the difference from resampled packings; made by
:func:`jamlab.reproduce.measurements.with_cutoff`) turned into a :class:`jamlab.report.Row`
judged against 0. Used by :mod:`jamlab.reproduce.table` under the cut-off rows.
"""

from __future__ import annotations

from typing import Any

from jamlab.report import Comparison, Row

__all__ = ["size_difference_data", "size_difference_row"]


def size_difference_row(where: str, d: Any) -> Row:
    """τ(largest N) − τ(smallest N) ``where`` (e.g. "at fixed pressure p = 0.001"), each alone
    in the cut-off fit's window, σ from resampled packings
    (:func:`jamlab.analysis.size_difference`), against 0."""
    n0, n1, t0, t1, s0, s1 = d.n[0], d.n[-1], d.tau[0], d.tau[-1], d.sigma[0], d.sigma[-1]
    return Row(
        quantity=(f"τ(N = {n1}) − τ(N = {n0}) {where}, each alone in the exponential cut-off "
                  "fit's window (packings resampled)"),
        reference_text="0 if τ does not depend on N in one window",
        value=d.delta, error=d.boot_sigma,
        value_text=(f"{d.delta:+.3f} ± {d.boot_sigma:.3f} ({t1:.3f} ± {s1:.3f} against "
                    f"{t0:.3f} ± {s0:.3f}, asymptotic σ; x_min = {d.x_min:.3g} ε; "
                    f"{d.fraction_not_above:.0%} of the resamples ≤ 0)"),
        samples=(f"N = {n0}: {d.packings[0]} packings, {d.tails[0]} sizes in the window; "
                 f"N = {n1}: {d.packings[-1]} packings, {d.tails[-1]} sizes"),
        comparisons=(Comparison("no size dependence", 0.0),),
    )


def size_difference_data(d: Any) -> dict[str, Any] | None:
    """The numbers of a :class:`jamlab.analysis.SizeDifference` (None without one)."""
    return None if d is None else dict(
        n=list(d.n), packings=list(d.packings), n_tail=list(d.tails), tau=list(d.tau),
        tau_stderr=list(d.sigma), x_min=d.x_min, delta=d.delta, delta_sigma_boot=d.boot_sigma,
        fraction_not_above=d.fraction_not_above)
