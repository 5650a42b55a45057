"""Figure of one avalanche: its non-affine displacement field as arrows, projected on a plane."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402

from jamlab.files import atomic_savefig  # noqa: E402


def avalanche_figure(
    positions: np.ndarray,
    u: np.ndarray,
    box_length: float,
    path: str | Path | None = None,
    *,
    diameters: np.ndarray | None = None,
    axes: tuple[int, int] = (0, 1),
    title: str = "",
    label: str = r"$\log_{10} |u_i|$ (units of the diameter $\sigma$)",
) -> plt.Figure:
    """One avalanche: particles projected on ``axes`` (default the shear plane ``x``–``y``; in
    2D faint discs of their diameter, in higher dimensions dots at their centres) and the
    displacements ``u`` as arrows, scaled so that the largest is half a mean diameter long (the
    factor is in the title); arrow colour ``log10 |u|``, its colour bar titled ``label`` (say
    what ``u`` is: e.g. the event field with the elastic response subtracted). Positions are
    drawn modulo ``L`` in each projected axis (a projection: nothing is cut)."""
    pos = np.asarray(positions, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    a, b = axes
    L = float(box_length)
    diam = np.ones(pos.shape[0]) if diameters is None else np.asarray(diameters, dtype=float)
    xy = np.mod(pos[:, [a, b]], L)
    mag = np.sqrt(np.einsum("ij,ij->i", u, u))
    umax = float(mag.max()) if mag.size and mag.max() > 0 else 1.0
    scale = 0.5 * float(np.mean(diam)) / umax
    fig, ax = plt.subplots(figsize=(6, 6))
    if pos.shape[1] == 2:
        ax.add_collection(
            EllipseCollection(
                diam,
                diam,
                np.zeros_like(diam),
                units="xy",
                offsets=xy,
                transOffset=ax.transData,
                facecolors="0.85",
                edgecolors="0.6",
                linewidths=0.3,
            )
        )
    else:  # discs of a projection hide one another: centres only
        ax.scatter(xy[:, 0], xy[:, 1], s=6, c="0.6", linewidths=0)
    order = np.argsort(mag)
    colours = np.log10(np.maximum(mag[order], umax * 1e-4))
    q = ax.quiver(
        xy[order, 0],
        xy[order, 1],
        scale * u[order, a],
        scale * u[order, b],
        colours,
        angles="xy",
        scale_units="xy",
        scale=1.0,
        cmap="viridis",
        width=0.004,
    )
    fig.colorbar(q, ax=ax, shrink=0.8, label=label)
    names = "xyzw"
    ax.set_xlim(-0.5, L + 0.5)
    ax.set_ylim(-0.5, L + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel(names[a] if a < 4 else f"axis {a}")
    ax.set_ylabel(names[b] if b < 4 else f"axis {b}")
    plane = f"{names[a] if a < 4 else a}–{names[b] if b < 4 else b}"
    ax.set_title(title + f"\nprojection on the {plane} plane; arrows ×{scale:.3g} "
                 f"(max |u| = {umax:.3g})", fontsize=9)
    fig.tight_layout()
    if path is not None:
        atomic_savefig(fig, path, dpi=150)
    return fig
