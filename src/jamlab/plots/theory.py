"""Figures. Each section belongs to one concept; functions take numbers, write files, return data.

Matplotlib runs with the ``Agg`` backend (no display needed).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

# ---------------------------------------------------------------------------------------------
# theory: the mean-field jump distribution (paper Fig. 3)


def jump_distribution_table(
    mu: float,
    dgammas: Sequence[float],
    q_max: float = 1.0,
    amplitude: float = 1.0,
    n_points: int = 300,
    decades: float = 14.0,
) -> dict[float, dict[str, NDArray[np.float64]]]:
    """``P(ΔE|δγ)`` of the printed formula for ``y = amplitude·((1-q)^-μ - 1)``.

    For each ``δγ``: ``|ΔE|`` log-spaced from ``|δγ|·10^-decades`` to ``20|δγ|`` and the
    corresponding ``pdf``, ``cdf`` (see :class:`jamlab.theory.PrintedJumpDistribution`).
    """
    from jamlab.theory import ParisiFunction, jump_distribution

    pf = ParisiFunction.power_law(mu, amplitude=amplitude, q_max=q_max)
    out: dict[float, dict[str, NDArray[np.float64]]] = {}
    for dg in dgammas:
        dist = jump_distribution(pf, dg)
        abs_dE = abs(dg) * np.logspace(-decades, np.log10(20.0), n_points)
        out[float(dg)] = {
            "abs_dE": abs_dE,
            "pdf": np.asarray(dist.pdf(-abs_dE)),
            "cdf": np.asarray(dist.cdf(-abs_dE)),
            "p_no_jump": np.array([dist.p_no_jump]),
        }
    return out


def plot_jump_distributions(
    mu: float,
    dgammas: Sequence[float],
    out: str | Path,
    q_max: float = 1.0,
    amplitude: float = 1.0,
    n_points: int = 300,
    csv: str | Path | None = None,
) -> dict[float, dict[str, NDArray[np.float64]]]:
    """Draw ``P(ΔE|δγ)`` against ``|ΔE|`` on log-log axes, one curve per ``δγ`` (paper Fig. 3).

    A dashed guide line of slope ``-2μ`` (the predicted ``τ = 2μ``) is drawn through the smallest
    ``δγ``'s curve in the middle of its power-law window ``|δγ|^(1+1/(2μ-1)) << |ΔE| << |δγ|``.
    Optionally writes the numbers as CSV (``dgamma,abs_dE,pdf,cdf``). Returns the table.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = jump_distribution_table(mu, dgammas, q_max, amplitude, n_points)
    fig, ax = plt.subplots(figsize=(6.0, 4.5))
    for dg, t in sorted(table.items(), key=lambda kv: -abs(kv[0])):
        ok = t["pdf"] > 0
        ax.loglog(t["abs_dE"][ok], t["pdf"][ok], label=f"δγ = {dg:g}")
    # guide line of slope -2μ near the smallest δγ
    dg_min = min(table, key=abs)
    t = table[dg_min]
    a = abs(dg_min)
    lo = a ** (1 + 1 / (2 * mu - 1)) if mu > 0.5 else a * 1e-12
    centre = np.sqrt(max(lo, t["abs_dE"][0]) * a)
    p_centre = float(np.interp(np.log(centre), np.log(t["abs_dE"]), t["pdf"]))
    if p_centre > 0:
        xs = centre * np.logspace(-2.5, 2.5, 2)
        ax.loglog(
            xs,
            3 * p_centre * (xs / centre) ** (-2 * mu),
            "k--",
            lw=1,
            label=f"slope −2μ = {-2 * mu:.4g}",
        )
    # frame the interesting part: from the top of the curves down to where they leave the power
    # law at large |ΔE| (their super-exponential tails would otherwise squash the picture)
    tops = [float(np.max(t["pdf"])) for t in table.values()]
    floor = min(
        float(np.interp(np.log(5 * abs(dg)), np.log(t["abs_dE"]), t["pdf"]))
        for dg, t in table.items()
    )
    if floor > 0:
        ax.set_ylim(floor, 10 * max(tops))
    cut = "" if q_max == 1.0 else f", $q_{{max}}$ = {q_max:g}"
    ax.set_title(f"Mean-field P(ΔE|δγ), y' ~ (1−q)^(−μ−1), μ = {mu:g}{cut}")
    ax.set_xlabel("|ΔE|")
    ax.set_ylabel("P(ΔE | δγ)")
    ax.legend(fontsize=8)
    ax.grid(True, which="major", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    if csv is not None:
        with open(csv, "w", encoding="utf-8") as fh:
            fh.write("dgamma,abs_dE,pdf,cdf\n")
            for dg, t in table.items():
                for e, p, c in zip(t["abs_dE"], t["pdf"], t["cdf"], strict=True):
                    fh.write(f"{float(dg)!r},{float(e)!r},{float(p)!r},{float(c)!r}\n")
    return table
