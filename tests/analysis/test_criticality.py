"""Jamming criticality: forces, gaps and bucklers against a brute-force recount over all pairs and
all periodic images; the exponent fitter against synthetic samples of known exponent."""

import itertools
import math

import numpy as np
import pytest

from jamlab.analysis.criticality import (
    WindowRule,
    backbone_mask,
    choose_window,
    empirical_cdf,
    finite_size_cutoff,
    fit_exponent,
    local_exponents,
    packing_observables,
    pair_force,
    pairs_within,
)
from jamlab.spheres.packing import jam, relax
from jamlab.spheres.potential import (
    Packing,
    affine_shear,
    pressure,
    random_packing,
    remove_rattlers,
)

# --- brute force (independent of the module under test) ------------------------------------------


def _brute_pairs(pos, length, strain, dia, h_max):
    """Every pair i < j and its closest image, over the images ``m_x L e_x + m_y (γ L e_x + L e_y)
    + Σ m_k L e_k`` with ``m ∈ {−3..3}^d`` and ``m_x`` offset by ``−round(m_y γ)`` (raw strain,
    positions as given); asserts the second-closest image is out of range."""
    n, d = pos.shape
    vecs = []
    for m in itertools.product(range(-3, 4), repeat=d):
        v = np.array(m, dtype=float) * length
        # a large strain shifts the y-images far along x: centre the x-range on that shift
        v[0] += (m[1] * strain - round(m[1] * strain)) * length
        vecs.append(v)
    vecs = np.array(vecs)
    out = {}
    for i in range(n):
        for j in range(i + 1, n):
            sep = pos[i] - pos[j] - vecs
            dist = np.sqrt((sep**2).sum(axis=1))
            order = np.argsort(dist)
            sigma = 0.5 * (dia[i] + dia[j])
            if dist[order[0]] < sigma * (1 + h_max):
                assert dist[order[1]] >= sigma * (1 + h_max)
                out[(i, j)] = (dist[order[0]], sigma, sep[order[0]])
    return out


def _brute_observables(pos, length, strain, dia, alpha, h_max):
    n, d = pos.shape
    pairs = _brute_pairs(pos, length, strain, dia, h_max)
    contacts = {k: v for k, v in pairs.items() if v[0] < v[1]}
    alive = set(range(n))
    while True:  # rattlers, one particle at a time
        count = dict.fromkeys(alive, 0)
        for i, j in contacts:
            if i in alive and j in alive:
                count[i] += 1
                count[j] += 1
        low = [p for p in alive if count[p] < d + 1]
        if not low:
            break
        alive.discard(low[0])
    forces = {}
    for (i, j), (r, sigma, _) in contacts.items():
        if i in alive and j in alive:
            forces[(i, j)] = alpha * (1.0 - r / sigma) ** (alpha - 1) / sigma
    bucklers, localized = [], set()
    for p in sorted(alive):
        mine = [(f, k) for k, f in forces.items() if p in k]
        if len(mine) == d + 1:
            bucklers.append(p)
            localized.add(min(mine)[1])
    gaps = {
        k: v[0] / v[1] - 1.0
        for k, v in pairs.items()
        if v[0] >= v[1] and k[0] in alive and k[1] in alive
    }
    return alive, forces, bucklers, localized, gaps


def _check_against_brute(pos, length, strain, dia=None, alpha=2.0, h_max=0.4):
    n = pos.shape[0]
    dia_arr = np.ones(n) if dia is None else np.asarray(dia)
    alive, forces, buck, localized, gaps = _brute_observables(
        pos, length, strain, dia_arr, alpha, h_max
    )
    obs = packing_observables(pos, length, strain, dia, alpha, h_max)
    assert set(np.flatnonzero(obs.backbone)) == alive
    got = {
        (int(i), int(j)): f for i, j, f in zip(obs.contact_i, obs.contact_j, obs.force, strict=True)
    }
    assert got.keys() == forces.keys()
    for k, f in forces.items():
        assert got[k] == pytest.approx(f, rel=1e-9, abs=1e-15)
    assert obs.mean_force == pytest.approx(np.mean(list(forces.values())), rel=1e-12)
    assert sorted(obs.buckler_ids.tolist()) == buck
    got_loc = {
        (int(i), int(j))
        for i, j in zip(obs.contact_i[obs.localized], obs.contact_j[obs.localized], strict=True)
    }
    assert got_loc == localized
    got_gaps = {(int(i), int(j)): h for i, j, h in zip(obs.gap_i, obs.gap_j, obs.gap, strict=True)}
    assert got_gaps.keys() == gaps.keys()
    for k, h in gaps.items():
        assert got_gaps[k] == pytest.approx(h, rel=1e-9, abs=1e-13)
    return obs


