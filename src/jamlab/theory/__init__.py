"""Mean-field theory: Parisi functions, the static jump distribution, the exact cascade sampler."""

from jamlab.theory.cascade import CascadeJumps as CascadeJumps  # noqa: E402
from jamlab.theory.cascade import sample_cascade_jumps as sample_cascade_jumps  # noqa: E402
from jamlab.theory.cascade import sample_cascade_tree as sample_cascade_tree  # noqa: E402
from jamlab.theory.exact import exact_jump_R as exact_jump_R  # noqa: E402
from jamlab.theory.exact import one_level_R as one_level_R  # noqa: E402
