"""Figures for packings: the coordination curve (paper Fig. 1) and its scaling near jamming."""

from __future__ import annotations

import os

import numpy as np

from jamlab.files import atomic_savefig
from jamlab.spheres.packing import CoordinationCurve, fit_power_law

__all__ = ["plot_coordination"]


def plot_coordination(
    curve: CoordinationCurve, out: str | os.PathLike, fit_range: tuple[float, float] = (1e-4, 1e-1)
) -> dict[str, tuple[float, float, float]]:
    """Two panels: (a) ``z`` and ``z_nr`` against ``φ`` (paper Fig. 1); (b) log-log
    ``z_nr − 2d``, ``z_nr − z_iso(N')`` and ``p`` against ``φ − φ_J`` with power-law fits over
    ``fit_range``. Returns the fits ``{name: (exponent, error, prefactor)}``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = curve.dim
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ax1.plot(curve.phi, curve.z, "o-", ms=3, label="$z$ (all particles)")
    ax1.plot(curve.phi, curve.z_nr, "s-", ms=3, label="$z_{nr}$ (rattlers removed)")
    ax1.axhline(2 * d, color="gray", ls="--", lw=1, label=f"$2d = {2 * d}$")
    ax1.set_xlabel(r"packing fraction $\phi$")
    ax1.set_ylabel("mean coordination (contacts per particle)")
    ax1.set_title(f"(a) N={curve.n}, d={d}, $\\phi_J$={curve.phi_j:.5f}")
    ax1.legend()
    series = {
        "z_nr - 2d": curve.z_nr - 2 * d,
        "z_nr - z_iso": curve.z_nr - curve.z_iso,
        "p": curve.pressure,
    }
    fits: dict[str, tuple[float, float, float]] = {}
    lo, hi = fit_range
    xs = np.geomspace(lo, hi, 20)
    for (name, y), marker in zip(series.items(), ("o", "s", "^"), strict=True):
        pos = y > 0
        (line,) = ax2.loglog(curve.dphi[pos], y[pos], marker, ms=4, label=name)
        try:
            a, sa, c = fit_power_law(curve.dphi, y, lo, hi)
        except ValueError:
            continue
        fits[name] = (a, sa, c)
        ax2.loglog(
            xs,
            c * xs**a,
            "-",
            color=line.get_color(),
            lw=1,
            label=f"fit: {name} ∝ Δφ^({a:.3f}±{sa:.3f})",
        )
    ax2.axvspan(lo, hi, color="0.9", zorder=0)
    ax2.set_xlabel(r"$\phi - \phi_J$")
    ax2.set_ylabel(r"$z_{nr}-2d$,  $z_{nr}-z_{iso}(N')$,  pressure $p$ (energy/diameter$^d$)")
    ax2.set_title("(b) scaling above jamming (shaded: fit range)")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    atomic_savefig(fig, out, dpi=120)
    plt.close(fig)
    return fits
