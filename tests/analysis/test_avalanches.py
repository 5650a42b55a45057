"""Avalanche classification on synthetic traces with known jumps, and on the LAMMPS reference."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jamlab.analysis import (
    avalanche_sizes,
    branch_residual,
    classify_steps,
    coarsen_steps,
    consecutive_events,
    exclusions,
    jammed_steps,
    jumps_from_trace,
    noise_floor,
)
from reference_data import N500

REFERENCE = N500 / "trace.csv"


def _synthetic_trace(rng, noise):
    """Piecewise-quadratic E(γ) with Σ = dE/dγ exact on each branch; known jumps of size S.

    Branch b starting at strain γ_b: E = E_b + Σ_b d + ½ k_b d², Σ = Σ_b + k_b d, d = γ − γ_b.
    A jump at grid point n lowers E by S and resets Σ; a change of k alone is continuous.
    Steps 1600..1700 lie on a branch with negative modulus (ΔE_n < 0 but no avalanche).
    """
    dgamma, steps = 1e-5, 3000
    strain = np.arange(steps + 1) * dgamma
    jumps = {500: 2e-3, 1200: 4e-5, 2100: 7e-2}
    moduli = {1599: -40.0, 1700: 100.0}
    energy = np.empty(steps + 1)
    stress = np.empty(steps + 1)
    e_b, s_b, k, g_b = 5.0, -1.0, 100.0, 0.0
    for n in range(steps + 1):
        if n in jumps or n in moduli:
            d = strain[n] - g_b
            e_b, s_b, g_b = e_b + s_b * d + 0.5 * k * d**2, s_b + k * d, strain[n]
            if n in jumps:
                e_b -= jumps[n]
                s_b = -1.5 + rng.uniform(-0.1, 0.1)
            k = moduli.get(n, k)
        d = strain[n] - g_b
        energy[n] = e_b + s_b * d + 0.5 * k * d**2
        stress[n] = s_b + k * d
    energy = energy + rng.normal(0.0, noise, energy.shape)
    return strain, energy, stress, jumps


def test_jumps_from_trace_definition():
    strain = np.array([0.0, 0.1, 0.3])
    energy = np.array([1.0, 2.0, 2.5])
    stress = np.array([3.0, 4.0, 1.0])
    de, ds, dg = jumps_from_trace(strain, energy, stress)
    np.testing.assert_allclose(dg, [0.1, 0.2])
    np.testing.assert_allclose(de, [2.0 - 1.0 - 0.1 * 3.0, 2.5 - 2.0 - 0.2 * 4.0])
    np.testing.assert_allclose(ds, [1.0, -3.0])


def test_noise_floor_and_threshold_rule(rng):
    noise = 1e-12
    strain, energy, stress, jumps = _synthetic_trace(rng, noise)
    de, ds, dg = jumps_from_trace(strain, energy, stress)
    nf = noise_floor(de, ds, dg)
    # r_n contains ε_{n+1} − ε_n: Gaussian with std √2·noise
    assert nf.sigma == pytest.approx(np.sqrt(2) * noise, rel=0.1)
    assert nf.modulus == pytest.approx(100.0, rel=1e-6)
    negative_branch = (de < 0) & (np.abs(branch_residual(de, ds, dg)) < 1e-9)
    assert negative_branch.sum() >= 90  # the negative-modulus stretch has ΔE_n < 0 ...
    mask = classify_steps(de, threshold=nf.threshold(10.0), stress_jump=ds, strain_step=dg)
    assert sorted(np.flatnonzero(mask)) == [n - 1 for n in sorted(jumps)]  # ... but no avalanche
    naive = classify_steps(de, threshold=nf.threshold(10.0))
    assert naive.sum() >= len(jumps) + 90  # −ΔE_n alone would count the continuous branch
    sizes = avalanche_sizes(de, threshold=nf.threshold(10.0), stress_jump=ds, strain_step=dg)
    # S = −ΔE_n = jump − the elastic energy ½ k δγ² the step gains on the old branch (k = 100)
    expected = np.sort(list(jumps.values())) - 0.5 * 100.0 * 1e-5**2
    np.testing.assert_allclose(np.sort(sizes), expected, rtol=0, atol=20 * noise)


def test_sizes_from_plastic_flags():
    de = np.array([1e-9, -2e-3, -6e-9, 3e-9, -0.1])
    plastic = np.array([False, True, False, False, True])
    np.testing.assert_array_equal(avalanche_sizes(de, plastic), [2e-3, 0.1])
    np.testing.assert_array_equal(avalanche_sizes(de, plastic, threshold=0.01), [0.1])
    with pytest.raises(ValueError, match="plastic flags"):
        avalanche_sizes(de)
    with pytest.raises(ValueError, match="both"):
        avalanche_sizes(de, threshold=1.0, stress_jump=de)


def test_noise_floor_global_modulus_is_upper_bound(rng):
    strain, energy, stress, _ = _synthetic_trace(rng, 1e-12)
    de, ds, dg = jumps_from_trace(strain, energy, stress)
    local = noise_floor(de, ds, dg)
    glob = noise_floor(de, ds, dg, local=False)
    assert glob.sigma >= local.sigma


def test_reference_trace_continuous_branch_not_counted():
    data = np.genfromtxt(REFERENCE, delimiter=",", names=True)
    de, ds, dg = jumps_from_trace(data["strain"], data["energy"], data["shear_stress"])
    nf = noise_floor(de, ds, dg)
    mask = classify_steps(de, threshold=nf.threshold(10.0), stress_jump=ds, strain_step=dg)
    big = de < -1e-4  # the reference README's avalanches are 1e-3–1e-1
    assert np.all(mask[big])
    small_negative = (de < 0) & (de > -1e-8)
    assert small_negative.sum() >= 10
    # nearly all small negative ΔE_n lie on continuous branches: trapezoid rule holds there
    assert mask[small_negative].sum() <= 0.1 * small_negative.sum()


def test_jammed_flags_exclude_steps_that_start_or_end_unjammed():
    # minima 0..6; minima 2 and 3 unjammed: steps 1 (1→2), 2 (2→3), 3 (3→4) are excluded
    de = np.array([-1e-3, -2e-3, -3e-3, -4e-3, 1e-9, -5e-3])
    plastic = np.array([True, True, True, True, False, True])
    jammed = np.array([True, True, False, False, True, True, True])
    np.testing.assert_array_equal(jammed_steps(jammed), [True, False, False, False, True, True])
    np.testing.assert_array_equal(avalanche_sizes(de, plastic, jammed=jammed), [1e-3, 5e-3])
    np.testing.assert_array_equal(avalanche_sizes(de, plastic), [1e-3, 2e-3, 3e-3, 4e-3, 5e-3])
    ex = exclusions(de, jammed, plastic)
    assert (ex.n_steps, ex.n_steps_excluded, ex.n_avalanches, ex.n_avalanches_excluded) == (
        6,
        3,
        5,
        3,
    )
    # per sample along the last axis
    both = avalanche_sizes(
        np.stack([de, de]),
        np.stack([plastic, plastic]),
        jammed=np.stack([jammed, np.ones(7, bool)]),
    )
    assert both.size == 2 + 5
    with pytest.raises(ValueError, match="one flag per minimum"):
        avalanche_sizes(de, plastic, jammed=jammed[:-1])
    with pytest.raises(ValueError, match="boolean"):
        jammed_steps(jammed.astype(float))


def test_noise_floor_ignores_unjammed_steps(rng):
    # elastic noise 1e-12 on jammed steps, 1e-6 garbage on the unjammed stretch
    m = 400
    dg = 1e-5
    ds = np.full(m, 2.0 * dg)
    de = 0.5 * dg * ds + rng.normal(0.0, 1e-12, m)
    jammed = np.ones(m + 1, dtype=bool)
    jammed[100:300] = False
    de[99:300] += rng.normal(0.0, 1e-6, 201)
    clean = noise_floor(de, ds, dg, jammed=jammed)
    assert clean.n_elastic == m - 201
    assert 0.7e-12 < clean.sigma < 1.3e-12
    assert noise_floor(de, ds, dg).sigma > 1e-9


def test_coarsen_steps_k1_is_the_trace(rng):
    strain, energy, stress, _ = _synthetic_trace(rng, 1e-12)
    de, ds, dg = jumps_from_trace(strain, energy, stress)
    c = coarsen_steps(de, ds, dg, 1, plastic=de < 0, jammed=np.ones(de.size + 1, bool))
    assert np.array_equal(c.energy_jump, de) and np.array_equal(c.stress_jump, ds)
    assert np.array_equal(c.strain_step, dg) and np.array_equal(c.plastic, de < 0)
    assert c.jammed.all() and c.dropped == 0 and c.k == 1


@pytest.mark.parametrize("k", [2, 3, 7, 64])
def test_coarsen_steps_is_the_subsampled_trace(rng, k):
    """Independent route: jumps_from_trace of the minima 0, k, 2k, … (absolute E and Σ)."""
    strain, energy, stress, jumps = _synthetic_trace(rng, 0.0)
    de, ds, dg = jumps_from_trace(strain, energy, stress)
    c = coarsen_steps(de, ds, dg, k)
    m = (de.size // k) * k
    de_k, ds_k, dg_k = jumps_from_trace(strain[: m + 1 : k], energy[: m + 1 : k],
                                        stress[: m + 1 : k])
    assert c.dropped == de.size - m and c.energy_jump.shape == de_k.shape
    np.testing.assert_allclose(c.energy_jump, de_k, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.stress_jump, ds_k, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.strain_step, dg_k, rtol=1e-12)
    # the jump of size S at grid point n: measured −ΔE grows with the strain left in the block
    # after it, by (Σ_old − Σ_new) per unit strain (the curvature ½ G (kδγ)² is 1e-6 of that)
    for n, size in jumps.items():
        if n > m:
            continue
        block = (n - 1) // k
        g_end = strain[(block + 1) * k]
        drop = stress[n - 1] + 100.0 * 1e-5 - stress[n]  # Σ_old at γ_n minus Σ_new
        expect = size + drop * (g_end - strain[n]) - 0.5 * 100.0 * (k * 1e-5) ** 2
        assert -c.energy_jump[block] == pytest.approx(expect, rel=1e-6)


def test_coarsen_steps_flags_and_samples_axis(rng):
    de = rng.normal(size=(3, 10))
    ds = rng.normal(size=(3, 10))
    plastic = np.zeros((3, 10), bool)
    plastic[0, 4] = plastic[2, 9] = True
    jammed = np.ones((3, 11), bool)
    jammed[1, 3] = False  # minimum 3 ends block 0 (minima 0..3) and starts block 1 (3..6)
    c = coarsen_steps(de, ds, 1e-5, 3, plastic=plastic, jammed=jammed)
    assert c.energy_jump.shape == (3, 3) and c.dropped == 1
    assert c.plastic.tolist() == [[False, True, False], [False] * 3, [False] * 3]  # step 9 dropped
    assert c.jammed.tolist() == [[True] * 3, [False, False, True], [True] * 3]
    # by hand, block 0 of sample 0: ΔE_0 + (ΔE_1 + δγ ΔΣ_0) + (ΔE_2 + δγ (ΔΣ_0 + ΔΣ_1))
    hand = de[0, 0] + de[0, 1] + de[0, 2] + 1e-5 * (2 * ds[0, 0] + ds[0, 1])
    assert c.energy_jump[0, 0] == pytest.approx(hand, rel=1e-14)
    for bad in (0, 11, 2.0):
        with pytest.raises(ValueError):
            coarsen_steps(de, ds, 1e-5, bad)
    with pytest.raises(ValueError):
        coarsen_steps(de, ds[:, :5], 1e-5, 2)
    with pytest.raises(ValueError):
        coarsen_steps(de, ds, 1e-5, 2, jammed=jammed[:, :10])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.booleans(), min_size=1, max_size=12), min_size=1, max_size=4))
def test_consecutive_events_equals_a_loop_over_neighbours(rows):
    width = min(len(r) for r in rows)
    events = np.array([r[:width] for r in rows], dtype=bool)
    expected = [(a, b) for a in range(events.shape[0]) for b in range(width - 1)
                if events[a, b] and events[a, b + 1]]
    i, k = consecutive_events(events)
    assert list(zip(i.tolist(), k.tolist(), strict=True)) == expected
    # a run of r consecutive events gives r - 1 overlapping pairs
    (j,) = consecutive_events(np.array([0, 1, 1, 1, 0, 1], dtype=bool))
    assert j.tolist() == [1, 2]


def test_consecutive_events_refuses_a_scalar():
    with pytest.raises(ValueError, match="steps axis"):
        consecutive_events(np.bool_(True))
