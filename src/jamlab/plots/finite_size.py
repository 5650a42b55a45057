"""Figure of the finite-size scaling of avalanche sizes: ``⟨S⟩``, ``S_c`` against ``N`` and the
collapse ``P(S) S^τ`` against ``S/N^β`` (:mod:`jamlab.analysis.finite_size`)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from jamlab.files import atomic_savefig

__all__ = ["plot_finite_size_scaling"]


def plot_finite_size_scaling(
    scaling: Mapping[str, Any],
    collapses: Mapping[str, Any],
    titles: Mapping[str, str],
    out: str | os.PathLike,
) -> None:
    """One column per label (``titles``): top, ``⟨S⟩`` and ``S_c`` (ε) against ``N`` with error
    bars (bootstrap over samples) and the fitted power laws; bottom, the collapse ``P(S) S^τ``
    against ``S/N^β`` per ``N`` (or a note when there is none)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [k for k in titles if k in scaling]
    fig, axes = plt.subplots(2, max(len(labels), 1), figsize=(4.6 * max(len(labels), 1), 8),
                             squeeze=False)
    for col, label in enumerate(labels):
        top, bottom = axes[0, col], axes[1, col]
        sc = scaling[label]
        top.set_title(titles[label], fontsize=10)
        if sc is None:
            top.text(0.5, 0.5, "fewer than two sizes with avalanches", ha="center",
                     transform=top.transAxes)
            bottom.set_axis_off()
            continue
        n = sc.n.astype(float)
        grid = np.geomspace(n.min() / 1.3, n.max() * 1.3, 20)
        for y, err, slope, name, marker in (
            (sc.cutoff, sc.cutoff_err, sc.beta, r"$S_c=\langle S^2\rangle/\langle S\rangle$", "s"),
            (sc.mean, sc.mean_err, sc.mean_exponent, r"$\langle S\rangle$", "o"),
        ):
            (line,) = top.plot([], [])
            top.errorbar(n, y, yerr=err, fmt=marker, color=line.get_color(), capsize=3,
                         label=f"{name}: slope {slope:.2f}")
            amp = np.exp(np.mean(np.log(y) - slope * np.log(n)))
            top.plot(grid, amp * grid**slope, "--", color=line.get_color(), lw=1)
        top.set_xscale("log")
        top.set_yscale("log")
        top.set_xlabel("N")
        top.set_ylabel("S (ε, total energy)")
        top.legend(fontsize=7)
        co = collapses.get(label)
        if co is None:
            bottom.text(0.5, 0.5, "no collapse (no τ fit)", ha="center",
                        transform=bottom.transAxes)
            continue
        for size in sorted(co.x):
            bottom.loglog(co.x[size], co.y[size], "o-", ms=3, lw=0.8, label=f"N = {size}")
        bottom.set_xlabel(rf"$S/N^{{\beta}}$, $\beta$ = {co.beta:.2f}")
        bottom.set_ylabel(rf"$P(S)\,S^{{\tau}}$, $\tau$ = {co.tau:.3f}")
        bottom.set_title(f"collapse RMS {co.quality:.3f} decades", fontsize=9)
        bottom.legend(fontsize=7)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=90)
    plt.close(fig)
