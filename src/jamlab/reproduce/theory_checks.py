"""Theory checks of the report: no-jump probabilities of the printed formula, the exact recursion
and the cascade sampler.

Rule (``docs/reproduce.md``): the exact k-level recursion (:func:`jamlab.theory.exact_jump_R`)
against the cascade sampler at ``y = 2.5 q``, ``q_max = 0.9`` discretised to ``cascade_k``
levels, at each of ``cascade_dgammas`` (seeds ``seed + 100 + i``), with the paper's printed
formula beside them; and the one-level case (``k = 1``, ``y_1 = 1``, ``δγ = 0.5``, seed
``seed + 99``) against the paper's ``χ_1``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jamlab.reproduce.scales import Scale

__all__ = [
    "ExponentCheck",
    "NoJumpPoint",
    "TheoryChecks",
    "exact_law_checks",
    "printed_chi_one_level",
    "theory_checks",
]

EXPONENT_DGAMMA = 1e-3
"""``δγ`` of the exponent check (the exact law's local slope, docs/theory-vs-cascade.md §9)."""
EXPONENT_WINDOW = (0.02, 0.15)
"""``|ΔE|/δγ`` window where the local slope of ``P(ΔE|δγ)`` is read (inside SPEC §1's)."""
EXPONENT_Q_MAX = 1.0 - 1e-5
"""Cut-off of ``y(q) = (1 − q)^(−μ) − 1`` for the exact law (it needs one, docs §8)."""
EXPONENT_POINTS = 60
"""Points of the exponent window (log-spaced)."""
FIG3_EXACT_DGAMMAS = (1e-2, 1e-3)
"""The strain steps of the exact-law panel of Fig. 3 (the exact law costs seconds per δγ)."""
FIG3_EXACT_POINTS = 60
"""Points per curve of that panel (over ``|ΔE|/δγ ∈ [1e-4, 5]``)."""


@dataclass(frozen=True)
class ExponentCheck:
    """``τ = −d log P/d log |ΔE|`` of the exact and printed laws for ``y = (1−q)^(−μ) − 1``
    (``q_max = 1 − 1e-5``) at ``δγ = 1e-3``, read over ``|ΔE|/δγ ∈ [0.02, 0.15]``: the median
    and the range of the local slope over the window, against ``2μ``."""

    mu: float
    tau_exact: float
    tau_exact_min: float
    tau_exact_max: float
    tau_printed: float


def _exponent_check(mu: float, table: dict[str, np.ndarray]) -> ExponentCheck:
    """The check of ``μ`` from its exact-law table over the window."""
    slope = -np.asarray(table["slope_exact"])
    return ExponentCheck(mu=float(mu), tau_exact=float(np.median(slope)),
                         tau_exact_min=float(slope.min()), tau_exact_max=float(slope.max()),
                         tau_printed=float(np.median(-np.asarray(table["slope_printed"]))))


def exact_law_checks(mus: tuple[float, ...] | None = None
                     ) -> tuple[tuple[ExponentCheck, ...], dict]:
    """One :class:`ExponentCheck` per ``μ`` and the tables of the exact-law panel of Fig. 3
    (``{μ: {δγ: table}}``, :func:`jamlab.plots.theory.exact_jump_distribution_table` at
    ``FIG3_EXACT_DGAMMAS``) in one pass: the exponent window is read from the panel's law at
    ``δγ = EXPONENT_DGAMMA`` (the same law, built once). ``mus``:
    default ``μ_J`` and 0.5, the report's."""
    from jamlab.plots.theory import exact_jump_distribution_table
    from jamlab.theory import mu_jamming

    if mus is None:
        mus = (mu_jamming(), 0.5)
    checks, tables = [], {}
    for mu in mus:
        tab = exact_jump_distribution_table(
            mu, FIG3_EXACT_DGAMMAS, q_max=EXPONENT_Q_MAX, n_points=FIG3_EXACT_POINTS,
            windows={EXPONENT_DGAMMA: (EXPONENT_WINDOW, EXPONENT_POINTS)})
        checks.append(_exponent_check(mu, tab[EXPONENT_DGAMMA].pop("window")))
        tables[float(mu)] = tab
    return tuple(checks), tables


LINEAR_Y = (2.5, 0.0, 0.9)
"""The Parisi function of the checks: ``y(q) = 2.5 q`` (``y_0 = 0``) cut at ``q_max = 0.9``."""


@dataclass(frozen=True)
class NoJumpPoint:
    """P(no jump) at one ``dgamma``: exact recursion, sampled (± its standard error), printed."""

    dgamma: float
    exact: float
    sampled: float
    sampled_err: float
    printed: float


@dataclass(frozen=True)
class TheoryChecks:
    """The checks at ``k`` levels with ``n`` cascades per point: the points at ``cascade_dgammas``,
    the printed formula and its first-order form on a fine ``δγ`` grid, and the one-level case."""

    k: int
    n: int
    rows: tuple[NoJumpPoint, ...]
    fine_dgamma: tuple[float, ...]
    fine_printed: tuple[float, ...]
    fine_first_order: tuple[float, ...]
    k1_exact: float
    k1_sampled: float
    k1_sampled_err: float
    k1_chi: float
    exponents: tuple[ExponentCheck, ...] = ()

    def at(self, dgamma: float) -> NoJumpPoint:
        """The point at ``dgamma`` (one of the scale's ``cascade_dgammas``)."""
        return next(r for r in self.rows if r.dgamma == dgamma)


def printed_chi_one_level(y: float, dgamma: float) -> float:
    """The paper's Appendix ``χ_1(0)`` for ``k = 1``, ``q_1 = 0``, ``Y_1 = Δy_1 = y``:
    ``H(2 δγ y) + H(0) exp(−y δγ² y)`` with ``H(x) = erfc(x/2)/2`` (SPEC §1, "known
    discrepancy")."""
    from scipy.special import erfc

    a = dgamma * y
    return float(0.5 * erfc(a) + 0.5 * math.exp(-y * dgamma * dgamma * y))


def theory_checks(scale: Scale, exponents: tuple[ExponentCheck, ...]) -> TheoryChecks:
    """No-jump probabilities: printed formula, exact recursion, cascade sampler (y = 2.5 q,
    q_max = 0.9, ``cascade_k`` levels) at ``cascade_dgammas``, and the one-level case;
    ``exponents``: the checks of ``μ_J`` and 0.5 (:func:`exact_law_checks`, which makes them with
    the tables of Fig. 3's exact panel), carried into the result."""
    from jamlab.theory import (
        ParisiFunction,
        exact_jump_R,
        jump_distribution,
        jump_rate_first_order,
        one_level_R,
        sample_cascade_jumps,
    )

    pf = ParisiFunction.linear(*LINEAR_Y)
    q, y = pf.discretise(scale.cascade_k)
    rows = []
    for i, d in enumerate(scale.cascade_dgammas):
        r = sample_cascade_jumps(q, y, d, scale.cascade_samples, seed=scale.seed + 100 + i)
        p, se = r.p_no_jump()
        rows.append(NoJumpPoint(dgamma=d, exact=float(exact_jump_R(q, y, d, 0.0)[0]),
                                sampled=float(p), sampled_err=float(se),
                                printed=float(jump_distribution(pf, d).R(0.0))))
    fine = np.linspace(0.01, max(scale.cascade_dgammas) * 1.1, 40)
    rate = jump_rate_first_order(pf)
    k1 = sample_cascade_jumps([0.0], [1.0], 0.5, scale.cascade_samples, seed=scale.seed + 99)
    p1, se1 = k1.p_no_jump()
    return TheoryChecks(
        k=scale.cascade_k,
        n=scale.cascade_samples,
        rows=tuple(rows),
        fine_dgamma=tuple(fine.tolist()),
        fine_printed=tuple(float(jump_distribution(pf, d).R(0.0)) for d in fine),
        fine_first_order=tuple(np.exp(-fine * rate).tolist()),
        k1_exact=float(one_level_R(0.0, 1.0, 0.5)),
        k1_sampled=float(p1),
        k1_sampled_err=float(se1),
        k1_chi=printed_chi_one_level(1.0, 0.5),
        exponents=exponents,
    )
