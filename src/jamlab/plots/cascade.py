"""Figures for the cascade sampler: sampled jump statistics beside theory, and one cascade tree.

Conventions: ``ΔE <= 0`` is plotted as ``|ΔE|``; a theory is given by its
``R(x) = P(ΔE >= x)`` (``x <= 0``), and its density in a bin ``[a, b]`` of ``|ΔE|`` is the
bin average ``(R(-b) - R(-a)) / (b - a)`` (no numerical derivative), to compare with the sampled
``(number of jumps in the bin) / (n (b - a))``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from jamlab.files import atomic_savefig  # noqa: E402
from jamlab.theory.cascade import CascadeJumps, CascadeTree  # noqa: E402

TheoryR = Callable[[np.ndarray], np.ndarray]

_STYLES = ["C3-", "C0--", "C2:", "C4-."]


def log_bins(jumps: CascadeJumps, nbins: int = 40) -> np.ndarray:
    """Logarithmic bin edges spanning the sampled ``|ΔE|`` of jumps (1st to 100th percentile)."""
    a = np.abs(jumps.dE[jumps.jumped])
    a = a[a > 0]
    if a.size < 2:
        return np.geomspace(1e-4, 1.0, nbins + 1)
    lo = max(float(np.min(a)), float(np.quantile(a, 0.001)))
    return np.geomspace(lo, float(np.max(a)) * 1.0001, nbins + 1)


def jump_histograms_figure(
    jumps: CascadeJumps,
    theories: Mapping[str, TheoryR],
    path: str | Path | None = None,
    title: str = "",
    nbins: int = 40,
) -> plt.Figure:
    """Three panels: log-binned density of ``|ΔE|``, ``R(x) = P(ΔE >= x)`` and the overlap of
    jumps, sampled (points, with Poisson error bars) beside each theory (lines)."""
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    edges = log_bins(jumps, nbins)
    width = np.diff(edges)
    mid = np.sqrt(edges[1:] * edges[:-1])
    a = np.abs(jumps.dE[jumps.jumped])
    counts, _ = np.histogram(a, edges)
    dens = counts / (jumps.n * width)
    err = np.sqrt(np.maximum(counts, 1)) / (jumps.n * width)
    ok = counts > 0
    ax[0].errorbar(mid[ok], dens[ok], err[ok], fmt="ko", ms=3, label=f"cascade (n={jumps.n})")
    xs = -np.geomspace(edges[0], edges[-1], 200)
    p0, se = jumps.p_no_jump()
    lines = [f"sampled p_no_jump = {p0:.4f} ± {se:.4f}"]
    for (name, R), st in zip(theories.items(), _STYLES, strict=False):
        Rb = np.asarray(R(-edges), dtype=np.float64)
        th = (Rb[1:] - Rb[:-1]) / width
        ax[0].plot(mid, th, st, label=name)
        ax[1].plot(-xs, np.asarray(R(xs)), st, label=name)
        lines.append(f"{name}: R(0) = {float(np.asarray(R(np.array([0.0])))[0]):.4f}")
    ax[0].set(xscale="log", yscale="log", xlabel="|ΔE|", ylabel="density of jumps")
    ax[0].legend(fontsize=8)
    ax[1].plot(-xs, jumps.R(xs), "k-", lw=2, alpha=0.5, label="cascade")
    ax[1].set(xscale="log", xlabel="|x|", ylabel="R(x) = P(ΔE ≥ x)")
    ax[1].legend(fontsize=8)
    ax[1].text(0.03, 0.03, "\n".join(lines), transform=ax[1].transAxes, fontsize=7, va="bottom")
    qs = np.append(jumps.q, 1.0)
    frac = np.array([np.mean(jumps.q_jump == qv) for qv in jumps.q])
    ax[2].bar(jumps.q, frac, width=0.8 * np.diff(qs), align="edge", color="0.6",
              label="cascade: P(jump at q_i)")
    ax[2].set(xlabel="overlap q of old and new ground states", ylabel="probability")
    ax[2].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    if path is not None:
        atomic_savefig(fig, path, dpi=120)
        plt.close(fig)
    return fig


def cascade_tree_figure(tree: CascadeTree, path: str | Path | None = None) -> plt.Figure:
    """The sampled cascade like the paper's Fig. 2: root on top, states at the bottom coloured by
    energy ``U``; old ground state (min ``U``) circled, new one (min ``U - δγ Σ``) starred; the
    paths to both drawn thick."""
    n = tree.parent.size
    k1 = int(tree.level.max())
    children: list[list[int]] = [[] for _ in range(n)]
    for j in range(1, n):
        children[tree.parent[j]].append(j)
    for j in range(n):  # lower energy to the left
        children[j].sort(key=lambda c: tree.U[c])
    x = np.zeros(n)
    counter = [0.0]

    def place(j: int) -> None:
        if not children[j]:
            x[j] = counter[0]
            counter[0] += 1.0
            return
        for c in children[j]:
            place(c)
        x[j] = float(np.mean([x[c] for c in children[j]]))

    import sys

    sys.setrecursionlimit(max(10_000, 4 * k1 + 100))
    place(0)
    fig, ax = plt.subplots(figsize=(max(6.0, min(18.0, 0.12 * counter[0] + 4)), 5))
    depth = -tree.level.astype(float)
    # one collection per style, not one line per edge: a tree at the 65534-node limit took ~1 min
    # to draw edge by edge
    from matplotlib.collections import LineCollection

    def edges(nodes: np.ndarray) -> np.ndarray:
        p = tree.parent[nodes]
        return np.stack([np.column_stack([x[p], depth[p]]),
                         np.column_stack([x[nodes], depth[nodes]])], axis=1)

    ax.add_collection(LineCollection(edges(np.arange(1, n)), colors="0.75", linewidths=0.6,
                                     zorder=1))
    for g, col in ((tree.old_gs, "k"), (tree.new_gs, "C3")):
        path_nodes = []
        j = g
        while tree.parent[j] >= 0:
            path_nodes.append(j)
            j = tree.parent[j]
        ax.add_collection(LineCollection(edges(np.array(path_nodes, dtype=np.int64)),
                                         colors=col, linewidths=2.2, zorder=2))
    ax.autoscale_view()
    states = np.nonzero(tree.level == k1)[0]
    inner = np.nonzero(tree.level < k1)[0]
    ax.scatter(x[inner], depth[inner], s=8, c="0.4", zorder=3)
    sc = ax.scatter(x[states], depth[states], c=tree.U[states], cmap="viridis", s=18, zorder=3)
    ax.scatter([x[tree.old_gs]], [depth[tree.old_gs]], s=160, facecolors="none",
               edgecolors="k", lw=2, zorder=4, label="old ground state (min U)")
    ax.scatter([x[tree.new_gs]], [depth[tree.new_gs] - 0.15], s=160, marker="*", c="C3",
               zorder=4, label=f"new ground state (min U − δγΣ), δγ={tree.dgamma:g}")
    fig.colorbar(sc, ax=ax, label="state energy U")
    ax.set_yticks(-np.arange(1, k1 + 1))
    ax.set_yticklabels([f"q={v:.2f}" for v in tree.q] + ["states"])
    ax.set_xticks([])
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=2, fontsize=8)
    near = f"states within {tree.complete_window:.3g} of the ground states"
    if tree.truncated:
        near = f"truncated at {n} nodes: {near}, not {tree.window:g}"
    ax.set_title(f"Derrida–Ruelle cascade, k={tree.q.size} ({near})", fontsize=10)
    fig.tight_layout()
    if path is not None:
        atomic_savefig(fig, path, dpi=120)
        plt.close(fig)
    return fig
