"""Figures of AQS traces: energy and shear stress against strain (the paper's Fig. 4 style)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from jamlab.files import atomic_savefig  # noqa: E402
from jamlab.spheres.trace import Trace  # noqa: E402


def stress_strain_figure(trace: Trace, path: str | Path | None = None) -> plt.Figure:
    """Two panels sharing ``γ``: ``E/N`` and ``σ_xy = Σ/L^d`` (both intensive), plastic steps
    marked. ``L`` comes from ``trace.attrs['box_length']`` (``Σ/N`` is shown if it is absent)."""
    n = float(trace.attrs.get("N", 1))
    dim = int(trace.attrs.get("dim", 3))
    length = trace.attrs.get("box_length")
    volume = float(length) ** dim if length else None
    fig, (ax_e, ax_s) = plt.subplots(2, 1, sharex=True, figsize=(6, 5.5))
    ax_e.plot(trace.gamma, trace.energy / n, lw=1)
    ax_e.set_ylabel("E / N")
    stress = trace.shear_stress / (volume if volume else n)
    ax_s.plot(trace.gamma, stress, lw=1)
    ax_s.set_ylabel(r"$\sigma_{xy} = \Sigma / L^d$" if volume else r"$\Sigma / N$")
    ax_s.set_xlabel(r"$\gamma$")
    plastic = np.flatnonzero(trace.plastic)
    for ax, y in ((ax_e, trace.energy / n), (ax_s, stress)):
        ax.plot(trace.gamma[plastic], y[plastic], "o", ms=3, color="C3", label="plastic step")
    ax_e.legend(loc="best", fontsize=8)
    fig.suptitle(
        f"AQS, N={int(n)}, phi={trace.attrs.get('phi', float('nan')):.4g}, "
        f"dγ={trace.attrs.get('dgamma', float('nan')):g}"
    )
    fig.tight_layout()
    if path is not None:
        atomic_savefig(fig, path, dpi=120)
        plt.close(fig)
    return fig
