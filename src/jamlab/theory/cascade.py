r"""Exact sampler of static jumps in a ``k``-level Derrida–Ruelle cascade (SPEC §2).

The cascade
-----------
``k`` levels, ``0 <= q_1 < ... < q_k < q_{k+1} = 1``, ``0 < y_1 < ... < y_k``. The root is the
level-1 node (energy 0, stress 0). A level-``i`` node's children form a Poisson process of
intensity ``exp(y_i (u - u_parent)) du``; each child's stress is its parent's plus an independent
``N(0, v_i)``, ``v_i = q_{i+1} - q_i``. Children of level-``k`` nodes are the states. The overlap of
two states is the ``q_i`` of their deepest common ancestor (level ``i``). At strain ``δγ`` the
ground state minimises ``V = U - δγ Σ``; a sample returns ``ΔE = ΔU - δγ ΔΣ`` (new minus old
ground state, ``ΔE <= 0``), ``ΔU``, ``ΔΣ`` and ``q_jump`` (``1`` when there is no jump).

The algorithm (exact, no truncation)
------------------------------------
Take ``δγ > 0`` (for ``δγ < 0`` flip every stress; the stress law is symmetric) and ``d = |δγ|``.
Give every edge the key increment ``a = Δu - d s⁺``. For any state the sum of the keys along its
path is ``A = U - d Σ_edges s⁺ <= min(U, U - dΣ)`` because ``Σ <= Σ s⁺`` and ``Σ s⁺ >= 0``.

* In the variable ``a`` a level-``i`` node's children are a Poisson process of intensity
  ``T_i e^{y_i a}``, ``T_i = E[e^{y_i d s⁺}] = ½ + e^{y_i² d² v_i/2} Φ(y_i d √v_i)``; given ``a``,
  the stress has density ``∝ φ_{v_i}(s) e^{y_i d s⁺}`` and ``Δu = a + d s⁺``.
* The minimum of ``A`` over a level-``i`` subtree, relative to its root, is Gumbel:
  ``P(min > m) = exp(-(c_i/y_i) e^{y_i m})`` with ``c_k = T_k``,
  ``c_i = T_i (c_{i+1}/y_{i+1})^{r_i} Γ(1 - r_i)``, ``r_i = y_i / y_{i+1}``; the children's subtree
  minima form a Poisson process of intensity ``c_i e^{y_i m}``.
* Splitting a child's subtree minimum ``m = a + G``: ``(c_{i+1}/y_{i+1}) e^{y_{i+1} G}`` is
  ``Gamma(1 - r_i, 1)`` independently of ``m``; the child's own children then have their first
  subtree minimum exactly at ``G`` and the rest a Poisson process on ``(G, ∞)``.

Child slots are kept in a heap keyed by their absolute lower bound and expanded best-first;
the search stops once the smallest key is ``>= max(U*, V*)`` (the best ``U`` and ``U - dΣ`` so
far): no state left unexplored can beat either, so both minimisers are exact.

With ``δγ = 0`` the old and new ground states coincide. (With ``d = 0``, ``T_i = 1`` and the
constants ``c_i`` reduce to SPEC §2's.)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import gammainc, gammaln, log_ndtr

from jamlab import validation
from jamlab.theory import _cascade_kernels as _k

__all__ = [
    "CascadeJumps",
    "cascade_constants",
    "sample_cascade_jumps",
    "sample_cascade_tree",
    "brute_force_cascade_jumps",
    "check_representable",
    "check_total_work",
    "expected_nodes_bound",
    "validate_levels",
]

MAX_NODES = 50_000_000
"""Most nodes one sample may materialise (its work arrays then take several GB). Reaching it is a
one-line ValueError; :func:`sample_cascade_jumps` refuses up front a strain at which one sample
would reach it with probability ``> 1 - MAX_MISS`` (:func:`check_representable`)."""

MAX_MISS = 1e-3
"""The up-front refusal's bound on the probability that one sample stays below ``MAX_NODES``."""

