"""Analysis of traces: avalanches, power-law fits, moduli moments (pure functions on arrays).

Imports neither :mod:`jamlab.theory` nor :mod:`jamlab.spheres`. Formulas and rules:
``docs/analysis.md``.

The public names below are loaded on first use (PEP 562): ``import jamlab.analysis.anatomy``
(as the AQS driver does) then does not import scipy.stats and scipy.optimize for every
command that shears. ``from jamlab.analysis import X`` works as before.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from jamlab import lazy

_EXPORTS: dict[str, tuple[str, ...]] = {
    "avalanches": (
        "CoarseSteps", "Exclusions", "NoiseFloor", "avalanche_sizes", "branch_residual",
        "classify_steps", "coarsen_steps", "consecutive_events", "exclusions", "jammed_steps",
        "jumps_from_trace", "noise_floor",
    ),
    "cutoff_powerlaw": (
        "CHI2_1_95", "CutoffPowerLawFit", "CutoffShapeProfile", "cutoff_power_law_cdf",
        "cutoff_power_law_ks", "cutoff_power_law_log_norm", "cutoff_power_law_logpdf",
        "cutoff_shape_profile", "fit_cutoff_power_law", "log_upper_gamma", "log_upper_gamma_array",
        "sample_cutoff_power_law", "shape_free_interval",
    ),
    "finite_size": (
        "Collapse", "CutoffScaling", "JointScaling", "JointShapeFree", "collapse",
        "collapse_quality", "cutoff_size", "fit_cutoff_scaling", "fit_joint_scaling",
        "joint_shape_free", "joint_shape_profile",
    ),
    "histograms": ("LogHistogram", "log_histogram"),
    "jackknife": ("jackknife_variance",),
    "moduli": (
        "CORRELATION_PARTS", "ModulusMoments", "SlopeFit", "event_neighbours", "fit_log_slope",
        "increment_correlation", "increment_correlation_parts", "moduli_from_stress_jumps",
        "moduli_from_trace",
    ),
    "order": ("BondOrder", "bond_order"),
    "packing_dispersion": ("PackingDispersion", "packing_dispersion"),
    "powerlaw": (
        "PowerLawFit", "fit_power_law", "mle_tau", "power_law_cdf", "power_law_gof",
        "power_law_loglik", "power_law_pdf", "sample_power_law",
    ),
    "rate_collapse": ("RateCollapse", "cumulative_rates", "rate_collapse"),
    "shape_per_size": ("SharedTau", "fixed_tau_loglik", "shared_tau"),
    "shape_test": ("ClusteredShapeTest", "clustered_shape_test"),
    "size_difference": (
        "SizeDifference", "StrainStepSlopes", "combined_scores", "size_difference",
        "strain_step_slopes",
    ),
}
"""The submodule of each public name."""

_PATH_OF = {name: f"{__name__}.{module}" for module, names in _EXPORTS.items() for name in names}
"""The module of each public name, as a full path (:func:`jamlab.lazy.attribute`)."""

__all__ = sorted(_PATH_OF)


def __getattr__(name: str) -> Any:
    return lazy.attribute(__name__, globals(), _PATH_OF, name)


def __dir__() -> list[str]:
    return lazy.names(globals(), __all__)


class _Package(types.ModuleType):
    """The import system binds each submodule to its name in this package. Three public
    functions share their submodule's name (``packing_dispersion``, ``rate_collapse``,
    ``size_difference``): the name stays the function's, as when this package imported every
    submodule eagerly (the submodule itself is in ``sys.modules``)."""

    def __setattr__(self, name: str, value: object) -> None:
        if name in _PATH_OF and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
