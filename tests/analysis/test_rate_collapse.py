"""Rate collapse ``n_N(≥ S) = N^(−b) F(S/N^a)`` against ensembles drawn from known laws, brute-force
counts and a brute-force grid of the objective."""

import math

import numpy as np
import pytest

from jamlab.analysis import cumulative_rates, rate_collapse
from jamlab.analysis.rate_collapse import RateCurves, collapse_rms

SIZES = (250, 500, 1000, 2000)
STRAIN = 0.01


def ensemble(a0: float, b0: float, packings: int = 30, seed: int = 1) -> dict:
    """Per packing a Poisson number of avalanches with mean ``60 (N/250)^(1 − b0)`` and sizes
    ``1e-8 (N/250)^a0 X``, ``X`` log-normal (σ of ln X 1.2: a curved F): the rate per particle at a
    fixed scaled size is ``∝ N^(−b0)`` exactly, the sizes ``∝ N^a0``."""
    rng = np.random.default_rng(seed)
    out = {}
    for n in SIZES:
        r = n / 250
        out[n] = [1e-8 * r**a0 * rng.lognormal(0.0, 1.2, rng.poisson(60 * r ** (1 - b0)))
                  for _ in range(packings)]
    return out


def test_objective_against_a_brute_force_pair_loop():
    rng = np.random.default_rng(4)
    g = {100: [rng.pareto(0.5, 300) + 1], 400: [rng.pareto(0.5, 500) + 1, rng.pareto(0.5, 400) + 1]}
    c = RateCurves(g, 0.1, 1.0, 5, 10)
    a, b = 0.2, 0.3
    sq = []
    for i in g:
        pi = np.concatenate(g[i])
        for j in g:
            if j == i:
                continue
            pj = np.concatenate(g[j])
            for s in c.points[i]:
                t = s * (j / i) ** a
                cj = sum(1 for v in pj if v >= t)
                if cj >= 5 and t >= 1.0:
                    ni = sum(1 for v in pi if v >= s) / (i * 0.1 * len(g[i]))
                    nj = cj / (j * 0.1 * len(g[j]))
                    sq.append((math.log10(i**b * ni) - math.log10(j**b * nj)) ** 2)
    assert collapse_rms(c, a, b) == pytest.approx(math.sqrt(np.mean(sq)), rel=1e-12)


def test_cumulative_rates_match_a_brute_force_count():
    rng = np.random.default_rng(3)
    groups = {10: [rng.uniform(1, 100, 7), rng.uniform(1, 100, 5)], 20: [rng.uniform(1, 100, 9)]}
    curves = cumulative_rates(groups, 0.5, 2.0, least=2, points_per_decade=4)
    for n, (s, rate) in curves.items():
        pooled = np.concatenate(groups[n])
        for si, ri in zip(s, rate, strict=True):
            count = sum(1 for v in pooled if v >= si)
            assert count >= 2
            assert ri == pytest.approx(count / (n * 0.5 * len(groups[n])), rel=1e-14)
        # grid: 2 · 10^(k/4), every point kept that has two avalanches or more
        grid = 2.0 * 10.0 ** (np.arange(0, 20) / 4)
        assert np.allclose(s, [g for g in grid if np.sum(pooled >= g) >= 2])


@pytest.mark.parametrize(("a0", "b0"), [(0.3, 0.4), (0.6, 0.2)])
def test_recovers_known_exponents(a0, b0):
    r = rate_collapse(ensemble(a0, b0), STRAIN, 1e-9, boot=40, seed=2)
    assert r.boot_used == 40
    assert abs(r.a - a0) < 3 * r.a_sigma + 0.02 and abs(r.a - a0) < 0.1
    assert abs(r.b - b0) < 3 * r.b_sigma + 0.02 and abs(r.b - b0) < 0.1
    assert r.rms < r.rms_none and r.rms <= r.rms_rate_only + 1e-12
    assert r.tails == tuple(sum(int(np.sum(p >= 1e-9)) for p in ensemble(a0, b0)[n])
                            for n in SIZES)