@pytest.fixture(scope="module")
def jammed64():
    res = jam(64, 3, seed=3, p_target=1e-6)
    assert res.ok
    return res.packing


def test_jammed_packing_against_brute_force(jammed64):
    p = jammed64
    obs = _check_against_brute(p.positions, p.box.length, p.strain)
    # the backbone of a jammed packing is isostatic and holds bucklers
    assert obs.isostatic_excess == 0
    assert obs.buckler_ids.size > 0 and obs.localized.sum() > 0
    # and the library's own rattler removal (spheres) agrees
    rr = remove_rattlers(p)
    assert np.array_equal(rr.mask, obs.backbone)
    assert rr.n_contacts_nr == obs.n_contacts


def test_pressure_from_forces(jammed64):
    """``p = (1/(d L^d)) Σ f_ij r_ij`` over all contacts equals the engine's pressure."""
    p = jammed64
    pl = pairs_within(p.positions, p.box.length, p.strain, h_max=0.0)
    f = pair_force(pl.r, pl.sigma)
    assert np.sum(f * pl.r) / (3 * p.box.volume) == pytest.approx(pressure(p), rel=1e-10)


@pytest.mark.parametrize("strain", [0.3, -0.45, 1.7, 12.38])
def test_sheared_minimum_against_brute_force(jammed64, strain):
    """A minimum at strain γ (affine shear of a compressed packing, then relaxed): pairs across
    the Lees–Edwards boundary, with the raw strain in the brute force."""
    p = jammed64
    dense = Packing(p.positions * 0.98, type(p.box)(p.box.length * 0.98, 3, 0.0))
    sheared = relax(affine_shear(dense, strain), ftol=1e-10).packing
    assert sheared.strain == pytest.approx(strain)
    obs = _check_against_brute(sheared.positions, sheared.box.length, sheared.strain)
    assert obs.n_contacts > 0


def test_unwrapped_positions_are_handled(jammed64):
    p = jammed64
    rng = np.random.default_rng(5)
    shift = rng.integers(-3, 4, size=p.positions.shape) * p.box.length
    a = packing_observables(p.positions, p.box.length, 0.0)
    b = packing_observables(p.positions + shift, p.box.length, 0.0)
    assert np.array_equal(a.contact_i, b.contact_i) and np.array_equal(a.contact_j, b.contact_j)
    assert np.allclose(a.force, b.force, rtol=1e-8)


@pytest.mark.parametrize(("dim", "alpha", "strain"), [(2, 2.5, 0.21), (3, 2.0, -0.37)])
def test_bidisperse_overlapping_against_brute_force(dim, alpha, strain):
    """Random positions of a 50:50 mixture with D = 1 and 1.4 at φ ≈ 0.85 (not a minimum: the
    counts and formulas do not need one), Hertzian or harmonic."""
    n = 60 if dim == 2 else 70
    rng = np.random.default_rng(11)
    dia = np.where(np.arange(n) % 2 == 0, 1.0, 1.4)
    vol = sum(math.pi ** (dim / 2) * (D / 2) ** dim / math.gamma(dim / 2 + 1) for D in dia)
    length = (vol / 0.85) ** (1 / dim)
    pos = rng.random((n, dim)) * length
    obs = _check_against_brute(pos, length, strain, dia, alpha, h_max=0.3)
    assert obs.n_contacts > 0 and obs.gap.size > 0


def test_forces_match_the_engine_harmonic(jammed64):
    """Monodisperse harmonic: ``f = 2 (1 − r)``, the engine's contact list gives the overlaps."""
    from jamlab.spheres.potential import contacts

    p = jammed64
    ci, cj, cd = contacts(p)
    obs = packing_observables(p.positions, p.box.length, 0.0)
    keep = obs.backbone[ci] & obs.backbone[cj]
    expect = 2.0 * (1.0 - np.linalg.norm(cd[keep], axis=1))
    assert np.array_equal(ci[keep], obs.contact_i) and np.array_equal(cj[keep], obs.contact_j)
    assert np.allclose(obs.force, expect, rtol=1e-9)


