"""Figures. Each section belongs to one concept; functions take numbers, write files, return data.

Matplotlib runs with the ``Agg`` backend (no display needed).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jamlab.files import atomic_savefig, atomic_write_text

# ---------------------------------------------------------------------------------------------
# theory: the mean-field jump distribution (paper Fig. 3)


#: the drawn range of ``|ΔE|`` ends at ``JUMP_RANGE_TOP·|δγ|``
JUMP_RANGE_TOP = 20.0


def jump_distribution_table(
    mu: float,
    dgammas: Sequence[float],
    q_max: float = 1.0,
    amplitude: float = 1.0,
    n_points: int = 300,
    decades: float = 14.0,
) -> dict[float, dict[str, NDArray[np.float64]]]:
    """``P(ΔE|δγ)`` of the printed formula for ``y = amplitude·((1-q)^-μ - 1)``.

    For each ``δγ``: ``|ΔE|`` log-spaced from ``|δγ|·10^-decades`` to ``JUMP_RANGE_TOP·|δγ|``
    (:data:`JUMP_RANGE_TOP`) and the
    corresponding ``pdf``, ``cdf`` (see :class:`jamlab.theory.PrintedJumpDistribution`).
    """
    from jamlab.theory import ParisiFunction, jump_distribution

    pf = ParisiFunction.power_law(mu, amplitude=amplitude, q_max=q_max)
    out: dict[float, dict[str, NDArray[np.float64]]] = {}
    for dg in dgammas:
        dist = jump_distribution(pf, dg)
        abs_dE = abs(dg) * np.logspace(-decades, np.log10(JUMP_RANGE_TOP), n_points)
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
    atomic_savefig(fig, out, dpi=120)
    plt.close(fig)
    if csv is not None:
        lines = ["dgamma,abs_dE,pdf,cdf\n"]
        for dg, t in table.items():
            for e, p, c in zip(t["abs_dE"], t["pdf"], t["cdf"], strict=True):
                lines.append(f"{float(dg)!r},{float(e)!r},{float(p)!r},{float(c)!r}\n")
        atomic_write_text(csv, "".join(lines))
    return table


def exact_jump_distribution_table(
    mu: float,
    dgammas: Sequence[float],
    q_max: float = 1.0 - 1e-5,
    amplitude: float = 1.0,
    n_points: int = 200,
    ratios: tuple[float, float] = (1e-4, 5.0),
    levels: int = 64,
    windows: Mapping[float, tuple[tuple[float, float], int]] | None = None,
) -> dict[float, dict[str, Any]]:
    """Exact (continuum, :func:`jamlab.theory.exact_jump_law`) and printed ``P(ΔE|δγ)`` for
    ``y = amplitude·((1-q)^-μ - 1)`` with cut-off ``q_max < 1`` (the same function in both).

    For each ``δγ``: ``abs_dE`` log-spaced over ``|δγ|·ratios``, ``pdf_exact``, ``cdf_exact``,
    ``pdf_printed``, the local log-slopes ``slope_exact``, ``slope_printed``
    (``d log P / d log |ΔE|``) and ``p_no_jump_exact``, ``p_no_jump_printed``. ``windows``:
    ``{δγ: (ratios, n_points)}``, a second table of the same kind at those ``δγ`` (each one of
    ``dgammas``), under the key ``"window"`` of that ``δγ``'s table: made from the same exact
    law, whose construction is the cost (seconds; one law in memory at a time).
    """
    from jamlab.theory import ParisiFunction, exact_jump_law, jump_distribution

    windows = dict(windows or {})
    if not set(windows) <= {float(dg) for dg in dgammas}:
        raise ValueError(f"windows at {sorted(windows)} need their δγ among {list(dgammas)}")
    pf = ParisiFunction.power_law(mu, amplitude=amplitude, q_max=q_max)
    out: dict[float, dict[str, Any]] = {}
    for dg in dgammas:
        law = exact_jump_law(pf, dg, levels=levels)
        pr = jump_distribution(pf, dg)
        out[float(dg)] = _law_table(law, pr, dg, ratios, n_points)
        if float(dg) in windows:
            out[float(dg)]["window"] = _law_table(law, pr, dg, *windows[float(dg)])
        del law  # ~0.3 GB at 64 levels: freed before the next δγ's is built
    return out


def _law_table(law: Any, printed: Any, dg: float, ratios: tuple[float, float],
               n_points: int) -> dict[str, NDArray[np.float64]]:
    """One table of :func:`exact_jump_distribution_table` from the exact and the printed law."""
    abs_dE = abs(dg) * np.logspace(np.log10(ratios[0]), np.log10(ratios[1]), n_points)
    pe = np.asarray(law.pdf(-abs_dE))
    pp = np.asarray(printed.pdf(-abs_dE))
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.gradient(np.log(pe), np.log(abs_dE))
        sp = np.gradient(np.log(pp), np.log(abs_dE))
    return {
        "abs_dE": abs_dE,
        "pdf_exact": pe,
        "cdf_exact": np.asarray(law.cdf(-abs_dE)),
        "pdf_printed": pp,
        "slope_exact": se,
        "slope_printed": sp,
        "p_no_jump_exact": np.array([law.p_no_jump]),
        "p_no_jump_printed": np.array([printed.p_no_jump]),
    }


def plot_jump_distributions_exact(
    mus: Sequence[float],
    dgammas: Sequence[float],
    out: str | Path,
    q_max: float = 1.0 - 1e-5,
    amplitude: float = 1.0,
    n_points: int = 200,
    tables: dict[float, dict[float, dict[str, NDArray[np.float64]]]] | None = None,
) -> dict[float, dict[float, dict[str, NDArray[np.float64]]]]:
    """Paper Fig. 3 with the exact curves added: for each ``μ`` a column with ``P(ΔE|δγ)``
    (printed without cut-off as in the paper: thin grey; printed with the cut-off ``q_max``:
    dashed; exact with the same cut-off: solid) against ``|ΔE|/|δγ|``, below it the local
    log-slopes with the line ``-2μ``, and at the bottom the ratio ``P_exact / P_printed`` (the
    two differ at second order in ``δγ``, at small ``δγ`` by less than the top row's line
    widths). ``tables`` (from :func:`exact_jump_distribution_table`, keyed by
    ``μ``) skips the computation. Returns the tables."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jamlab.theory import ParisiFunction, jump_distribution

    if tables is None:
        tables = {float(m): exact_jump_distribution_table(m, dgammas, q_max, amplitude, n_points)
                  for m in mus}
    fig, axes = plt.subplots(3, len(mus), figsize=(5.5 * len(mus), 10.5), squeeze=False,
                             sharex=True, gridspec_kw={"height_ratios": [3, 3, 2]})
    for c, mu in enumerate(mus):
        tab = tables[float(mu)]
        ax, axs, axr = axes[0, c], axes[1, c], axes[2, c]
        pf_nocut = ParisiFunction.power_law(mu, amplitude=amplitude)
        for j, (dg, t) in enumerate(sorted(tab.items(), key=lambda kv: -abs(kv[0]))):
            r = t["abs_dE"] / abs(dg)
            col = f"C{j}"
            p_nc = np.asarray(jump_distribution(pf_nocut, dg).pdf(-t["abs_dE"]))
            ok = p_nc > 0
            ax.loglog(r[ok], p_nc[ok], color="0.6", lw=0.8)
            ok = t["pdf_printed"] > 0
            ax.loglog(r[ok], t["pdf_printed"][ok], "--", color=col, lw=1)
            ax.loglog(r, t["pdf_exact"], "-", color=col, lw=1.6, label=f"δγ = {dg:g}")
            axs.semilogx(r, t["slope_printed"], "--", color=col, lw=1)
            axs.semilogx(r, t["slope_exact"], "-", color=col, lw=1.6)
            axr.semilogx(r[ok], t["pdf_exact"][ok] / t["pdf_printed"][ok], "-", color=col,
                         lw=1.6)
        axs.axhline(-2 * mu, color="k", lw=0.8, ls=":")
        axs.set_ylim(-2 * mu - 1.5, 1.0)
        axr.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.set_title(f"μ = {mu:g}, q_max = 1 − {1 - q_max:.0e}: exact (solid), printed (dashed),"
                     "\nprinted without cut-off (grey)", fontsize=9)
        ax.set_ylabel("P(ΔE | δγ)")
        axs.set_ylabel("d log P / d log |ΔE|  (dotted: −2μ)")
        axr.set_ylabel("P_exact / P_printed  (dotted: 1)")
        axr.set_xlabel("|ΔE| / |δγ|")
        ax.legend(fontsize=8)
        for a in (ax, axs, axr):
            a.grid(True, which="major", alpha=0.3)
        tops = [float(np.max(t["pdf_exact"])) for t in tab.values()]
        ax.set_ylim(1e-4, 10 * max(tops))
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=120)
    plt.close(fig)
    return tables
