"""Jammed / UNSAT packings and the coordination curve, checked against independent computations.

Contacts are recounted by brute force over all pairs and images (``spheres_brute``), rattlers are
removed with a loop written here, and the pressure is compared with ``−ΔE/ΔV`` between minima.
"""

from __future__ import annotations

import numpy as np
import pytest
from spheres_brute import brute_jammed_state, pair_terms

import jamlab.spheres as sp
from jamlab.spheres.box import box_length_for
from jamlab.spheres.fire import minimize
from jamlab.spheres.jam_search import quench_seed
from jamlab.spheres.packing import (
    JammingError,
    compress_to,
    coordination_curve,
    fit_power_law,
    fit_power_law_corrected,
    jam,
    prepare,
    rescale,
)

P_TARGET = 1e-7


def independent_backbone(packing: sp.Packing) -> tuple[int, int]:
    """``(N', N_c')`` from brute-force contacts and a plain rattler loop (fewer than d+1)."""
    pos = packing.wrapped().positions
    i, j, _ = pair_terms(pos, packing.box.length, packing.strain)
    keep = set(range(packing.n))
    edges = list(zip(i.tolist(), j.tolist(), strict=True))
    changed = True
    while changed:
        changed = False
        count = dict.fromkeys(keep, 0)
        for a, b in edges:
            if a in keep and b in keep:
                count[a] += 1
                count[b] += 1
        for k, c in count.items():
            if c < packing.dim + 1:
                keep.discard(k)
                changed = True
    n_c = sum(1 for a, b in edges if a in keep and b in keep)
    return len(keep), n_c


@pytest.fixture(scope="module")
def jammed256() -> list:
    return [jam(256, 3, seed) for seed in (1, 2)]


def test_jammed_packing_is_isostatic_by_independent_count(jammed256) -> None:
    for res in jammed256:
        assert res.ok, res.reason
        n_kept, n_c = independent_backbone(res.packing)
        assert n_c == 3 * (n_kept - 1) + 1
        assert (n_kept, n_c) == (256 - res.state.n_rattlers, res.state.n_contacts_nr)
        # the stopping rule: isostatic and p within a factor 2 of the target
        assert P_TARGET / 2 <= sp.pressure(res.packing) <= 2 * P_TARGET
        # the contact count was decided on a minimum polished to ftol / 10
        assert res.steps[-1].role == "polish" and sp.max_force(res.packing) < 1e-13


def test_phi_j_range_3d(jammed256) -> None:
    # N=256: sample-to-sample spread of phi_J is ~0.003 (docs/packings.md), well inside the range
    for res in jammed256:
        assert 0.63 <= res.phi_j <= 0.65
        assert res.phi_j == pytest.approx(sp.packing_fraction(256, 3, res.packing.box.length))


def test_pressure_is_minus_energy_volume_derivative(jammed256) -> None:
    # between two nearby minima dE/dV = -p to first order (the relaxation term vanishes at a
    # minimum), so -ΔE/ΔV must equal the mean virial pressure to O(Δφ²)
    base = compress_to(jammed256[0].packing, jammed256[0].phi_j + 1e-3).packing
    a = compress_to(base, base.phi * (1 + 2e-5)).packing
    b = compress_to(a, a.phi * (1 + 2e-5)).packing
    dv = b.box.volume - a.box.volume
    de = sp.energy(b) - sp.energy(a)
    assert -de / dv == pytest.approx(0.5 * (sp.pressure(a) + sp.pressure(b)), rel=1e-3)


@pytest.mark.parametrize(
    ("n", "seeds"),
    [(16, range(12)), (32, (1, 2, 3, 16, 38))],  # includes seeds that once failed
)
def test_tiny_n_jams_isostatic(n: int, seeds) -> None:
    # small N jams over a wide phi range (unjammed after the quench at phi_init, hyperstatic or
    # saddle states): every seed must still end isostatic by the independent count
    for seed in seeds:
        res = jam(n, 3, seed)
        assert res.ok and res.converged, (seed, res.reason)
        n_kept, n_c = independent_backbone(res.packing)
        assert n_c == 3 * (n_kept - 1) + 1, seed
        assert P_TARGET / 2 <= sp.pressure(res.packing) <= 2 * P_TARGET, seed
        assert sp.max_force(res.packing) < 1e-13
        assert res.phi_j == pytest.approx(sp.packing_fraction(n, 3, res.packing.box.length))


def test_jam_is_reproducible_with_restarts() -> None:
    first = [jam(16, 3, seed) for seed in range(12)]
    assert any(r.n_restarts > 0 for r in first)  # the restart path is exercised
    again = next(r for r in first if r.n_restarts > 0)
    seed = int(again.params["seed"])
    twin = jam(16, 3, seed)
    assert twin.n_restarts == again.n_restarts
    np.testing.assert_array_equal(twin.packing.positions, again.packing.positions)