def test_backbone_mask_cascade():
    """A chain hanging off a rigid cluster is removed link by link (d = 2: < 3 contacts)."""
    # a K4 in 2D (every node 3 contacts) plus a tail 3-4-5 attached to node 0
    i = np.array([0, 0, 0, 1, 1, 2, 0, 4])
    j = np.array([1, 2, 3, 2, 3, 3, 4, 5])
    keep = backbone_mask(6, i, j, 2)
    assert keep.tolist() == [True, True, True, True, False, False]


def test_pairs_refuse_too_small_a_box():
    with pytest.raises(ValueError, match="L/2"):
        pairs_within(np.zeros((2, 3)) + [[0, 0, 0], [1, 1, 1]], 2.5, h_max=0.5)


def test_random_packing_gaps_cover_every_pair():
    """With a large h_max every pair of an overlapping random state within the cut-off appears
    once: the count equals the brute-force count."""
    p = random_packing(40, 3, 0.3, seed=2)
    pl = pairs_within(p.positions, p.box.length, 0.77, h_max=0.8)
    brute = _brute_pairs(p.positions, p.box.length, 0.77, np.ones(40), 0.8)
    assert {(int(a), int(b)) for a, b in zip(pl.i, pl.j, strict=True)} == brute.keys()


# --- exponent fitter ---------------------------------------------------------------------------


def _synthetic(rng, m, a, x_cut, bulk=0.5):
    """``m`` samples: density ``∝ x^a`` on ``[x_cut, 1]``, depleted as ``x^a (x/x_cut)²`` below
    ``x_cut`` (a finite-size cut-off that removes mass), and a fraction ``bulk`` from
    ``1 + Exp(1)``. Inverse-CDF sampling, written out here."""
    lower = x_cut ** (1 + a) / (3 + a)
    middle = (1 - x_cut ** (1 + a)) / (1 + a)
    u = rng.random(m) * (lower + middle)
    x = np.empty(m)
    below = u < lower
    x[below] = x_cut * ((3 + a) * u[below] / x_cut ** (1 + a)) ** (1 / (3 + a))
    x[~below] = (x_cut ** (1 + a) + (1 + a) * (u[~below] - lower)) ** (1 / (1 + a))
    b = rng.random(m) < bulk
    x[b] = 1 + rng.exponential(1.0, b.sum())
    return x


def test_synthetic_sampler_has_the_stated_cdf():
    rng = np.random.default_rng(0)
    x = _synthetic(rng, 200_000, 0.42, 1e-2, bulk=0.0)
    # above the cut-off F(x) − F(x_c) ∝ x^1.42 − x_c^1.42
    f = empirical_cdf([x], [0.1, 0.5])
    fc = empirical_cdf([x], [1e-2])[0]
    ratio = (f[1] - fc) / (f[0] - fc)
    assert ratio == pytest.approx((0.5**1.42 - 1e-2**1.42) / (0.1**1.42 - 1e-2**1.42), rel=0.02)


@pytest.mark.parametrize(
    ("a", "method", "trials"),
    [(0.42311, "cdf", 80), (-0.41269, "cdf", 80), (0.17, "cdf", 80)],
)
def test_fitter_covers_the_true_exponent(a, method, trials):
    """20 packings of 3000 samples, half in the power law; the cut-off leaves about one sample per
    packing below it (``x_c = (1/1500)^(1/(1+a))``, the ``N^(−1/(1+a))`` law); the window starts
    where the packings hold 5 samples each and ends at 0.3. The 95 % interval must contain the
    true exponent in at least 90 % of the trials."""
    m, packings = 3000, 20
    x_cut = float(finite_size_cutoff(m / 2, a))
    assert x_cut == pytest.approx((1 / 1500) ** (1 / (1 + a)))
    hits, values = 0, []
    for trial in range(trials):
        rng = np.random.default_rng([19, trial])
        samples = [_synthetic(rng, m, a, x_cut) for _ in range(packings)]
        window = choose_window(samples, WindowRule(per_packing=5, upper=0.3))
        assert window[0] > x_cut
        fit = fit_exponent(samples, window, method=method, n_boot=100, seed=trial)
        values.append(fit.value)
        hits += fit.ci95[0] <= a <= fit.ci95[1]
    assert hits >= 0.9 * trials, (hits, np.mean(values), np.std(values))
    assert abs(np.mean(values) - a) < 0.5 * np.std(values)


