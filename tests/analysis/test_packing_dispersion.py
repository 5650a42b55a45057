"""packing_dispersion: packings drawn from one law are called alike; packings that differ in their
cut-off or in their rate are called over-dispersed. The draws come from tests/law_draws.py."""

import numpy as np
import pytest

from jamlab.analysis import packing_dispersion
from law_draws import cutoff_power_law  # noqa: E402  (tests/ is on sys.path via rootdir conftest)

X_MIN = 1e-9


def _packs(rng, n_packs, rate, tau, cutoffs):
    return [cutoff_power_law(rng, tau, float(s_c), int(rng.poisson(rate)), X_MIN)
            for s_c in np.broadcast_to(cutoffs, (n_packs,))]


def test_alike_packings_are_not_called_dispersed():
    ps_f, ps_c = [], []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        d = packing_dispersion(_packs(rng, 40, 30, 1.4, 1e-6), X_MIN, permutations=200, seed=seed)
        assert d.n_packings == 40
        ps_f.append(d.f_p)
        ps_c.append(d.count_p)
        assert 0.4 < d.f_ratio < 2.0 and 0.4 < d.count_ratio < 2.2
    # p-values of a true null are uniform: not piled up near 0
    assert np.mean(np.array(ps_f) < 0.05) <= 0.2 and np.mean(np.array(ps_c) < 0.05) <= 0.2


def test_packings_with_their_own_cutoff_are_dispersed():
    rng = np.random.default_rng(7)
    cutoffs = 10.0 ** rng.uniform(-8, -5, 40)  # the cut-off spread over three decades
    d = packing_dispersion(_packs(rng, 40, 30, 1.4, cutoffs), X_MIN, permutations=500)
    assert d.f_ratio > 2 and d.f_p < 0.01


def test_packings_with_their_own_rate_are_dispersed_in_counts():
    rng = np.random.default_rng(8)
    packs = [cutoff_power_law(rng, 1.4, 1e-6, int(rng.poisson(r)), X_MIN)
             for r in rng.choice([5, 60], 40)]
    d = packing_dispersion(packs, X_MIN, permutations=100)
    assert d.count_ratio > 5 and d.count_p < 1e-6


def test_the_ratio_by_hand():
    packs = [np.array([1.0, 2.0, 4.0]), np.array([8.0, 16.0]), np.array([0.5, 1.0, 1.0, 32.0])]
    d = packing_dispersion(packs, 1.0, permutations=10)
    logs = [np.log(p[p >= 1.0]) for p in packs]
    allv = np.concatenate(logs)
    means = [v.mean() for v in logs]
    between = sum(v.size * (m - allv.mean()) ** 2 for v, m in zip(logs, means, strict=True)) / 2
    within = sum(((v - m) ** 2).sum() for v, m in zip(logs, means, strict=True)) / (allv.size - 3)
    assert d.f_ratio == pytest.approx(between / within, rel=1e-12)
    assert d.sizes == 8 and d.packings == 3 and d.mean_log == pytest.approx(allv.mean())
    assert d.count_ratio == pytest.approx(np.var([3, 2, 3], ddof=1) / np.mean([3, 2, 3]))


def test_bad_input():
    with pytest.raises(ValueError, match="need two"):
        packing_dispersion([np.array([1.0, 2.0]), np.array([0.1])], 1.0)
    with pytest.raises(ValueError, match="x_min"):
        packing_dispersion([np.array([1.0, 2.0])] * 2, 0.0)
    with pytest.raises(ValueError, match="permutations"):
        packing_dispersion([np.array([1.0, 2.0])] * 2, 1.0, permutations=0)
