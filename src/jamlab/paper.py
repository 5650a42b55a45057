"""Reference values quoted from the paper and the literature, each written once.

Franz & Spigler, "Mean-field avalanches in jammed spheres" (``/work/shared/paper``), the SPEC's
numbers derived from it (``SPEC.md`` §1) and O'Hern et al., Phys. Rev. E 68, 011306 (2003).
These are numbers to compare against, and the one number the theory takes from the literature:
``θ`` (:data:`THETA_JAMMING`), from which :mod:`jamlab.theory.exponents` derives ``μ_J``,
``τ_J``, ``κ`` and :mod:`jamlab.analysis.criticality` its reference exponents.

This module imports nothing, so every layer (theory, analysis, the report) may use it.
"""

from __future__ import annotations

__all__ = [
    "THETA_JAMMING",
    "THETA_LOCALIZED_3D",
    "COORDINATION_EXPONENTS",
    "K1_EXACT_SPEC",
    "K1_PAPER_CHI",
    "OHERN_PHI_J_2D",
    "OHERN_PHI_J_3D",
    "PAPER_PHI_J",
    "PAPER_PHI_J_ERR",
    "PAPER_TAU",
    "PAPER_TAU_J",
    "PAPER_TAU_J_DIGITS",
    "PRINTED_NO_JUMP_SPEC",
]

THETA_JAMMING = 0.42311
"""The small-force exponent ``θ`` (``θ_e``) at jamming (``SPEC.md`` §1, §6; the paper)."""
THETA_LOCALIZED_3D = 0.17
"""The localized small-force exponent ``θ_l`` in 3D, approximate (``SPEC.md`` §6)."""

PAPER_TAU: dict[str, tuple[float, float]] = {
    "jamming": (1.52, 0.075),
    "0.75": (1.11, 0.029),
    "0.8": (1.12, 0.028),
}
"""The paper's fitted avalanche exponents τ (Fig. 5 caption): value and quoted uncertainty, keyed
by the φ label of the run directories (``"jamming"``, ``"0.75"``, ``"0.8"``)."""

PAPER_TAU_J = 1.41269
"""The paper's printed ``τ_J = (3+θ)/(2+θ)``, to its digits (the formula:
:func:`jamlab.theory.tau_jamming`)."""
PAPER_TAU_J_DIGITS = 5e-6
"""Half a unit in the last printed digit of :data:`PAPER_TAU_J`."""

PAPER_PHI_J = 0.64
"""The paper's φ_J of 3D monodisperse spheres ("≈ 0.64"), read as 0.64 ± 0.005 (its last digit)."""
PAPER_PHI_J_ERR = 0.005

OHERN_PHI_J_3D = 0.639
"""O'Hern et al. 2003: φ_J ≈ 0.639 of 3D monodisperse harmonic spheres."""
OHERN_PHI_J_2D = 0.842
"""O'Hern et al. 2003: φ_J ≈ 0.842 of the 2D 50:50 bidisperse (diameter ratio 1.4) system."""

COORDINATION_EXPONENTS: dict[str, float] = {"z_nr - z_iso": 0.5, "p": 1.0}
"""O'Hern et al. 2003: ``z − z_iso ∝ (φ − φ_J)^(1/2)``, ``p ∝ (φ − φ_J)^1`` (harmonic)."""

K1_EXACT_SPEC = 0.744
"""SPEC §1: exact one-level no-jump probability (k = 1, q_1 = 0, y_1 = 1, δγ = 0.5)."""
K1_PAPER_CHI = 0.629
"""SPEC §1: the paper's χ_1 at the same point (a known discrepancy)."""
PRINTED_NO_JUMP_SPEC = 0.69
"""SPEC §1: the paper's printed formula for P(no jump) at δγ = 0.3, y = 2.5 q, q_max = 0.9."""