def test_schedule_replays_to_the_same_packing() -> None:
    # the recorded steps (start, phi, ftol, max_iter) are the whole schedule: replaying them with
    # the bare minimiser and a hand-made affine rescale gives the same pressures and positions
    res = jam(128, 3, 8, p_target=1e-4)  # a seed with a restart and re-compressions
    assert res.ok and res.n_restarts >= 1
    assert {"recompress", "polish"} <= {s.role for s in res.steps}
    minima: list[sp.Packing] = []
    for k, st in enumerate(res.steps):
        if st.start == -1:
            start = sp.random_packing(128, 3, st.phi, quench_seed(8, st.attempt))
        else:
            assert 0 <= st.start < k
            src = minima[st.start]
            length = box_length_for(128, 3, st.phi)
            start = sp.Packing(src.positions * (length / src.box.length), sp.Box(length, 3))
        r = minimize(start, ftol=st.ftol, max_iter=st.max_iter)
        assert r.converged == st.converged and sp.pressure(r.packing) == st.pressure, k
        minima.append(r.packing)
    np.testing.assert_array_equal(minima[-1].positions, res.packing.positions)
    assert res.n_minimizations == len(res.steps) == len(res.history)


def test_recompression_finds_an_isostatic_state_in_the_window() -> None:
    # N=128 at p_target=1e-4 (p N^2 = 1.6, like N=4000 at 1e-7): excess contacts in the window
    # are common, so the search goes below it and re-compresses the isostatic minimum found there
    p_t = 1e-4
    res = jam(128, 3, 15, p_target=p_t)
    assert res.ok and res.n_restarts == 0, res.reason
    n_kept, n_c = independent_backbone(res.packing)
    assert n_c == 3 * (n_kept - 1) + 1
    assert p_t / 2 <= sp.pressure(res.packing) <= 2 * p_t
    roles = [s.role for s in res.steps]
    first = roles.index("recompress")
    base = res.steps[res.steps[first].start]  # isostatic, below the window
    assert base.excess == 0 and base.jammed and base.pressure < p_t / 2
    # every re-compression starts from an isostatic minimum below the window
    for s in res.steps[first:]:
        if s.role == "recompress":
            st = res.steps[s.start]
            assert st.excess == 0 and st.pressure < p_t / 2


def test_jam_rejects_bad_protocol_options() -> None:
    with pytest.raises(ValueError, match="sizes"):
        jam(32, 3, 1, sizes="tridisperse")
    with pytest.raises(ValueError, match="alpha"):
        jam(32, 3, 1, alpha=1.0)
    with pytest.raises(ValueError, match="confirm_ftol_factor"):
        jam(32, 3, 1, confirm_ftol_factor=0.0)


def test_rescale_is_affine() -> None:
    pk = sp.random_packing(64, 3, 0.3, seed=3)
    out = rescale(pk, 0.45)
    assert out.phi == pytest.approx(0.45, rel=1e-14)
    s = out.box.length / pk.box.length
    assert s == pytest.approx((0.3 / 0.45) ** (1 / 3), rel=1e-14)
    np.testing.assert_allclose(out.positions, pk.positions * s, rtol=1e-15)


def test_prepare_unsat() -> None:
    res = prepare(256, 3, 0.8, seed=4)
    assert res.ok and res.converged
    assert res.packing.phi == pytest.approx(0.8)
    n_kept, n_c = independent_backbone(res.packing)
    assert n_c > 3 * (n_kept - 1) + 1  # hyperstatic well above jamming
    assert res.state.pressure > 0


def test_prepare_refuses_a_floppy_backbone() -> None:
    """N = 16, 2D, φ = 0.8, seed 0: 14 particles survive rattler removal, but with 24 contacts
    (27 needed) at p ≈ 1.8e-12, below the force resolution: unjammed, reported ok before. The
    verdict is recounted by brute force (every pair and image, rattlers removed here)."""
    floppy = prepare(16, 2, 0.8, seed=0)
    b = brute_jammed_state(floppy.packing, 1e-12)
    assert floppy.converged and b["n_kept"] == 14 and b["n_c"] == 24
    assert b["n_c"] < 2 * (b["n_kept"] - 1) + 1 and b["p"] < b["floor"] and not b["jammed"]
    assert not floppy.ok and "hypostatic backbone (3 contacts short" in floppy.reason
    jammed = prepare(16, 2, 0.9, seed=0)
    assert brute_jammed_state(jammed.packing, 1e-12)["jammed"]
    assert jammed.ok and jammed.reason == ""


