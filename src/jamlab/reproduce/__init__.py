"""``jamlab reproduce``: run the ensembles, compute every number and figure, write the report.

Pipeline (``docs/reproduce.md``):

1. **Ensembles** (through :func:`jamlab.runs.run_study`, so a second call resumes): under
   ``RUNS`` (default ``OUT/runs``) the run directories ``jamming`` (φ = "jamming", the sizes
   ``jamming_n``), ``unsat`` (φ = 0.75, 0.80, sizes ``unsat_n``), both sheared with ``dgamma`` up to
   ``gamma_max``, and ``stress-strain`` (φ = ``stress_phi``, one size, to γ = 0.15 with the larger
   step ``stress_dgamma``).
2. **Numbers** from the stored traces with :mod:`jamlab.analysis`, the coordination curve
   (:func:`jamlab.spheres.packing.coordination_curve`) and the theory (:mod:`jamlab.theory`).
3. **Figures** 1–7 and theory vs cascade into ``OUT/figures``; **report** ``OUT/index.html``,
   ``OUT/report.md``, ``OUT/results.json`` (:mod:`jamlab.report`).

Modules, one concept each (the rules for the numbers are in the docstrings of the three that
compute them, and each is re-derived independently in ``tests/test_reproduce.py``):

- :mod:`~jamlab.reproduce.scales`: :class:`Scale`, the named :data:`SCALES`, their studies;
- :mod:`~jamlab.reproduce.ensembles`: reading the run directories (finished samples, sizes, stress);
- :mod:`~jamlab.reproduce.measurements`: τ, φ_J, moduli, one trace, stress–strain (typed results;
  the moduli rendered by :mod:`~jamlab.reproduce.moduli_table`);
- :mod:`~jamlab.reproduce.coordination`: coordination exponents (with
  :mod:`~jamlab.reproduce.cache`, the ``.npz`` cache of coordination curves);
- :mod:`~jamlab.reproduce.theory_checks`: no-jump probabilities, printed vs exact vs sampled;
- :mod:`~jamlab.reproduce.criticality`: θ_e, θ_l, γ of the jamming ensemble's packings and the
  finite-size scaling of the avalanches (rendered by :mod:`~jamlab.reproduce.criticality_table`);
- :mod:`~jamlab.reproduce.table` and :mod:`~jamlab.reproduce.figures`: rendering the results as
  table rows (against :mod:`jamlab.paper`, the paper's reference values) and figures;
- :mod:`~jamlab.reproduce.pipeline`: :func:`reproduce` and :func:`make_figure`.
"""

from jamlab.reproduce.ensembles import avalanche_sizes_of
from jamlab.reproduce.measurements import fit_tau
from jamlab.reproduce.pipeline import NoSamplesError, ReproduceResult, make_figure, reproduce
from jamlab.reproduce.scales import SCALES, Scale, studies

__all__ = [
    "NoSamplesError",
    "SCALES",
    "Scale",
    "ReproduceResult",
    "avalanche_sizes_of",
    "fit_tau",
    "make_figure",
    "reproduce",
    "studies",
]

# The other public names of the module this package replaced, still importable from here.
from jamlab.paper import COORDINATION_EXPONENTS as COORDINATION_EXPONENTS  # noqa: E402
from jamlab.paper import K1_EXACT_SPEC as K1_EXACT_SPEC  # noqa: E402
from jamlab.paper import K1_PAPER_CHI as K1_PAPER_CHI  # noqa: E402
from jamlab.paper import PAPER_PHI_J as PAPER_PHI_J  # noqa: E402
from jamlab.paper import PAPER_PHI_J_ERR as PAPER_PHI_J_ERR  # noqa: E402
from jamlab.paper import PAPER_TAU as PAPER_TAU  # noqa: E402
from jamlab.reproduce.coordination import (  # noqa: E402
    coordination_exponents as coordination_exponents,
)
from jamlab.reproduce.ensembles import intensive_stress as intensive_stress  # noqa: E402
from jamlab.reproduce.figures import TITLES as TITLES  # noqa: E402
from jamlab.reproduce.pipeline import COMPUTED_PARTS as COMPUTED_PARTS  # noqa: E402
from jamlab.reproduce.pipeline import FIGURE_PART as FIGURE_PART  # noqa: E402
from jamlab.reproduce.pipeline import PARTS as PARTS  # noqa: E402
from jamlab.reproduce.scales import UNSAT_PHI as UNSAT_PHI  # noqa: E402
from jamlab.reproduce.scales import with_seed as with_seed  # noqa: E402
from jamlab.reproduce.table import TARGETS as TARGETS  # noqa: E402
from jamlab.reproduce.theory_checks import (  # noqa: E402
    printed_chi_one_level as printed_chi_one_level,
)
from jamlab.reproduce.theory_checks import theory_checks as theory_checks  # noqa: E402