MAX_TOTAL_NODES = 1e10
"""Most nodes ``n`` samples together may draw: ``1e10`` nodes is ~25 min on one core at the
sampler's measured ~7e6 nodes/s (AMD EPYC, one level at δγ = 3–5; 1–3e6 nodes/s with two and
three levels). :func:`sample_cascade_jumps` refuses more up front by the lower bound
:func:`expected_nodes_bound` (``jamlab cascade --q 0 --y 1 --dgamma 5`` with the default
``--n 100000`` would draw ~2.7e10 nodes, about an hour), and while sampling by the running
projection (:data:`PROJECTION_AFTER`)."""

PROJECTION_AFTER = 1e8
"""Nodes drawn (1 % of :data:`MAX_TOTAL_NODES`) after which :func:`sample_cascade_jumps` stops
a run as soon as the mean nodes of its samples so far, times ``n``, exceed
:data:`MAX_TOTAL_NODES` (one-line ValueError naming the projection and the largest ``n`` that
fits). The up-front bound leaves out the stress increments and lies far below the mean with
several levels; this catches those runs after ~15–60 s instead of hours, and no run draws more
than ``MAX_TOTAL_NODES`` (plus one sample). With node counts this heavy-tailed (two levels at
δγ = 3: median 570, mean 3.2e4, largest of 200 3.6e6) an early projection can also
overshoot: the message says from how many samples it was made."""

MAX_LEVELS = 4096
"""Most levels ``k`` a ``ParisiFunction`` is discretised into for the sampler (``jamlab cascade
--k``). The sampler's constants ``log c_i`` grow faster than ``k`` (a ``Γ(1 − r_i)`` with
``1 − r_i = O(1/k)`` per level; ×2.2–2.4 per doubling of ``k``), so they overflow float64
(``log c > 709``) at ``k = 512`` for ``y = 2.5q`` (``q_max = 0.9``) and at ``k = 1024`` for
``power_law(μ_J)`` (``q_max = 1`` or ``0.9999``) and ``y = 5 + 100q`` (``q_max = 0.999``),
at ``δγ = 1e-3`` and ``0.1`` alike; the exact recursion is converged to ``5e-4`` at
``k = 512`` (``docs/theory-vs-cascade.md``, §4). ``4096`` is 4× the most levels any of them
represents; it refuses at once a ``k`` whose discretisation alone would take memory and time
without end."""


@dataclass(frozen=True)
class CascadeJumps:
    """Static jumps sampled from a cascade; every array has length ``n``.

    ``dE = dU - dgamma * dSigma`` (new minus old ground state, ``<= 0``), ``q_jump`` the overlap
    between old and new ground states (``1.0`` when they coincide), ``n_states`` the number of
    states (leaves) the exact sampler had to draw, ``n_nodes`` all nodes drawn.
    """

    dE: np.ndarray
    dU: np.ndarray
    dSigma: np.ndarray
    q_jump: np.ndarray
    n_states: np.ndarray
    n_nodes: np.ndarray
    q: np.ndarray
    y: np.ndarray
    dgamma: float
    seed: Any = field(default=None)

    @property
    def n(self) -> int:
        return int(self.dE.shape[0])

    @property
    def jumped(self) -> np.ndarray:
        """Boolean mask of samples in which the ground state changed."""
        return self.q_jump < 1.0

    def p_no_jump(self) -> tuple[float, float]:
        """Sampled no-jump probability and its binomial standard error."""
        p = float(np.mean(~self.jumped))
        return p, float(np.sqrt(max(p * (1 - p), 1e-300) / self.n))

    def R(self, x: np.ndarray | float) -> np.ndarray:
        """Empirical ``R(x) = P(ΔE >= x)`` for ``x <= 0`` (the printed theory's ``R``)."""
        xs = np.sort(self.dE)
        xa = np.atleast_1d(np.asarray(x, dtype=np.float64))
        return 1.0 - np.searchsorted(xs, xa, side="left") / self.n