def test_failure_is_reported_not_hidden() -> None:
    res = jam(128, 3, 5, max_minimizations=2)
    assert not res.ok and res.reason
    with pytest.raises(JammingError):
        jam(128, 3, 5, max_minimizations=2, strict=True)
    below = prepare(128, 3, 0.4, seed=1)
    assert not below.ok and "below jamming" in below.reason


def test_fit_power_law_recovers_known_exponent() -> None:
    x = np.geomspace(1e-6, 0.3, 30)
    a, sa, c = fit_power_law(x, 3.0 * x**0.5, 1e-4, 1e-1)
    assert a == pytest.approx(0.5, abs=1e-12) and c == pytest.approx(3.0, rel=1e-10)
    with pytest.raises(ValueError):
        fit_power_law(x, -x)


def test_corrected_fit_recovers_exponent_and_correction() -> None:
    # y = A x^b (1 + c x): the plain fit over [1e-4, 1e-1] is biased (b = 1.024 here), the fit
    # with the correction term is not
    x = np.geomspace(1e-6, 0.3, 30)
    y = 2.0 * x * (1.0 + 3.0 * x)
    assert fit_power_law(x, y)[0] == pytest.approx(1.0245, abs=1e-3)
    b, sb, a, c, sc = fit_power_law_corrected(x, y)
    assert b == pytest.approx(1.0, abs=1e-8) and c == pytest.approx(3.0, rel=1e-6)
    assert a == pytest.approx(2.0, rel=1e-8) and sb < 1e-8
    b, _, _, c, _ = fit_power_law_corrected(x, 3.0 * x**0.5 * (1.0 - 0.5 * x))
    assert b == pytest.approx(0.5, abs=1e-10) and c == pytest.approx(-0.5, rel=1e-8)
    with pytest.raises(ValueError, match="at least 4 points"):
        fit_power_law_corrected(x[:5], y[:5])


@pytest.mark.slow
def test_coordination_exponents_small_n(jammed256) -> None:
    # N=256, two seeds, averaged. At this N and with a fit range reaching 1e-1 the corrections to
    # scaling push a above 1/2 (measured 0.55-0.58, see docs/packings.md): the window for a is
    # widened to [0.45, 0.62] for that stated reason. Likewise p = k Δφ (1 + O(Δφ)) bends up at
    # Δφ ~ 0.1, giving b = 1.05-1.06 at N=256 (4 seeds): b's window is [0.95, 1.08]. At N=1000
    # (10 seeds, scripts/coordination_exponents.py) a = 0.536 falls inside the window and
    # b = 1.054 stays just outside (docs/packings.md); those windows are not claimed here.
    a_vals, b_vals = [], []
    for res in jammed256:
        curve = coordination_curve(res.packing, res.phi_j, steps=24)
        assert curve.converged.all()
        assert np.all(np.diff(curve.pressure) > 0)
        a_vals.append(fit_power_law(curve.dphi, curve.z_nr - curve.z_iso)[0])
        b_vals.append(fit_power_law(curve.dphi, curve.pressure)[0])
    assert 0.45 <= np.mean(a_vals) <= 0.62
    assert 0.95 <= np.mean(b_vals) <= 1.08


@pytest.mark.slow
def test_jammed_n1000_ensemble() -> None:
    # the check at N=1000 on a CI budget (about 10 s CPU per seed): every packing
    # isostatic by the independent count, p within a factor 2 of the target, phi_J in
    # [0.63, 0.65]. Seeds 2 and 3 are the ones the earlier protocol left at p = 2.5e-8; seed 1
    # (one restart, ~35 s) and the other six are in scripts/coordination_exponents.py runs.
    for seed in (2, 3, 4, 5):
        res = jam(1000, 3, seed)
        assert res.ok, (seed, res.reason)
        n_kept, n_c = independent_backbone(res.packing)
        assert n_c == 3 * (n_kept - 1) + 1, seed
        assert P_TARGET / 2 <= sp.pressure(res.packing) <= 2 * P_TARGET, seed
        assert 0.63 <= res.phi_j <= 0.65, (seed, res.phi_j)


@pytest.mark.parametrize("bad", [{"max_minimizations": 0}, {"max_minimizations": -3},
                                 {"max_iter": 0}, {"max_minimizations": 2.5}])
def test_jam_refuses_a_budget_that_cannot_run(bad):
    """A budget of no minimisation used to run all its attempts and report a failed packing;
    it is a bad argument."""
    name = next(iter(bad))
    with pytest.raises(ValueError, match=f"{name} must be an integer >= 1"):
        jam(16, 2, seed=0, p_target=1e-3, **bad)
