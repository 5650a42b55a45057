"""Analysis of traces: avalanches, power-law fits, moduli moments (pure functions on arrays).

Imports neither :mod:`jamlab.theory` nor :mod:`jamlab.spheres`. Formulas and rules:
``docs/analysis.md``.
"""

from jamlab.analysis.avalanches import (
    Exclusions,
    NoiseFloor,
    avalanche_sizes,
    branch_residual,
    classify_steps,
    exclusions,
    jammed_steps,
    jumps_from_trace,
    noise_floor,
)
from jamlab.analysis.cutoff_powerlaw import (
    CutoffPowerLawFit,
    CutoffShapeProfile,
    cutoff_power_law_cdf,
    cutoff_power_law_ks,
    cutoff_power_law_log_norm,
    cutoff_power_law_logpdf,
    cutoff_shape_profile,
    fit_cutoff_power_law,
    log_upper_gamma,
    log_upper_gamma_array,
    sample_cutoff_power_law,
)
from jamlab.analysis.finite_size import (
    Collapse,
    CutoffScaling,
    JointScaling,
    collapse,
    collapse_quality,
    cutoff_size,
    fit_cutoff_scaling,
    fit_joint_scaling,
)
from jamlab.analysis.histograms import LogHistogram, log_histogram
from jamlab.analysis.moduli import (
    ModulusMoments,
    SlopeFit,
    fit_log_slope,
    moduli_from_stress_jumps,
    moduli_from_trace,
)
from jamlab.analysis.powerlaw import (
    PowerLawFit,
    fit_power_law,
    mle_tau,
    power_law_cdf,
    power_law_gof,
    power_law_loglik,
    power_law_pdf,
    sample_power_law,
)

__all__ = [
    "CutoffPowerLawFit",
    "CutoffShapeProfile",
    "cutoff_power_law_cdf",
    "cutoff_power_law_ks",
    "cutoff_power_law_log_norm",
    "cutoff_power_law_logpdf",
    "cutoff_shape_profile",
    "fit_cutoff_power_law",
    "log_upper_gamma",
    "log_upper_gamma_array",
    "sample_cutoff_power_law",
    "Collapse",
    "CutoffScaling",
    "collapse",
    "collapse_quality",
    "cutoff_size",
    "fit_cutoff_scaling",
    "JointScaling",
    "fit_joint_scaling",
    "Exclusions",
    "exclusions",
    "jammed_steps",
    "LogHistogram",
    "ModulusMoments",
    "NoiseFloor",
    "PowerLawFit",
    "SlopeFit",
    "avalanche_sizes",
    "branch_residual",
    "classify_steps",
    "fit_log_slope",
    "fit_power_law",
    "jumps_from_trace",
    "log_histogram",
    "mle_tau",
    "moduli_from_stress_jumps",
    "moduli_from_trace",
    "noise_floor",
    "power_law_cdf",
    "power_law_gof",
    "power_law_loglik",
    "power_law_pdf",
    "sample_power_law",
]