def validate_levels(q: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
    """Check and convert the level parameters (ValueError naming the bad value)."""
    qa = np.atleast_1d(np.asarray(q, dtype=np.float64))
    ya = np.atleast_1d(np.asarray(y, dtype=np.float64))
    if qa.ndim != 1 or ya.ndim != 1 or qa.size == 0:
        raise ValueError(
            f"q and y must be non-empty 1-d sequences, got shapes {qa.shape}, {ya.shape}"
        )
    if qa.size != ya.size:
        raise ValueError(f"q and y must have the same length, got {qa.size} and {ya.size}")
    if not (np.all(np.isfinite(qa)) and np.all(np.isfinite(ya))):
        raise ValueError(f"q and y must be finite, got q={qa.tolist()}, y={ya.tolist()}")
    if qa[0] < 0.0 or qa[-1] >= 1.0:
        raise ValueError(f"q must lie in [0, 1), got q={qa.tolist()}")
    if np.any(np.diff(qa) <= 0.0):
        raise ValueError(f"q must be strictly increasing, got q={qa.tolist()}")
    if ya[0] <= 0.0:
        raise ValueError(f"y must be positive, got y_1={ya[0]!r}")
    if np.any(np.diff(ya) <= 0.0):
        raise ValueError(f"y must be strictly increasing, got y={ya.tolist()}")
    return qa, ya


def _levels_from(q: Any, y: Any, k: int | None) -> tuple[np.ndarray, np.ndarray]:
    if hasattr(q, "discretise"):
        if y is not None:
            raise ValueError("pass either a ParisiFunction (with k=) or arrays q and y, not both")
        if k is None or not 1 <= int(k) <= MAX_LEVELS:
            raise ValueError(f"a ParisiFunction needs 1 <= k <= {MAX_LEVELS} levels, got k={k!r}")
        qd, yd = q.discretise(int(k))
        return validate_levels(qd, yd)
    if y is None:
        raise ValueError("y is required when q is an array")
    return validate_levels(q, y)


def cascade_constants(q: Any, y: Any, dgamma: float) -> dict[str, np.ndarray]:
    """The constants of the best-first sampler for ``d = |dgamma|``.

    ``T_i = ½ + e^{y_i² d² v_i/2} Φ(y_i d √v_i)``, ``c_k = T_k``,
    ``c_i = T_i (c_{i+1}/y_{i+1})^{r_i} Γ(1 - r_i)``, ``r_i = y_i/y_{i+1}``,
    ``v_i = q_{i+1} - q_i``.
    Returns ``{"v", "sd", "T", "c"}``.
    """
    qa, ya = validate_levels(q, y)
    d = abs(float(dgamma))
    v = np.diff(np.append(qa, 1.0))
    b = ya * d * np.sqrt(v)
    with np.errstate(over="ignore"):  # an overflow is the one-line ValueError below
        T = 0.5 + np.exp(0.5 * b * b + log_ndtr(b))
    k = ya.size
    logc = np.empty(k)
    logc[-1] = np.log(T[-1])
    for i in range(k - 2, -1, -1):
        r = ya[i] / ya[i + 1]
        logc[i] = np.log(T[i]) + r * (logc[i + 1] - np.log(ya[i + 1])) + gammaln(1.0 - r)
    with np.errstate(over="ignore", invalid="ignore"):
        c = np.exp(logc)
    if not np.all(np.isfinite(c)) or np.any(c <= 0):
        raise ValueError(f"cascade constants overflow float64 for these {k} levels (y from "
                         f"{ya[0]:.6g} to {ya[-1]:.6g}) at dgamma={dgamma!r}: use fewer levels "
                         "or a smaller |dgamma|")
    return {"v": v, "sd": np.sqrt(v), "T": T, "c": c}


def check_representable(q: Any, y: Any, dgamma: float) -> None:
    r"""Refuse levels and a strain at which one sample exceeds :data:`MAX_NODES` (ValueError).

    Let ``g`` be the old ground state and ``n_i`` its level-``i`` ancestor. The other children of
    ``n_i`` whose subtree minimum of the bound ``A`` lies below ``U(g)`` are all drawn (the search
    stops at ``max(U*, V*) >= U(g)``), each a node of its own. Their number is Poisson with mean
    ``W_i (R_i e^{y_i d S_i} - 1) >= W_i (R_i - 1)``: ``R_i = c_i(δγ)/c_i(0)``, ``S_i >= 0`` the
    sum of the positive stress increments above ``n_i``, and ``W_i = (c_i(0)/y_i) e^{y_i m_g}``
    (``m_g`` the position of ``g``'s branch below ``n_i``) is ``Gamma(a_i, 1)``,
    ``a_i = 1 - y_{i-1}/y_i`` (``a_1 = 1``), independently for each ``i``. So one sample stays
    below ``M = MAX_NODES`` nodes with probability at most ``Π_i P(W_i < 2M/(R_i - 1))`` (plus
    Poisson tails ``< k e^{-M/4}``); refused when that is below :data:`MAX_MISS`. One level:
    ``R_1 = T_1 ≈ e^{(y d)²(1-q)/2}`` (``q = 0, y = 1``: refused from ``|δγ| = 7.2``).
    """
    qa, ya = validate_levels(q, y)
    a, log_r = _growth(qa, ya, _check_dgamma(dgamma))
    grows = log_r > 1e-12
    # 2M / (R - 1), 0 when R - 1 overflows
    t = 2.0 * MAX_NODES / np.expm1(np.minimum(log_r[grows], 709.0))
    with np.errstate(divide="ignore"):
        log_p = float(np.sum(np.log(gammainc(a[grows], t))))
    if log_p < np.log(MAX_MISS):
        raise ValueError(
            f"dgamma={dgamma!r} is too large for these levels (k={qa.size}, y up to "
            f"{ya[-1]:.4g}): one sample would need more than {MAX_NODES:.0e} nodes, the "
            "sampler's limit; use a smaller |dgamma|")


def _growth(qa: np.ndarray, ya: np.ndarray, dg: float) -> tuple[np.ndarray, np.ndarray]:
    """``(a_i, log R_i)``: the shapes ``a_i = 1 - y_{i-1}/y_i`` (``a_1 = 1``) of the weights
    ``W_i`` and ``R_i = c_i(δγ)/c_i(0)`` (:func:`check_representable`)."""
    log_r = np.log(cascade_constants(qa, ya, dg)["c"]) - np.log(
        cascade_constants(qa, ya, 0.0)["c"])
    a = 1.0 - np.concatenate(([0.0], ya[:-1] / ya[1:]))
    return a, log_r


def expected_nodes_bound(q: Any, y: Any, dgamma: float) -> float:
    r"""A lower bound on the mean number of nodes one sample draws: ``Σ_i a_i (R_i - 1)``.

    The other children of the old ground state's level-``i`` ancestor that the search must draw
    are Poisson with mean ``>= W_i (R_i - 1)``, ``W_i ~ Gamma(a_i, 1)`` (mean ``a_i``), and
    different ``i`` count different nodes (:func:`check_representable`). One level: the mean is
    ``R_1 - 1 = T_1 - 1`` itself (``q = 0, y = 1, δγ = 5``: 2.68e5; sampled 2.62e5 states).
    The bound leaves out the stress increments ``S_i`` and the nodes on the ground states' own
    paths, so with many close levels it can be far below the mean. ``inf`` when ``R_i``
    overflows.
    """
    qa, ya = validate_levels(q, y)
    a, log_r = _growth(qa, ya, _check_dgamma(dgamma))
    with np.errstate(over="ignore"):
        return float(np.sum(a * np.expm1(np.maximum(log_r, 0.0))))


def check_total_work(q: Any, y: Any, dgamma: float, n: int) -> None:
    """Refuse ``n`` samples whose expected nodes (by :func:`expected_nodes_bound`, a lower bound)
    exceed :data:`MAX_TOTAL_NODES` (ValueError naming the largest ``n`` that fits)."""
    per = expected_nodes_bound(q, y, dgamma)
    if n * per > MAX_TOTAL_NODES:
        fits = int(MAX_TOTAL_NODES // per) if np.isfinite(per) else 0
        raise ValueError(
            f"n={n} samples at dgamma={dgamma!r} would draw at least {n * per:.2g} nodes "
            f"({per:.2g} per sample; the limit is {MAX_TOTAL_NODES:.0e}, ~25 min on one core): "
            f"use n <= {fits} (and several seeds) or a smaller |dgamma|")


def _check_dgamma(dgamma: Any) -> float:
    try:
        dg = float(dgamma)
    except (TypeError, ValueError):
        raise ValueError(f"dgamma must be a real number, got {dgamma!r}") from None
    if not np.isfinite(dg):
        raise ValueError(f"dgamma must be finite, got {dgamma!r}")
    return dg


def _kernel_seed(seed: Any) -> int:
    if seed is None:
        raise ValueError("an explicit seed is required (an int or a numpy SeedSequence)")
    ss = (seed if isinstance(seed, np.random.SeedSequence)
          else np.random.SeedSequence(validation.seed("seed", seed)))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def sample_cascade_jumps(
    q: Any,
    y: Any = None,
    dgamma: float = 0.1,
    n: int = 10_000,
    seed: Any = None,
    *,
    k: int | None = None,
) -> CascadeJumps:
    """Sample ``n`` static jumps of the cascade with levels ``(q, y)`` at strain ``dgamma``.

    Exact: see the module docstring for the best-first search and its stopping rule.

    Parameters
    ----------
    q, y : array_like or ParisiFunction
        The ``k`` overlaps ``q_1..q_k`` and parameters ``y_1..y_k`` (SPEC §2), or ``q`` a
        ``ParisiFunction`` (then ``y`` is omitted and ``k`` gives the number of levels,
        ``ParisiFunction.discretise(k)``).
    dgamma : float
        The strain step ``δγ``.
    n : int
        Number of independent cascades (jumps) to sample.
    seed : int or numpy.random.SeedSequence
        Required; the result is a deterministic function of it.
    k : int, optional
        Levels when ``q`` is a ``ParisiFunction``.

    Returns
    -------
    CascadeJumps
        ``dE``, ``dU``, ``dSigma``, ``q_jump`` per sample (``q_jump = 1``, ``dE = 0`` when the
        ground state does not change) and summaries such as ``p_no_jump()``.

    Examples
    --------
    The sampler against the exact recursion for the probability of no jump:

    >>> from jamlab.theory import ParisiFunction, exact_jump_R, sample_cascade_jumps
    >>> y = ParisiFunction.linear(2.5, 0.0, 0.9)
    >>> jumps = sample_cascade_jumps(y, dgamma=0.1, n=20000, seed=1, k=16)
    >>> p, se = jumps.p_no_jump()
    >>> q16, y16 = y.discretise(16)
    >>> exact = float(exact_jump_R(q16, y16, 0.1, 0.0)[0])
    >>> round(exact, 4), abs(p - exact) < 4 * se, bool((jumps.dE <= 0).all())
    (0.9119, True, True)
    """
    qa, ya = _levels_from(q, y, k)
    dg = _check_dgamma(dgamma)
    if isinstance(n, bool) or int(n) != n or int(n) < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    n = int(n)
    check_representable(qa, ya, dg)
    check_total_work(qa, ya, dg, n)
    cst = cascade_constants(qa, ya, dg)
    try:
        out = _k.sample_batch(
            ya, cst["sd"], cst["T"], cst["c"], abs(dg), n, _kernel_seed(seed), MAX_NODES,
            MAX_TOTAL_NODES, PROJECTION_AFTER,
        )
    except RuntimeError as e:  # the kernel's node limit; its samples are lost with it
        if "max_nodes" not in str(e):
            raise
        raise ValueError(
            f"a cascade sample needed more than {MAX_NODES:.0e} nodes (the sampler's limit) at "
            f"dgamma={dgamma!r} with {qa.size} levels (y up to {ya[-1]:.4g}): use a smaller "
            "|dgamma| (or fewer levels, a lower y)") from None
    if out.shape[0] < n:  # the running projection stopped the run (PROJECTION_AFTER)
        drawn = float(out[:, _k.OUT_NNODES].sum())
        per = drawn / out.shape[0]
        raise ValueError(
            f"n={n} samples at dgamma={dgamma!r} with {qa.size} levels project to "
            f"{per * n:.2g} nodes ({per:.2g} per sample over the first {out.shape[0]}, "
            f"{drawn:.2g} drawn; the limit is {MAX_TOTAL_NODES:.0e}): use n <= "
            f"{int(MAX_TOTAL_NODES // per)} (and several seeds) or a smaller |dgamma|")
    du = out[:, _k.OUT_DU].copy()
    ds = out[:, _k.OUT_DS].copy()
    if dg < 0:
        ds = -ds
    level = out[:, _k.OUT_LEVEL].astype(np.int64)
    qext = np.append(qa, 1.0)
    qj = qext[level - 1]
    dE = du - dg * ds
    # exact zeros when there is no jump
    same = level == qa.size + 1
    dE[same] = 0.0
    return CascadeJumps(
        dE=dE,
        dU=du,
        dSigma=ds,
        q_jump=qj,
        n_states=out[:, _k.OUT_NSTATES].astype(np.int64),
        n_nodes=out[:, _k.OUT_NNODES].astype(np.int64),
        q=qa,
        y=ya,
        dgamma=dg,
        seed=seed,
    )


@dataclass(frozen=True)
class CascadeTree:
    """One sampled cascade: all nodes below a threshold, with the two ground states.

    ``parent[j]`` (``-1`` for the root), ``level[j]`` (1 = root, ``k + 1`` = state), absolute
    energy ``U`` and stress ``Sigma``; ``old_gs``, ``new_gs`` index the minimisers of ``U`` and of
    ``U - dgamma Σ``. ``window`` is the window asked for, ``complete_window`` the one the tree
    holds: every state whose ``min(U, U - |δγ|Σ)`` lies within it of ``max(U*, V*)``. They differ
    only when the tree stopped at :data:`TREE_MAX_NODES` nodes (``truncated``).
    """

    parent: np.ndarray
    level: np.ndarray
    U: np.ndarray
    Sigma: np.ndarray
    old_gs: int
    new_gs: int
    q: np.ndarray
    y: np.ndarray
    dgamma: float
    window: float
    complete_window: float

    @property
    def truncated(self) -> bool:
        """True when the tree holds fewer states than ``window`` asked for (node limit)."""
        return self.complete_window < self.window


TREE_MAX_NODES = _k.TREE_MAX_NODES
"""Most nodes :func:`sample_cascade_tree` draws (65534). A tree that reaches it before both ground
states are settled is refused (ValueError); one that reaches it while drawing the window around
them is returned with ``truncated`` set and the window it does hold."""


def sample_cascade_tree(
    q: Any,
    y: Any = None,
    dgamma: float = 0.1,
    seed: Any = None,
    *,
    k: int | None = None,
    window: float = 1.5,
) -> CascadeTree:
    """One cascade with every state whose ``min(U, U - |δγ|Σ)`` lies within ``window`` of the
    larger of the two ground-state values (plus their ancestors); for pictures.

    The same search as :func:`sample_cascade_jumps`: for a given ``seed`` it draws the cascade of
    that function's first sample (``window=0`` gives exactly the nodes that sample drew). At most
    :data:`TREE_MAX_NODES` nodes: the window may then be narrower than asked
    (``CascadeTree.truncated``, ``complete_window``); a sample that needs more nodes than that to
    settle its two ground states is a ValueError."""
    qa, ya = _levels_from(q, y, k)
    dg = _check_dgamma(dgamma)
    if not np.isfinite(window) or window < 0:
        raise ValueError(f"window must be >= 0, got {window!r}")
    cst = cascade_constants(qa, ya, dg)
    d = abs(dg)
    par, lev, u, s, iu, iv, reach = _k.sample_tree(
        ya, cst["sd"], cst["T"], cst["c"], d, _kernel_seed(seed), float(window)
    )
    settled = iu >= 0 and reach >= max(u[iu], u[iv] - d * s[iv])
    if not settled:
        raise ValueError(
            f"the cascade tree needs more than {TREE_MAX_NODES} nodes to settle its two ground "
            f"states at dgamma={dgamma!r} (k={qa.size}, seed={seed!r}): use a smaller |dgamma| "
            "or another seed")
    drawn = min(float(window), reach - max(u[iu], u[iv] - d * s[iv]))
    if dg < 0:
        s = -s
    return CascadeTree(par, lev, u, s, int(iu), int(iv), qa, ya, dg, float(window), drawn)


def brute_force_cascade_jumps(
    q: Any,
    y: Any,
    dgamma: float,
    n: int,
    seed: Any,
    *,
    window: float | None = None,
    top_cut: float = 25.0,
) -> CascadeJumps:
    """Plain enumeration sampler for ``k = 1, 2`` (independent check of the best-first search).

    Draws, for ``k = 1``, the minimum state (``e^{y u_0}/y ~ Exp(1)``) and every other state in
    ``(u_0, u_0 + W]``; for ``k = 2``, every level-2 node with ``u <= top_cut`` (a plain Poisson
    process of intensity ``e^{y_1 u}`` on ``(-∞, top_cut]``), the minimum of each node's states
    (Gumbel), and every state within ``W`` of the overall minimum. ``W`` defaults to
    ``4 d² (1-q_1) y_k + 8 d √(1-q_1)``, beyond which a state beats the old ground state in
    ``U - dΣ`` with probability ``< e^{-16}``; the cut ``top_cut`` misses a relevant level-2 node
    with probability ``~ e^{y_k W - (y_2-y_1) top_cut}``.
    """
    qa, ya = validate_levels(q, y)
    dg = _check_dgamma(dgamma)
    d = abs(dg)
    kk = qa.size
    if kk > 2:
        raise ValueError(f"the brute-force sampler handles k = 1, 2 only, got k={kk}")
    v = np.diff(np.append(qa, 1.0))
    if window is None:
        window = 4 * d * d * (1 - qa[0]) * ya[-1] + 8 * d * np.sqrt(1 - qa[0]) + 1e-12
    W = float(window)
    rng = np.random.default_rng(seed)
    dE = np.empty(n)
    dU = np.empty(n)
    dS = np.empty(n)
    qj = np.empty(n)
    nst = np.empty(n, np.int64)
    for t in range(n):
        if kk == 1:
            yk = ya[0]
            u0 = np.log(rng.exponential() * yk) / yk
            nrest = rng.poisson(np.exp(yk * u0) / yk * np.expm1(yk * W))
            ur = np.log(np.exp(yk * u0) + rng.random(nrest) * np.exp(yk * u0) * np.expm1(yk * W))
            u = np.concatenate(([u0], ur / yk))
            s = rng.normal(0.0, np.sqrt(v[0]), u.size)
            node = np.zeros(u.size, np.int64)
        else:
            y1, y2 = ya
            n1 = rng.poisson(np.exp(y1 * top_cut) / y1)
            u1 = top_cut + np.log(rng.random(n1)) / y1
            s1 = rng.normal(0.0, np.sqrt(v[0]), n1)
            mins = u1 + np.log(rng.exponential(size=n1) * y2) / y2
            top = mins.min() + W
            sel = np.nonzero(mins < top)[0]
            us, ss, nodes = [], [], []
            for j in sel:
                base = np.exp(y2 * (mins[j] - u1[j]))
                mass = (np.exp(y2 * (top - u1[j])) - base) / y2
                nr = rng.poisson(mass)
                ur = u1[j] + np.log(base + rng.random(nr) * y2 * mass) / y2
                uj = np.concatenate(([mins[j]], ur))
                us.append(uj)
                ss.append(s1[j] + rng.normal(0.0, np.sqrt(v[1]), uj.size))
                nodes.append(np.full(uj.size, j))
            u = np.concatenate(us)
            s = np.concatenate(ss)
            node = np.concatenate(nodes)
        iu = int(np.argmin(u))
        iv = int(np.argmin(u - d * s))
        dU[t] = u[iv] - u[iu]
        dS[t] = s[iv] - s[iu]
        if iu == iv:
            qj[t] = 1.0
        elif node[iu] == node[iv] and kk == 2:
            qj[t] = qa[1]
        else:
            qj[t] = qa[0]
        nst[t] = u.size
    if dg < 0:
        dS = -dS
    dE = dU - dg * dS
    dE[qj == 1.0] = 0.0
    return CascadeJumps(dE, dU, dS, qj, nst, nst.copy(), qa, ya, dg, seed)