def test_fitter_on_exact_power_law_cdf_is_exact():
    """Samples placed at the quantiles of ``F(x) = x^(1+a)`` on [0, 1]: the CDF fit returns ``a``
    to the discretisation error."""
    a = 0.3
    q = (np.arange(1, 200_001) - 0.5) / 200_000
    x = q ** (1 / (1 + a))
    for method in ("cdf", "plain", "mle"):
        fit = fit_exponent([x[k::4] for k in range(4)], (1e-2, 0.5), method=method, n_boot=20)
        assert fit.value == pytest.approx(a, abs=2e-3)
        assert fit.ci95[0] <= fit.value <= fit.ci95[1]


def test_a_fit_at_an_end_of_its_search_says_so():
    """Samples whose window CDF no ``1 + a`` in the search range can follow (quantiles of
    ``x^(1+a)`` with ``1 + a = −2``, and of ``1 + a = 9``) give the bound and ``at_bound``; the
    exact power law above does not, and the flag survives ``negated`` (γ from the gap fit)."""
    from jamlab.analysis.exponent_fit import CDF_SEARCH

    q = (np.arange(1, 40_001) - 0.5) / 40_000
    for exponent, bound in ((-2.0, CDF_SEARCH[0]), (9.0, CDF_SEARCH[1])):
        x = 1e-2 * (1 - q * (1 - 100.0**exponent)) ** (1 / exponent)  # on [1e-2, 1]
        fit = fit_exponent([x[k::4] for k in range(4)], (1e-2, 1.0), n_boot=20)
        assert fit.value == pytest.approx(bound - 1, abs=1e-4)
        assert fit.at_bound and fit.negated().at_bound
    x = q ** (1 / 1.3)
    fit = fit_exponent([x[k::4] for k in range(4)], (1e-2, 0.5), n_boot=20)
    assert not fit.at_bound and not fit.negated().at_bound


def test_local_exponents_track_a_changing_slope():
    """A density ``x^0`` below 0.1 and ``x^1`` above: the local exponent is ~0 on low windows
    and ~1 on high ones (the plain CDF fit, which sees the mass below its window, lags the
    change; the window fits do not)."""
    rng = np.random.default_rng(4)
    # inverse CDF of p(x) ∝ 1 (x < c), x/c (c ≤ x ≤ 1), c = 0.1
    c = 0.1
    low_mass, high_mass = c, (1 - c * c) / (2 * c)
    samples = []
    for _ in range(10):
        u = rng.random(50_000) * (low_mass + high_mass)
        x = np.where(u < low_mass, u, np.sqrt(c * c + 2 * c * np.clip(u - low_mass, 0, None)))
        samples.append(x)
    loc = local_exponents(samples, 1e-3, 1.0, 1.0, 1.0, method="cdf", n_boot=20)
    assert loc.lo.tolist() == pytest.approx([1e-3, 1e-2, 1e-1])
    assert loc.value[0] == pytest.approx(0.0, abs=0.15)
    assert loc.value[1] == pytest.approx(0.0, abs=0.05)
    assert loc.value[-1] == pytest.approx(1.0, abs=0.05)
    assert np.all(loc.ci_low < loc.value) and np.all(loc.value < loc.ci_high)
    loc_cdf = local_exponents(samples, 1e-3, 1.0, 1.0, 1.0, method="plain", n_boot=20)
    assert loc_cdf.value[1] == pytest.approx(0.0, abs=0.05)
    assert 0.5 < loc_cdf.value[-1] < 0.95


def test_window_rule_and_errors():
    s = [np.arange(1, 101, dtype=float) / 100 for _ in range(3)]
    assert choose_window(s, WindowRule(per_packing=10, upper=0.5)) == (0.1, 0.5)
    with pytest.raises(ValueError, match="empty window"):
        choose_window(s, WindowRule(per_packing=60, upper=0.5))
    with pytest.raises(ValueError, match="window"):
        fit_exponent(s, (0.5, 0.1))
    with pytest.raises(ValueError, match="method"):
        fit_exponent(s, (0.1, 0.5), method="ols")
    with pytest.raises(ValueError, match="fewer than 2"):
        fit_exponent(s, (2.0, 3.0))


def test_finite_size_cutoff_formula():
    assert finite_size_cutoff(1000, 0.42311) == pytest.approx(1000 ** (-1 / 1.42311))
    assert finite_size_cutoff([10, 100], -0.41269, 2.0)[1] == pytest.approx(
        2 * 100 ** (-1 / 0.58731)
    )
