"""Jamming criticality of a packing: contact forces, gaps, bucklers and their exponents.

Pure functions on arrays (``SPEC.md`` §6; rules and measured numbers in ``docs/criticality.md``).
Nothing here imports :mod:`jamlab.spheres`: a packing enters as positions, box side, Lees–Edwards
strain and (optional) diameters.

Conventions, for spheres of diameters ``D_i`` (default all 1) in a periodic cube of side ``L``
with Lees–Edwards strain ``γ`` (the image across the ``y`` boundary, axis 1, is shifted by ``γ L``
along ``x``, axis 0; ``SPEC.md`` §3):

- ``σ_ij = (D_i + D_j)/2``; pair law ``V(r) = (1 − r/σ_ij)^α`` for ``r < σ_ij`` (``α = 2``: the
  paper's harmonic spheres; ``SPEC.md`` §5).
- Contact: a pair with ``r_ij < σ_ij``. Its force ``f_ij = −V'(r_ij) = α (1 − r/σ)^(α−1)/σ > 0``.
- Rattlers: particles with fewer than ``d + 1`` contacts, removed repeatedly; the rest is the
  *backbone*. Backbone contacts join two backbone particles.
- Gap of a pair not in contact: ``h_ij = r_ij/σ_ij − 1 > 0``, for every pair of backbone
  particles (rattlers excluded unless asked) up to ``h_max``.
- Buckler: a backbone particle with exactly ``d + 1`` backbone contacts. The weakest contact of
  each buckler is *localized*; every other backbone contact is *extended* (Charbonneau, Corwin,
  Parisi & Zamponi, PRL 114, 125504 (2015); Lerner, Düring & Wyart, Soft Matter 9, 8252 (2013)).
- Forces are used in units of their mean over the backbone contacts of their packing.

Exponents (``P(f) ~ f^θ``, ``g(h) ~ h^(−γ)``) are fitted on the pooled empirical cumulative
distribution ``F(x) ~ x^(1+a)`` (``a = θ`` or ``−γ``) over a stated window, with a bootstrap over
packings for the 95 % interval (:func:`fit_exponent`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jamlab.analysis.contact_geometry import (
    PackingObservables,
    PairList,
    backbone_mask,
    bucklers,
    packing_observables,
    pair_force,
    pairs_within,
)
from jamlab.analysis.exponent_fit import (
    ExponentFit,
    LocalExponents,
    WindowRule,
    choose_window,
    empirical_cdf,
    finite_size_cutoff,
    fit_exponent,
    local_exponents,
)
from jamlab.paper import THETA_JAMMING, THETA_LOCALIZED_3D

__all__ = [
    "PairList",
    "PackingObservables",
    "ExponentFit",
    "LocalExponents",
    "WindowRule",
    "THETA_E",
    "THETA_L",
    "GAMMA",
    "pairs_within",
    "pair_force",
    "backbone_mask",
    "bucklers",
    "packing_observables",
    "empirical_cdf",
    "fit_exponent",
    "local_exponents",
    "choose_window",
    "finite_size_cutoff",
    "DEFAULT_RULES",
    "REFERENCE",
    "criticality_samples",
    "measure_exponents",
    "counts",
    "smallest_per_packing",
]

FloatArray = NDArray[np.float64]

THETA_E = THETA_JAMMING
"""Mean-field extended small-force exponent (``SPEC.md`` §6)."""
GAMMA = 1.0 / (2.0 + THETA_JAMMING)
"""Mean-field gap exponent ``γ = 1/(2 + θ_e)`` = 0.41269 (``SPEC.md`` §6)."""
THETA_L = THETA_LOCALIZED_3D
"""Localized small-force exponent in 3D (approximate; ``SPEC.md`` §6)."""


# ------------------------------------------------------------------------------------------------
# the three exponents of a set of packings

DEFAULT_RULES: dict[str, WindowRule] = {
    "theta_e": WindowRule(per_packing=5, upper=0.1),
    "theta_l": WindowRule(per_packing=5, upper=0.05),
    "gamma": WindowRule(per_packing=5, upper=1e-2),
}
"""The stated window rule (``docs/criticality.md``): the lower end is where the packings hold on
average 5 samples each of that class (the finite-size cut-off is where they hold about one), the
upper end the crossover to the bulk: ``f/⟨f⟩ = 0.1`` (extended), ``0.05`` (localized; their
distribution turns over at smaller forces), ``h = 1e-2``."""

REFERENCE = {"theta_e": THETA_E, "theta_l": THETA_L, "gamma": GAMMA}
"""``SPEC.md`` §6 values."""


def criticality_samples(observables: Sequence[PackingObservables]) -> dict[str, list[FloatArray]]:
    """Per packing: extended and localized ``f/⟨f⟩`` and gaps ``h``, keyed ``theta_e``,
    ``theta_l``, ``gamma``."""
    return {
        "theta_e": [o.extended_force for o in observables],
        "theta_l": [o.localized_force for o in observables],
        "gamma": [o.gap for o in observables],
    }


def measure_exponents(
    observables: Sequence[PackingObservables],
    rules: dict[str, WindowRule] | None = None,
    windows: dict[str, tuple[float, float]] | None = None,
    method: str = "cdf",
    n_boot: int = 1000,
    seed: int = 0,
    names: Sequence[str] | None = None,
) -> dict[str, ExponentFit]:
    """``θ_e``, ``θ_l`` and ``γ`` (sign flipped from the gap fit) pooled over ``observables``,
    each on ``windows[name]`` if given, else on the window of ``rules[name]``
    (:data:`DEFAULT_RULES`); only those in ``names`` if given."""
    rules = DEFAULT_RULES if rules is None else rules
    windows = {} if windows is None else windows
    out: dict[str, ExponentFit] = {}
    for name, samples in criticality_samples(observables).items():
        if names is not None and name not in names:
            continue
        window = windows.get(name) or choose_window(samples, rules[name])
        fit = fit_exponent(samples, window, method=method, n_boot=n_boot, seed=seed)
        out[name] = fit.negated() if name == "gamma" else fit
    return out


def counts(observables: Sequence[PackingObservables]) -> dict[str, int]:
    """Packings, backbone contacts, extended and localized contacts, bucklers, gaps, rattlers."""
    return {
        "packings": len(observables),
        "contacts": int(sum(o.n_contacts for o in observables)),
        "extended_contacts": int(sum(int((~o.localized).sum()) for o in observables)),
        "localized_contacts": int(sum(int(o.localized.sum()) for o in observables)),
        "bucklers": int(sum(o.buckler_ids.size for o in observables)),
        "gaps": int(sum(o.gap.size for o in observables)),
        "rattlers": int(sum(o.n_rattlers for o in observables)),
    }


def smallest_per_packing(samples: Sequence[ArrayLike]) -> FloatArray:
    """The smallest sample of each packing (the measured finite-size cut-off)."""
    return np.array([float(np.min(s)) if np.size(s) else math.nan for s in samples])

