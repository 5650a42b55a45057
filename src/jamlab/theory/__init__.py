"""Mean-field theory: Parisi functions, the static jump distribution, the exact cascade sampler."""

from jamlab.theory.exponents import THETA_JAMMING, kappa, mu_jamming, tau_from_mu, tau_jamming
from jamlab.theory.first_order import (
    jump_rate_first_order,
    overlap_atoms_first_order,
    overlap_density_first_order,
    stress_jump_density_first_order,
)
from jamlab.theory.jumps import PrintedJumpDistribution, jump_distribution
from jamlab.theory.parisi import ParisiFunction

__all__ = [
    "THETA_JAMMING",
    "ParisiFunction",
    "PrintedJumpDistribution",
    "jump_distribution",
    "jump_rate_first_order",
    "kappa",
    "mu_jamming",
    "overlap_atoms_first_order",
    "overlap_density_first_order",
    "stress_jump_density_first_order",
    "tau_from_mu",
    "tau_jamming",
]

from jamlab.theory.cascade import CascadeJumps as CascadeJumps  # noqa: E402
from jamlab.theory.cascade import sample_cascade_jumps as sample_cascade_jumps  # noqa: E402
from jamlab.theory.cascade import sample_cascade_tree as sample_cascade_tree  # noqa: E402
from jamlab.theory.exact import exact_jump_R as exact_jump_R  # noqa: E402
from jamlab.theory.exact import one_level_R as one_level_R  # noqa: E402
from jamlab.theory.exact_law import ExactEnergyJumpLaw as ExactEnergyJumpLaw  # noqa: E402
from jamlab.theory.exact_law import ExactJumpLaw as ExactJumpLaw  # noqa: E402
from jamlab.theory.exact_law import exact_energy_jump_law as exact_energy_jump_law  # noqa: E402
from jamlab.theory.exact_law import exact_jump_law as exact_jump_law  # noqa: E402
from jamlab.theory.sk import SKGroundState as SKGroundState  # noqa: E402
from jamlab.theory.sk import sk_ground_state as sk_ground_state  # noqa: E402
