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
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize_scalar
from scipy.spatial import cKDTree

from jamlab.analysis.powerlaw import mle_tau

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
IntArray = NDArray[np.intp]

THETA_E = 0.42311
"""Mean-field extended small-force exponent (``SPEC.md`` §6)."""
GAMMA = 0.41269
"""Mean-field gap exponent ``γ = 1/(2 + θ_e)`` (``SPEC.md`` §6)."""
THETA_L = 0.17
"""Localized small-force exponent in 3D (approximate; ``SPEC.md`` §6)."""


# ------------------------------------------------------------------------------------------------
# pairs


@dataclass(frozen=True, eq=False)
class PairList:
    """Pairs ``i < j`` closer than a cut-off: separation vectors ``rij = r_i − r_j`` of the
    (unique) interacting image, distances ``r`` and ``σ_ij``."""

    i: IntArray
    j: IntArray
    rij: FloatArray
    r: FloatArray
    sigma: FloatArray


def _diameters(diameters: ArrayLike | None, n: int) -> FloatArray:
    if diameters is None:
        return np.ones(n)
    dia = np.asarray(diameters, dtype=np.float64)
    if dia.shape != (n,):
        raise ValueError(f"diameters must have shape ({n},), got {dia.shape}")
    if not (np.all(np.isfinite(dia)) and np.all(dia > 0)):
        raise ValueError("diameters must be finite and > 0")
    return dia


