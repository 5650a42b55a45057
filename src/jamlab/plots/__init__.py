"""Figures (matplotlib, Agg): one module per concept, each a pure function of computed data.

- :mod:`jamlab.plots.theory`    P(ΔE|δγ) of the mean-field theory (paper Fig. 3)
- :mod:`jamlab.plots.cascade`   a sampled cascade tree (Fig. 2), sampled jumps beside theory
- :mod:`jamlab.plots.packings`  coordination and pressure against φ (Fig. 1)
- :mod:`jamlab.plots.shear`     energy and stress against strain for one trace (Fig. 4)
- :mod:`jamlab.plots.report`    the reproduction's ensemble figures (Figs. 3–7, theory vs cascade)
"""