def test_no_size_dependence_gives_zero_within_errors():
    r = rate_collapse(ensemble(0.0, 0.0, seed=5), STRAIN, 1e-9, boot=40)
    assert abs(r.a) < 3 * r.a_sigma + 0.02
    assert abs(r.b) < 3 * r.b_sigma + 0.02


def test_optimum_not_beaten_by_a_fine_grid():
    g = ensemble(0.3, 0.4, seed=7)
    r = rate_collapse(g, STRAIN, 1e-9, boot=2)
    curves = RateCurves(g, STRAIN, 1e-9, 20, 20)
    grid = np.arange(-0.2, 0.2001, 0.01)
    brute = min(collapse_rms(curves, r.a + da, r.b + db) for da in grid for db in grid)
    assert r.rms <= brute + 1e-9
    assert r.rms == pytest.approx(collapse_rms(curves, r.a, r.b), rel=1e-12)


def test_a_common_unit_of_size_changes_nothing():
    g = ensemble(0.3, 0.4, seed=9)
    r1 = rate_collapse(g, STRAIN, 1e-9, boot=5)
    r7 = rate_collapse({n: [7 * p for p in v] for n, v in g.items()}, STRAIN, 7e-9, boot=5)
    assert r7.a == pytest.approx(r1.a, abs=1e-3) and r7.b == pytest.approx(r1.b, abs=1e-3)
    # the strain only scales every rate: b and a unchanged
    r2 = rate_collapse(g, 2 * STRAIN, 1e-9, boot=5)
    assert r2.a == pytest.approx(r1.a, abs=1e-3) and r2.b == pytest.approx(r1.b, abs=1e-3)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"strain": 0.0}, "strain"), ({"s_min": -1.0}, "s_min"), ({"least": 0}, "least"),
    ({"boot": 1}, "boot"), ({"s_min": 1.0}, "fewer than two sizes"),
])
def test_refusals(kwargs, message):
    args = {"strain": STRAIN, "s_min": 1e-9} | {k: v for k, v in kwargs.items()
                                                if k in ("strain", "s_min")}
    rest = {k: v for k, v in kwargs.items() if k not in ("strain", "s_min")}
    with pytest.raises(ValueError, match=message):
        rate_collapse(ensemble(0.3, 0.4, packings=5), args["strain"], args["s_min"], **rest)


def test_strains_per_packing_checked():
    g = ensemble(0.3, 0.4, packings=5)
    per = {n: [STRAIN] * 5 for n in SIZES}
    # one strain per packing, all equal: the one-number fit exactly; unequal strains: the
    # exposure is N times their sum
    r = rate_collapse(g, per, 1e-9, boot=3)
    one = rate_collapse(g, STRAIN, 1e-9, boot=3)
    assert (r.a, r.b, r.rms, r.a_sigma) == (one.a, one.b, one.rms, one.a_sigma)
    mixed = {**per, 2000: [STRAIN, 3 * STRAIN, STRAIN, STRAIN, 2 * STRAIN]}
    s, rate = cumulative_rates(g, mixed, 1e-9)[2000]
    pooled = np.concatenate(g[2000])
    assert rate == pytest.approx([np.sum(pooled >= x) / (2000 * 8 * STRAIN) for x in s], rel=1e-13)
    for bad, message in (({**per, 250: [STRAIN] * 4}, "one per packing"),
                         ({**per, 500: [STRAIN] * 4 + [0.0]}, "numbers > 0"),
                         ({n: per[n] for n in SIZES[1:]}, "no strains")):
        with pytest.raises(ValueError, match=message):
            rate_collapse(g, bad, 1e-9, boot=3)
    with pytest.raises(ValueError, match="no packings"):
        rate_collapse({**g, 250: []}, STRAIN, 1e-9, boot=3)


def test_one_size_refused():
    with pytest.raises(ValueError, match="two sizes"):
        rate_collapse({250: ensemble(0.3, 0.4, packings=3)[250]}, STRAIN, 1e-9)