def _check_positions(positions: ArrayLike, box_length: float) -> FloatArray:
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] < 2 or pos.shape[0] < 2:
        raise ValueError(f"positions must have shape (N >= 2, d >= 2), got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError("positions must be finite")
    if not (math.isfinite(box_length) and box_length > 0):
        raise ValueError(f"box length must be finite and > 0, got {box_length!r}")
    return pos


def pairs_within(
    positions: ArrayLike,
    box_length: float,
    strain: float = 0.0,
    diameters: ArrayLike | None = None,
    h_max: float = 0.5,
) -> PairList:
    """Every pair ``i < j`` with ``r_ij < σ_ij (1 + h_max)`` in the Lees–Edwards box.

    Positions are wrapped into the primary cell of the sheared lattice (strain reduced to
    ``γ − round(γ)``), the ``3^d`` images ``n_x L e_x + n_y (γ L e_x + L e_y) + Σ_k n_k L e_k``,
    ``n ∈ {−1, 0, 1}^d``, are put in a k-d tree, and each particle is paired with every image
    within the cut-off. With ``|γ| ≤ 1/2`` and a cut-off below ``L/2`` these images contain every
    interacting one and each pair has a single interacting image (``ValueError`` otherwise).
    """
    pos = _check_positions(positions, box_length)
    n, d = pos.shape
    if not (math.isfinite(h_max) and h_max >= 0):
        raise ValueError(f"h_max must be finite and >= 0, got {h_max!r}")
    dia = _diameters(diameters, n)
    length = float(box_length)
    cutoff = float(dia.max()) * (1.0 + h_max)
    if not cutoff < length / 2:
        raise ValueError(
            f"cut-off max(D)(1 + h_max) = {cutoff:.4g} must be below L/2 = {length / 2:.4g}"
        )
    g = float(strain) - math.floor(float(strain) + 0.5)
    w = pos.copy()
    ny = np.floor(w[:, 1] / length)
    w[:, 1] -= ny * length
    w[:, 0] -= ny * g * length
    for a in range(d):
        if a != 1:
            w[:, a] -= np.floor(w[:, a] / length) * length
    grid = np.array(np.meshgrid(*([(-1, 0, 1)] * d), indexing="ij")).reshape(d, -1).T
    shifts = grid * length
    shifts[:, 0] += grid[:, 1] * g * length
    images = (w[None, :, :] + shifts[:, None, :]).reshape(-1, d)
    found = cKDTree(w).sparse_distance_matrix(cKDTree(images), cutoff, output_type="ndarray")
    i = found["i"].astype(np.intp)
    k = found["j"].astype(np.intp)
    j = k % n
    keep = i < j
    i, j, k = i[keep], j[keep], k[keep]
    rij = w[i] - images[k]
    r = np.sqrt(np.einsum("ij,ij->i", rij, rij))
    sigma = 0.5 * (dia[i] + dia[j])
    inside = r < sigma * (1.0 + h_max)
    i, j, rij, r, sigma = i[inside], j[inside], rij[inside], r[inside], sigma[inside]
    if np.unique(i * n + j).size != i.size:
        raise ValueError("a pair interacts through two images: the box is too small")
    order = np.lexsort((j, i))
    return PairList(i[order], j[order], rij[order], r[order], sigma[order])


def pair_force(r: ArrayLike, sigma: ArrayLike, alpha: float = 2.0) -> FloatArray:
    """Contact force ``f = −V'(r) = α (1 − r/σ)^(α−1)/σ`` for ``r < σ`` (0 otherwise) of
    ``V(r) = (1 − r/σ)^α``."""
    if not (math.isfinite(alpha) and alpha > 1):
        raise ValueError(f"pair exponent alpha must be > 1, got {alpha!r}")
    r = np.asarray(r, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    overlap = np.clip(1.0 - r / sigma, 0.0, None)
    return alpha * overlap ** (alpha - 1.0) / sigma


def backbone_mask(n: int, i: ArrayLike, j: ArrayLike, dim: int) -> NDArray[np.bool_]:
    """Particles kept after removing, repeatedly, those with fewer than ``d + 1`` contacts among
    the kept ones (``SPEC.md`` §3); ``i, j`` are the contacts."""
    i = np.asarray(i, dtype=np.intp)
    j = np.asarray(j, dtype=np.intp)
    keep = np.ones(n, dtype=bool)
    while True:
        live = keep[i] & keep[j]
        count = np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        drop = keep & (count < dim + 1)
        if not drop.any():
            return keep
        keep &= ~drop


def bucklers(
    n: int, i: ArrayLike, j: ArrayLike, force: ArrayLike, dim: int
) -> tuple[IntArray, NDArray[np.bool_]]:
    """Bucklers and localized contacts of a backbone whose contacts are ``(i, j)`` with forces
    ``force``: the particles with exactly ``d + 1`` contacts, and a mask over the contacts, True
    for the weakest contact of some buckler (ties: the first in the list)."""
    i = np.asarray(i, dtype=np.intp)
    j = np.asarray(j, dtype=np.intp)
    force = np.asarray(force, dtype=np.float64)
    count = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    buck = np.flatnonzero(count == dim + 1)
    localized = np.zeros(i.size, dtype=bool)
    if buck.size == 0 or i.size == 0:
        return buck, localized
    # per particle, the index of its weakest contact: sort (particle, force) and take the first
    ends = np.concatenate([i, j])
    idx = np.concatenate([np.arange(i.size), np.arange(i.size)])
    order = np.lexsort((idx, force[idx], ends))
    first = np.ones(order.size, dtype=bool)
    first[1:] = ends[order][1:] != ends[order][:-1]
    weakest = np.full(n, -1, dtype=np.intp)
    weakest[ends[order][first]] = idx[order][first]
    localized[weakest[buck]] = True
    return buck, localized


@dataclass(frozen=True, eq=False)
class PackingObservables:
    """Forces, gaps and bucklers of one packing.

    ``backbone``: mask of non-rattlers; ``contact_i, contact_j, force``: backbone contacts and their
    forces ``f = −V'(r)`` (absolute units); ``mean_force``: their mean; ``localized``: mask over
    those contacts (weakest contact of a buckler); ``buckler_ids``: the bucklers; ``gap_i, gap_j,
    gap``: non-contact pairs with ``0 < h ≤ h_max`` (both ends on the backbone unless
    ``include_rattlers``); ``n_all_contacts``: contacts of all particles, rattlers included.
    """

    n: int
    dim: int
    backbone: NDArray[np.bool_]
    contact_i: IntArray
    contact_j: IntArray
    force: FloatArray
    mean_force: float
    localized: NDArray[np.bool_]
    buckler_ids: IntArray
    gap_i: IntArray
    gap_j: IntArray
    gap: FloatArray
    h_max: float
    n_all_contacts: int

    @property
    def n_rattlers(self) -> int:
        return int(self.n - self.backbone.sum())

    @property
    def n_contacts(self) -> int:
        """Backbone contacts ``N_c'``."""
        return int(self.force.size)

    @property
    def isostatic_excess(self) -> int:
        """``N_c' − (d(N' − 1) + 1)``."""
        return self.n_contacts - (self.dim * (int(self.backbone.sum()) - 1) + 1)

    @property
    def scaled_force(self) -> FloatArray:
        """``f / ⟨f⟩`` over the backbone contacts."""
        return self.force / self.mean_force

    @property
    def extended_force(self) -> FloatArray:
        """``f / ⟨f⟩`` of the extended contacts."""
        return self.scaled_force[~self.localized]

    @property
    def localized_force(self) -> FloatArray:
        """``f / ⟨f⟩`` of the localized contacts."""
        return self.scaled_force[self.localized]


def packing_observables(
    positions: ArrayLike,
    box_length: float,
    strain: float = 0.0,
    diameters: ArrayLike | None = None,
    alpha: float = 2.0,
    h_max: float = 0.5,
    include_rattlers: bool = False,
    pairs: PairList | None = None,
) -> PackingObservables:
    """Contacts, backbone, forces, bucklers and gaps of one packing (module docstring).

    ``pairs``: a precomputed :class:`PairList` holding at least every pair with
    ``r < σ_ij (1 + h_max)`` (then positions only give ``N`` and ``d``).
    """
    pos = _check_positions(positions, box_length)
    n, d = pos.shape
    if pairs is None:
        pairs = pairs_within(pos, box_length, strain, diameters, h_max)
    h = pairs.r / pairs.sigma - 1.0
    contact = h < 0
    ci, cj = pairs.i[contact], pairs.j[contact]
    keep = backbone_mask(n, ci, cj, d)
    live = keep[ci] & keep[cj]
    bi, bj = ci[live], cj[live]
    force = pair_force(pairs.r[contact][live], pairs.sigma[contact][live], alpha)
    buck, localized = bucklers(n, bi, bj, force, d)
    gap_pair = ~contact & (h <= h_max)
    if not include_rattlers:
        gap_pair &= keep[pairs.i] & keep[pairs.j]
    return PackingObservables(
        n=n,
        dim=d,
        backbone=keep,
        contact_i=bi,
        contact_j=bj,
        force=force,
        mean_force=float(force.mean()) if force.size else math.nan,
        localized=localized,
        buckler_ids=buck,
        gap_i=pairs.i[gap_pair],
        gap_j=pairs.j[gap_pair],
        gap=h[gap_pair],
        h_max=float(h_max),
        n_all_contacts=int(contact.sum()),
    )


# ------------------------------------------------------------------------------------------------
# exponents


def _samples(samples: Sequence[ArrayLike]) -> list[FloatArray]:
    out = [np.sort(np.asarray(s, dtype=np.float64).ravel()) for s in samples]
    if not out:
        raise ValueError("need at least one packing's samples")
    return out


def empirical_cdf(samples: Sequence[ArrayLike], x: ArrayLike) -> FloatArray:
    """Pooled ``F(x) = #{samples ≤ x} / #{samples}`` over all packings."""
    s = _samples(samples)
    x = np.asarray(x, dtype=np.float64)
    counts = sum(np.searchsorted(a, x, side="right") for a in s)
    total = sum(a.size for a in s)
    return np.asarray(counts, dtype=np.float64) / total


@dataclass(frozen=True)
class ExponentFit:
    """Density exponent ``a`` of ``P(x) ~ x^a`` on ``window`` (so ``F(x) ~ x^(1+a)``): ``θ = a``
    for forces, ``γ = −a`` for gaps. ``ci95``: bootstrap percentile interval over packings;
    ``n_packings``, ``n_samples`` (all), ``n_in_window``; ``method``: ``"cdf"``, ``"plain"`` or
    ``"mle"`` (:func:`fit_exponent`); ``n_boot``: bootstrap resamples used."""

    value: float
    ci95: tuple[float, float]
    window: tuple[float, float]
    n_packings: int
    n_samples: int
    n_in_window: int
    method: str
    n_boot: int

    def negated(self) -> ExponentFit:
        """The same fit for ``−a`` (``γ`` from the gap fit)."""
        lo, hi = self.ci95
        return ExponentFit(
            -self.value,
            (-hi, -lo),
            self.window,
            self.n_packings,
            self.n_samples,
            self.n_in_window,
            self.method,
            self.n_boot,
        )

    def as_dict(self) -> dict[str, object]:
        return {
            "value": self.value,
            "ci95": list(self.ci95),
            "window": list(self.window),
            "n_packings": self.n_packings,
            "n_samples": self.n_samples,
            "n_in_window": self.n_in_window,
            "method": self.method,
        }


_METHODS = ("cdf", "plain", "mle")


def _T975(dof: int) -> float:
    """97.5 % quantile of Student's t with ``dof`` degrees of freedom."""
    from scipy.stats import t

    return float(t.ppf(0.975, dof))


def _check_window(window: tuple[float, float]) -> tuple[float, float]:
    lo, hi = (float(w) for w in window)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"window must satisfy 0 < lo < hi, got {window!r}")
    return lo, hi


def _plain_slope(counts: FloatArray, log_x: FloatArray) -> float:
    """``a`` from the least-squares slope ``1 + a`` of ``log counts`` against ``log x`` (counts
    ∝ F) over the positive counts; NaN with fewer than two."""
    ok = counts > 0
    if ok.sum() < 2:
        return math.nan
    return float(np.polyfit(log_x[ok], np.log(counts[ok]), 1)[0]) - 1.0


def _window_cdf_exponent(counts: FloatArray, log_x: FloatArray) -> float:
    """``a`` minimising ``Σ_k (F̂_w(x_k) − F_w(x_k; a))²`` over the interior grid points, with
    ``F̂_w = (C(x_k) − C(lo⁻))/(C(hi) − C(lo⁻))`` from the counts (``counts[0]``: below ``lo``,
    ``counts[-1]``: up to ``hi``) and ``F_w(x; a) = (x^(1+a) − lo^(1+a))/(hi^(1+a) − lo^(1+a))``;
    NaN with fewer than two samples in the window."""
    inside = counts[-1] - counts[0]
    if inside < 2:
        return math.nan
    emp = (counts[1:-1] - counts[0]) / inside
    t = log_x[1:-1] - log_x[0]
    span = log_x[-1] - log_x[0]

    def loss(u: float) -> float:
        model = np.expm1(u * t) / math.expm1(u * span)
        return float(np.sum((emp - model) ** 2))

    # 1 + a in [1e-3, 6]: every exponent a density can have near 0 (a > −1) up to a steep 5
    res = minimize_scalar(loss, bounds=(1e-3, 6.0), method="bounded", options={"xatol": 1e-7})
    return float(res.x) - 1.0


def fit_exponent(
    samples: Sequence[ArrayLike],
    window: tuple[float, float],
    method: str = "cdf",
    n_boot: int = 1000,
    seed: int = 0,
    n_points: int = 20,
) -> ExponentFit:
    """Exponent ``a`` of ``P(x) ~ x^a`` from samples of several packings on ``window``.

    All three methods work on the pooled samples at ``n_points`` points ``x_k`` log-spaced over
    the window ``[lo, hi]``:

    - ``"cdf"`` (default): the empirical CDF *of the window*,
      ``F̂_w(x) = #{lo ≤ X ≤ x}/#{lo ≤ X ≤ hi}``, fitted by least squares to
      ``(x^(1+a) − lo^(1+a))/(hi^(1+a) − lo^(1+a))``, the CDF of a density ``∝ x^a`` on the
      window. It does not see the mass outside the window, so a finite-size cut-off below
      ``lo`` does not bias it.
    - ``"plain"`` (``SPEC.md`` §6 read literally): ``1 + a`` is the least-squares slope of
      ``log F(x_k)`` against ``log x_k``, ``F`` the CDF of all samples. A deficit of samples
      below ``lo`` (the finite-size cut-off) steepens it by about
      ``(1 + a) × deficit / #(X ≤ lo)``.
    - ``"mle"``: the maximum-likelihood exponent of the truncated power law ``∝ x^a`` on the
      window (:func:`jamlab.analysis.powerlaw.mle_tau`).

    The 95 % interval is ``a ± t_{0.975, m−1} √(m/(m−1)) s_boot`` with ``s_boot`` the standard
    deviation of ``a`` over ``n_boot`` resamples of the ``m`` packings with replacement
    (``numpy.random.default_rng(seed)``): the bootstrap standard error with the small-sample
    corrections of a mean over ``m`` packings (the plain percentile interval covered the true
    exponent in only ~88 % of synthetic trials with ``m = 20``; ``docs/criticality.md``).
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {', '.join(_METHODS)}, got {method!r}")
    lo, hi = _check_window(window)
    if not (isinstance(n_boot, int) and n_boot >= 0):
        raise ValueError(f"n_boot must be an integer >= 0, got {n_boot!r}")
    s = _samples(samples)
    m = len(s)
    in_window = [a[(a >= lo) & (a <= hi)] for a in s]
    n_in = int(sum(a.size for a in in_window))
    if n_in < 2:
        raise ValueError(f"fewer than 2 samples in the window [{lo:.3g}, {hi:.3g}]")
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, m, size=(n_boot, m))
    if method == "mle":
        value = -mle_tau(np.concatenate(in_window), lo, hi)[0]
        boot = np.array(
            [-mle_tau(np.concatenate([in_window[k] for k in p]), lo, hi)[0] for p in picks]
        )
    else:
        x = np.geomspace(lo, hi, n_points)
        log_x = np.log(x)
        estimate = _plain_slope if method == "plain" else _window_cdf_exponent
        if method == "cdf":
            # counts strictly below lo, then up to each grid point (a bootstrap sums rows)
            rows = np.array(
                [
                    np.concatenate(
                        [
                            [np.searchsorted(a, lo, side="left")],
                            np.searchsorted(a, x[1:], side="right"),
                        ]
                    )
                    for a in s
                ],
                dtype=np.float64,
            )
        else:
            rows = np.array([np.searchsorted(a, x, side="right") for a in s], dtype=np.float64)
        value = estimate(rows.sum(axis=0), log_x)
        boot = np.array([estimate(rows[p].sum(axis=0), log_x) for p in picks])
    boot = boot[np.isfinite(boot)]
    ci = (math.nan, math.nan)
    if boot.size > 1 and m > 1:
        half = _T975(m - 1) * math.sqrt(m / (m - 1)) * float(np.std(boot, ddof=1))
        ci = (float(value) - half, float(value) + half)
    return ExponentFit(
        value=float(value),
        ci95=ci,
        window=(lo, hi),
        n_packings=m,
        n_samples=int(sum(a.size for a in s)),
        n_in_window=n_in,
        method=method,
        n_boot=int(boot.size),
    )


@dataclass(frozen=True, eq=False)
class LocalExponents:
    """Exponent fitted on consecutive windows ``[lo_k, hi_k]``: ``value``, ``ci_low``,
    ``ci_high`` (NaN where a window holds fewer than ``min_count`` samples) and ``n_in_window``."""

    lo: FloatArray
    hi: FloatArray
    value: FloatArray
    ci_low: FloatArray
    ci_high: FloatArray
    n_in_window: IntArray

    @property
    def center(self) -> FloatArray:
        return np.sqrt(self.lo * self.hi)


def local_exponents(
    samples: Sequence[ArrayLike],
    x_min: float,
    x_max: float,
    width_decades: float = 1.0,
    step_decades: float = 0.5,
    method: str = "cdf",
    n_boot: int = 200,
    seed: int = 0,
    min_count: int = 20,
) -> LocalExponents:
    """The exponent of :func:`fit_exponent` on sliding windows ``[x, x·10^width]`` with ``x``
    from ``x_min`` in steps of ``step_decades`` until the window passes ``x_max``."""
    _check_window((x_min, x_max))
    if not (width_decades > 0 and step_decades > 0):
        raise ValueError("width_decades and step_decades must be > 0")
    s = _samples(samples)
    n_win = int(math.floor((math.log10(x_max / x_min) - width_decades) / step_decades + 1e-9)) + 1
    los = x_min * 10.0 ** (step_decades * np.arange(max(n_win, 0)))
    his = los * 10.0**width_decades
    vals, clo, chi, counts = [], [], [], []
    for lo, hi in zip(los, his, strict=True):
        count = int(sum(((a >= lo) & (a <= hi)).sum() for a in s))
        counts.append(count)
        if count < min_count:
            vals.append(math.nan)
            clo.append(math.nan)
            chi.append(math.nan)
            continue
        fit = fit_exponent(s, (lo, hi), method, n_boot, seed)
        vals.append(fit.value)
        clo.append(fit.ci95[0])
        chi.append(fit.ci95[1])
    return LocalExponents(
        lo=np.asarray(los),
        hi=np.asarray(his),
        value=np.asarray(vals),
        ci_low=np.asarray(clo),
        ci_high=np.asarray(chi),
        n_in_window=np.asarray(counts, dtype=np.intp),
    )


@dataclass(frozen=True)
class WindowRule:
    """The fit window: from the value below which the packings hold on average ``per_packing``
    samples each (a factor above the finite-size cut-off, where they hold about one) to the
    fixed upper end ``upper`` (the crossover to the bulk)."""

    per_packing: float
    upper: float


def choose_window(samples: Sequence[ArrayLike], rule: WindowRule) -> tuple[float, float]:
    """The window ``[x_lo, rule.upper]`` of :class:`WindowRule`: ``x_lo`` is the pooled
    ``rule.per_packing × (number of packings)``-th smallest sample. ``ValueError`` if
    ``x_lo ≥ upper``."""
    s = _samples(samples)
    pooled = np.sort(np.concatenate(s))
    k = int(math.ceil(rule.per_packing * len(s)))
    if not 1 <= k <= pooled.size:
        raise ValueError(
            f"cannot place the window: need {k} samples, have {pooled.size} in {len(s)} packings"
        )
    lo = float(pooled[k - 1])
    if not lo < rule.upper:
        raise ValueError(
            f"empty window: the lower end {lo:.3g} ({rule.per_packing} samples per packing) is "
            f"not below the upper end {rule.upper:.3g}"
        )
    return lo, float(rule.upper)


def finite_size_cutoff(n: ArrayLike, exponent: float, prefactor: float = 1.0) -> FloatArray:
    """``x_min = c N^(−1/(1+a))``: the value below which ``N`` samples of a density ``∝ x^a``
    hold ``O(1)`` of them (``F(x_min) N ~ 1`` with ``F(x) ~ x^(1+a)``; ``a = θ`` for forces,
    ``−γ`` for gaps)."""
    if not exponent > -1:
        raise ValueError(f"exponent must be > -1, got {exponent!r}")
    return prefactor * np.asarray(n, dtype=np.float64) ** (-1.0 / (1.0 + exponent))


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
) -> dict[str, ExponentFit]:
    """``θ_e``, ``θ_l`` and ``γ`` (sign flipped from the gap fit) pooled over ``observables``,
    each on ``windows[name]`` if given, else on the window of ``rules[name]``
    (:data:`DEFAULT_RULES`)."""
    rules = DEFAULT_RULES if rules is None else rules
    windows = {} if windows is None else windows
    out: dict[str, ExponentFit] = {}
    for name, samples in criticality_samples(observables).items():
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
