"""Avalanche exponents of the mean-field theory (SPEC §1).

For ``y'(q) ~ (1-q)^(-μ-1)`` with ``μ > 1/2`` the static jump distribution is a power law
``P ~ |ΔE/δγ|^(-τ)`` with ``τ = 2μ``. At jamming ``μ_J = (3+θ)/(2(2+θ))`` with the pseudogap
exponent ``θ = 0.42311`` of the force distribution, giving ``τ_J = (3+θ)/(2+θ) = 1 + 1/(2+θ)``.
"""

from __future__ import annotations

import math

from jamlab.paper import THETA_JAMMING as THETA_JAMMING  # θ, written once (jamlab.paper)


def _check_theta(theta: float) -> float:
    """``θ`` must be finite and ``> -1``: a normalisable force distribution ``P(f) ~ f^θ``, and
    exactly where ``μ_J = 1/2 + 1/(2(2+θ))`` lies in ``(1/2, 1)``, the range of :func:`tau_from_mu`
    (``θ = -1`` gives ``μ = 1``, ``-2 < θ < -1`` gives ``μ > 1``, ``θ < -2`` gives ``μ < 1/2``)."""
    theta = float(theta)
    if not math.isfinite(theta) or theta <= -1.0:
        raise ValueError(
            f"theta must be a finite number > -1 (so that 1/2 < mu_J < 1), got {theta}"
        )
    return theta


def mu_jamming(theta: float = THETA_JAMMING) -> float:
    """``μ_J = (3+θ)/(2(2+θ))`` (0.706346 for ``θ = 0.42311``)."""
    theta = _check_theta(theta)
    return (3.0 + theta) / (2.0 * (2.0 + theta))


def tau_from_mu(mu: float) -> float:
    """Avalanche exponent ``τ = 2μ`` (valid for ``1/2 <= μ < 1``; ``μ = 1/2`` gives ``τ = 1``).

    Any other ``μ`` (NaN included) is a ValueError: below ``1/2`` the jump distribution is not
    the power law ``|ΔE/δγ|^(-2μ)`` (SPEC §1 states ``τ = 2μ`` for ``μ > 1/2`` and ``τ = 1`` at
    ``μ = 1/2``).
    """
    mu = float(mu)
    if not (math.isfinite(mu) and 0.5 <= mu < 1.0):
        raise ValueError(
            f"mu must lie in [1/2, 1) (tau = 2 mu holds only there, SPEC §1), got {mu}"
        )
    return 2.0 * mu


def tau_jamming(theta: float = THETA_JAMMING) -> float:
    """``τ_J = (3+θ)/(2+θ) = 1 + 1/(2+θ)`` (1.412693 for ``θ = 0.42311``)."""
    return tau_from_mu(mu_jamming(theta))


def kappa(theta: float = THETA_JAMMING) -> float:
    """``κ = 1/μ_J = 2(2+θ)/(3+θ)`` (1.415736 for ``θ = 0.42311``), the literature's name for the
    inverse exponent of ``y'(q) ~ (1-q)^(-1/κ-1)`` at jamming. Note ``κ ≠ τ_J = 2μ_J`` (1.412693).
    """
    return 1.0 / mu_jamming(theta)
