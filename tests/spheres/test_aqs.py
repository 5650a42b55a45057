"""AQS shear: against LAMMPS reference traces, the trapezoid rule, and plain FIRE.

Independent plastic-event detector used throughout (it never looks at jamlab's flags): the
trapezoid residual ``r_n = ΔE_n − ½ δγ ΔΣ_n`` of a continuous branch is ``O(δγ³)`` plus, when a
contact opens or closes inside the step, a kink term ``≲ δγ² · (contact stiffness 2)``; an
avalanche of size ``S`` gives ``r_n ≈ −S``. So ``−r_n > 100 δγ²`` (``1e-8`` at ``δγ = 1e-5``)
marks a jump; the threshold is also checked to exceed the measured noise floor
(:func:`jamlab.analysis.avalanches.noise_floor`) by orders of magnitude.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import jamlab.spheres as sp
from jamlab.analysis.avalanches import branch_residual, jumps_from_trace, noise_floor
from jamlab.spheres import aqs, random_packing
from jamlab.spheres.aqs.continuation import continue_network, switch_keeps_pd
from jamlab.spheres.aqs.linalg import backbone_matrix, factorise, hessian_matrix
from jamlab.spheres.aqs.network import (
    affine_to,
    backbone_mask,
    contact_list,
    find_backbone,
    network_forces,
)
from jamlab.spheres.aqs.predictor import BranchPath, Secants
from jamlab.spheres.fire import minimize
from jamlab.spheres.io import read_lammps_positions
from jamlab.spheres.trace import TRACE_COLUMNS, Trace, read_trace, write_trace
from reference_data import N500, N1000

DGAMMA = 1e-5


def _reference(folder: Path):
    meta = json.loads((folder / "meta.json").read_text())
    data = np.genfromtxt(folder / "trace.csv", delimiter=",", names=True)
    start = read_lammps_positions(folder / "positions.txt", box_length=meta["box_length"])
    return meta, data, start


def _residual(gamma, energy, stress) -> np.ndarray:
    ej, sj, dg = jumps_from_trace(gamma, energy, stress)
    return branch_residual(ej, sj, dg)


def _jumps_by_residual(gamma, energy, stress, threshold=100 * DGAMMA**2) -> np.ndarray:
    """Row indices ``n`` (step ``n−1 → n``) where the trapezoid residual says: jump."""
    return np.flatnonzero(-_residual(gamma, energy, stress) > threshold) + 1


def _first(rows: np.ndarray, default: int) -> int:
    return int(rows[0]) if rows.size else default


def _compare_with_reference(folder: Path, n_steps: int) -> None:
    _, ref, start = _reference(folder)
    res = aqs.shear(start, DGAMMA, n_steps=n_steps)
    tr = res.trace
    ref = ref[: n_steps + 1]
    ref_jumps = _jumps_by_residual(ref["strain"], ref["energy"], ref["shear_stress"])
    first_ref = _first(ref_jumps, n_steps + 1)
    first_ours = _first(np.flatnonzero(tr.plastic), n_steps + 1)
    # where the elastic branch ends does not depend on the minimiser
    assert first_ours == first_ref
    upto = slice(0, first_ref)
    np.testing.assert_allclose(tr.gamma, ref["strain"], rtol=1e-12, atol=0)
    np.testing.assert_allclose(tr.energy[upto], ref["energy"][upto], rtol=1e-9, atol=0)
    np.testing.assert_allclose(tr.shear_stress[upto], ref["shear_stress"][upto], rtol=1e-9, atol=0)
    np.testing.assert_allclose(tr.pressure[upto], ref["pressure"][upto], rtol=1e-9, atol=0)
    assert np.all(tr.max_force < 1e-12)


def test_lammps_reference_n1000_100_steps():
    _compare_with_reference(N1000, 100)


def test_lammps_reference_n500_first_plastic_event():
    # the first avalanche of this trace is at step 43 -> 44; 60 steps cover it
    _, ref, _ = _reference(N500)
    assert 0 < _first(_jumps_by_residual(ref["strain"], ref["energy"], ref["shear_stress"]), 0)
    _compare_with_reference(N500, 60)


@pytest.mark.slow
def test_lammps_reference_n500_1000_steps_events():
    """All 1000 steps. An avalanche in LAMMPS's trace is a step with ``−r > 100 δγ²``: its
    events have ``−r`` from 5.6e-7 to 0.22, its elastic steps ``|r| ≤ 2.8e-9`` (kinks where a
    contact closes on a soft mode, and steps just before a saddle-node). jamlab must flag exactly
    those steps; wherever the two land in the same minimum (energies equal), E and Σ agree."""
    _, ref, start = _reference(N500)
    tr = aqs.shear(start, DGAMMA, n_steps=1000).trace
    ref_jumps = _jumps_by_residual(ref["strain"], ref["energy"], ref["shear_stress"])
    ours = np.flatnonzero(tr.plastic)
    same = np.isclose(tr.energy, ref["energy"], rtol=1e-9, atol=0)
    common = int(np.argmin(same)) if not same.all() else tr.gamma.size
    np.testing.assert_array_equal(ours[ours <= common], ref_jumps[ref_jumps <= common])
    assert ours[0] == ref_jumps[0]
    np.testing.assert_allclose(tr.shear_stress[same], ref["shear_stress"][same], rtol=1e-8, atol=0)
    # plastic steps lower the energy below the branch (r < 0); the noise floor of elastic steps
    # is far below the smallest event
    r = tr.residual
    assert np.all(r[tr.plastic] < 0)
    floor = noise_floor(tr.energy_jump[1:], tr.stress_jump[1:], DGAMMA, plastic=tr.plastic[1:])
    assert floor.threshold(10) < 1e-2 * np.min(-r[tr.plastic])


def _short_trace(minimizer: str, n_steps: int = 40, ftol: float = 1e-12) -> Trace:
    _, _, start = _reference(N500)
    return aqs.shear(start, DGAMMA, n_steps=n_steps, minimizer=minimizer, ftol=ftol).trace


def test_elastic_steps_follow_the_trapezoid_rule():
    tr = _short_trace("linear")
    elastic = ~tr.plastic[1:]
    assert elastic.sum() == tr.n_steps  # no avalanche in the first 40 steps (LAMMPS: step 43)
    de = np.diff(tr.energy)
    trapezoid = 0.5 * np.diff(tr.gamma) * (tr.shear_stress[1:] + tr.shear_stress[:-1])
    np.testing.assert_allclose(de[elastic], trapezoid[elastic], rtol=0, atol=1e-9 * tr.energy[0])
    # tighter: the residual is minimiser noise plus contact-change kinks, far below δγ Σ
    assert np.max(np.abs(de - trapezoid)) < 1e-4 * np.min(np.abs(de))


def test_fast_path_equals_plain_fire():
    # FIRE's stress at max|F| < 1e-12 is only good to ~3e-10 relative here (soft modes of
    # stiffness ~2e-3 turn a 1e-12 force into a 5e-10 displacement); 1e-13 resolves 1e-10
    fast = _short_trace("linear", 25, ftol=1e-13)
    fire = _short_trace("fire", 25, ftol=1e-13)
    np.testing.assert_array_equal(fast.plastic, fire.plastic)
    np.testing.assert_allclose(fast.energy, fire.energy, rtol=1e-10, atol=0)
    np.testing.assert_allclose(fast.shear_stress, fire.shear_stress, rtol=1e-10, atol=0)
    assert np.median(fast.iterations[1:]) < 10 < np.min(fire.iterations[1:])


def _packing_at(n: int, phi: float, seed: int):
    res = minimize(random_packing(n, 3, phi, seed), ftol=1e-12)
    assert res.converged
    return res.packing


def _events_fast_vs_fire(start, n_steps: int, residual_checks: bool = True) -> tuple[Trace, Trace]:
    fast = aqs.shear(start, DGAMMA, n_steps=n_steps).trace
    fire = aqs.shear(start, DGAMMA, n_steps=n_steps, minimizer="fire").trace
    # each minimiser's flags are consistent with the independent residual test: every step whose
    # residual drop exceeds 100 δγ² is flagged (not near jamming, where S ~ δγ |ΔΣ|)
    for tr in (fast, fire):
        big = _jumps_by_residual(tr.gamma, tr.energy, tr.shear_stress)
        if residual_checks:
            assert set(big) <= set(np.flatnonzero(tr.plastic))
    # the events happen at the same steps up to where the two runs part ways (an avalanche may
    # land in different minima, and from then on the traces are different samples)
    same = np.isclose(fast.energy, fire.energy, rtol=1e-9, atol=0)
    common = int(np.argmin(same)) if not same.all() else fast.gamma.size
    np.testing.assert_array_equal(fast.plastic[: common + 1], fire.plastic[: common + 1])
    both = fast.plastic & fire.plastic & same
    np.testing.assert_allclose(
        fast.energy_jump[both], fire.energy_jump[both], rtol=1e-8, atol=1e-12
    )
    return fast, fire


@pytest.mark.slow
def test_events_fast_vs_fire_phi080():
    """φ = 0.8, N = 500, the issue's 300 steps (avalanches at rows 44, 215 and 235 when this
    was written; after the first one the runs may part from LAMMPS's trace: chaos)."""
    _, ref, start = _reference(N500)
    fast, fire = _events_fast_vs_fire(start, 300)
    # independent event lists: (1) jumps in LAMMPS's own trace of the same sample, up to the
    # first avalanche after which the two land in different minima
    ref = ref[:301]
    same = np.isclose(fast.energy, ref["energy"], rtol=1e-9, atol=0)
    common = int(np.argmin(same)) if not same.all() else ref.size
    ref_jumps = _jumps_by_residual(ref["strain"], ref["energy"], ref["shear_stress"])
    ours = np.flatnonzero(fast.plastic)
    assert ref_jumps[0] <= common
    np.testing.assert_array_equal(ours[ours <= common], ref_jumps[ref_jumps <= common])
    # plastic steps lower the energy below the branch (r < 0) when S >> δγ |ΔΣ|
    # (2) over all 300 steps, the drops of each run's energy below its continued branch
    for tr in (fast, fire):
        assert np.all(tr.residual[tr.plastic] < 0)
        np.testing.assert_array_equal(
            np.flatnonzero(tr.plastic), _jumps_by_residual(tr.gamma, tr.energy, tr.shear_stress)
        )
    assert fast.plastic.sum() >= 2


def _near_jamming(n: int, seed: int, p_target: float):
    """Bisection in φ by affine rescaling, FIRE to 1e-12 each time, until p ≈ p_target (within a
    factor 2). jamlab.spheres.packing.jam was not available when this test was written."""

    def at(p, phi):
        length = sp.box_length_for(p.n, p.dim, phi)
        return sp.Packing(p.positions * (length / p.box.length), sp.Box(length, p.dim, 0.0))

    lo, hi = 0.55, 0.70
    cur = minimize(random_packing(n, 3, hi, seed), ftol=1e-12).packing
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        trial = minimize(at(cur, mid), ftol=1e-12).packing
        pressure = sp.pressure(trial)
        if pressure > 2 * p_target:
            hi, cur = mid, trial
        elif pressure < 0.5 * p_target:
            lo = mid
        else:
            return trial
    raise AssertionError("bisection did not reach the target pressure")


@pytest.mark.slow
def test_events_fast_vs_fire_near_jamming():
    """Near jamming (p ≈ 1e-4, N = 64 rather than 500 for the CI budget, 60 steps)."""
    start = _near_jamming(64, 5, 1e-4)
    assert sp.remove_rattlers(start).n_rattlers < start.n
    _events_fast_vs_fire(start, 60, residual_checks=False)


def test_trace_round_trip(tmp_path):
    tr = Trace.from_rows(
        {
            "gamma": [0.0, 1e-5, 2e-5],
            "energy": [1.0, 1.1, 0.9],
            "shear_stress": [0.5, 0.6, 0.1],
            "pressure": [0.1, 0.1, 0.1],
            "z": [6.0, 6.0, 5.9],
            "z_nr": [6.1, 6.1, 6.0],
            "max_force": [1e-13, 1e-13, 1e-13],
            "iterations": [0, 2, 500],
            "plastic": [False, False, True],
        },
        attrs={"dgamma": 1e-5, "minimizer": "linear", "N": 3},
    )
    path = write_trace(tmp_path / "t.h5", tr)
    import h5py

    with h5py.File(path) as h5:
        assert set(h5.keys()) == set(TRACE_COLUMNS)
        assert all(h5[k].ndim == 1 for k in TRACE_COLUMNS)
    back = read_trace(path)
    for k in TRACE_COLUMNS:
        np.testing.assert_array_equal(getattr(back, k), getattr(tr, k))
    assert back.attrs["minimizer"] == "linear" and back.attrs["dgamma"] == 1e-5
    # row n describes the step n-1 -> n; row 0 has no step
    assert np.isnan(back.energy_jump[0]) and np.isnan(back.stress_jump[0])
    assert back.energy_jump[2] == pytest.approx(0.9 - 1.1 - 1e-5 * 0.6, rel=1e-14)
    assert back.stress_jump[1] == pytest.approx(0.1, rel=1e-12)


def test_save_every_may_be_a_numpy_integer(tmp_path):
    # as n_steps may: the same checkpoints as with the Python int
    start = _packing_at(64, 0.8, 3)
    for every, name in ((2, "a.h5"), (np.int64(2), "b.h5")):
        aqs.shear(start, DGAMMA, n_steps=5, out=tmp_path / name, save_every=every)
    names = [
        sorted(p.name for p in aqs.checkpoint_paths(tmp_path / name)[1].iterdir())
        for name in ("a.h5", "b.h5")
    ]
    assert names[0] == names[1] == ["step_00000002.h5", "step_00000004.h5", "step_00000005.h5"]
    a, b = read_trace(tmp_path / "a.h5"), read_trace(tmp_path / "b.h5")
    np.testing.assert_array_equal(a.energy, b.energy)


def test_resume_continues_the_same_trace(tmp_path):
    start = _packing_at(64, 0.8, 3)
    whole = aqs.shear(start, DGAMMA, n_steps=12).trace
    out = tmp_path / "run.h5"
    aqs.shear(start, DGAMMA, n_steps=5, out=out, save_every=2)
    last, snapshots = aqs.checkpoint_paths(out)
    assert last.is_file() and sorted(p.name for p in snapshots.iterdir()) == [
        "step_00000002.h5",
        "step_00000004.h5",
        "step_00000005.h5",
    ]
    from jamlab.spheres.io import read_packing

    part = read_trace(out)
    rest = aqs.shear(read_packing(last), DGAMMA, n_steps=12, previous=part).trace
    assert rest.n_steps == 12
    np.testing.assert_array_equal(rest.gamma, whole.gamma)
    np.testing.assert_allclose(rest.energy, whole.energy, rtol=1e-12)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"dgamma": 0.0, "gamma_max": 0.01},
        {"dgamma": -1e-5, "gamma_max": 0.01},
        {"dgamma": 0.02, "gamma_max": 0.01},
        {"dgamma": 1e-5, "gamma_max": 1e-5},
        {"dgamma": float("nan"), "gamma_max": 0.01},
        {"dgamma": 1e-5, "gamma_max": 0.01, "minimizer": "cg"},
        {"dgamma": 1e-5, "gamma_max": 0.01, "ftol": 0.0},
        {"dgamma": 1e-5, "n_steps": 0},
    ],
)
def test_bad_arguments(kwargs):
    start = random_packing(64, 3, 0.8, 1)
    with pytest.raises(ValueError):
        aqs.shear(start, **kwargs)


@pytest.mark.parametrize(("kick", "expect_pd"), [(0.002, True), (0.02, False)])
def test_corrected_preconditioner_is_the_inverse_of_the_updated_matrix(kick, expect_pd):
    """Woodbury-corrected ``P⁻¹`` of the fast path against a dense solve of ``M + U S Uᵀ`` built
    independently (contact sets by Python sets, blocks by hand), and its inertia test against
    the dense eigenvalues."""
    from jamlab.spheres.potential import NeighborList, contacts

    start = _packing_at(64, 0.7, 3)
    nl = NeighborList(start)
    fac = factorise(start, nl, find_backbone(start, nl))
    assert fac.positive_definite
    m_dense = backbone_matrix(start, nl, fac).toarray()
    c0 = contacts(start)
    before = {(int(i), int(j)) for i, j in zip(c0[0], c0[1], strict=True)}
    rng = np.random.default_rng(0)
    moved = start.with_positions(start.positions + kick * rng.standard_normal((start.n, 3)))
    c1 = contacts(moved)
    after = {(int(i), int(j)) for i, j in zip(c1[0], c1[1], strict=True)}
    sep = {(int(i), int(j)): v for i, j, v in zip(*c1, strict=True)}
    sep0 = {(int(i), int(j)): v for i, j, v in zip(*c0, strict=True)}
    changed = [(pair, 2.0, sep[pair]) for pair in sorted(after - before)]
    changed += [(pair, -2.0, sep0[pair]) for pair in sorted(before - after)]
    changed = [c for c in changed if fac.free_index[c[0][0]] >= 0 or fac.free_index[c[0][1]] >= 0]
    assert len(changed) >= 2
    p_dense = m_dense.copy()
    for (i, j), s, v in changed:
        b = np.zeros(m_dense.shape[0])
        nrm = v / np.linalg.norm(v)
        for particle, sign in ((i, 1.0), (j, -1.0)):
            f = fac.free_index[particle]
            if f >= 0:
                b[3 * f : 3 * f + 3] = sign * nrm
        p_dense += s * np.outer(b, b)
    ci, cj, cd = contact_list(moved, NeighborList(moved))
    fac.update(ci, cj, cd, max_rank=100)
    assert fac.corr_keys.size == len(changed)
    assert fac.corrected_pd == bool(np.all(np.linalg.eigvalsh(p_dense) > 0)) == expect_pd
    if fac.corrected_pd:
        r = rng.standard_normal(m_dense.shape[0])
        np.testing.assert_allclose(fac.solve(r), np.linalg.solve(p_dense, r), rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------------------------------------
# the pieces of the lean step, against independent computations


def test_fused_kernel_equals_the_separate_passes():
    """forces_virial_flags against energy_forces_virial and contact_pairs, and its contact-state
    comparison against a count from two contact lists."""
    # (the kernels themselves: a test of the private kernel modules of jamlab.spheres)
    from jamlab.spheres import kernels as AK
    from jamlab.spheres import kernels as KK
    from jamlab.spheres.potential import NeighborList

    pk = random_packing(200, 3, 0.7, 5)
    nl = NeighborList(pk)
    pos = nl.sorted(pk.positions)
    f1, s1 = np.empty_like(pos), np.empty((3, 3))
    e1, n1 = KK.energy_forces_virial(
        pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha, f1, s1
    )
    flags = np.empty(nl.nbr.size, dtype=np.uint8)
    f2, s2 = np.empty_like(pos), np.empty((3, 3))
    e2, n2, m = AK.forces_virial_flags(
        pos, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha, f2, s2, flags, True
    )
    assert m == 0 and n2 == n1 and int(flags.sum()) == n1
    np.testing.assert_allclose(e2, e1, rtol=1e-13)
    np.testing.assert_allclose(f2, f1, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s2, s1, rtol=1e-13, atol=1e-13)
    # move some particles: the mismatches are the symmetric difference of the contact sets
    moved = pos + 0.05 * np.random.default_rng(1).standard_normal(pos.shape)
    c0i, c0j, _ = KK.contact_pairs(pos, nl.start, nl.nbr, nl.shift, nl.diameters)
    before = {tuple(sorted(p)) for p in zip(c0i.tolist(), c0j.tolist(), strict=True)}
    ci, cj, _ = KK.contact_pairs(moved, nl.start, nl.nbr, nl.shift, nl.diameters)
    after = {tuple(sorted(p)) for p in zip(ci.tolist(), cj.tolist(), strict=True)}
    _, _, m = AK.forces_virial_flags(
        moved, nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha,
        np.empty_like(pos), np.empty((3, 3)), flags, False,
    )
    assert m == len(before ^ after) > 0


def test_path_predictor_is_exact_on_a_polynomial_branch():
    """The weighted least-squares predictor reproduces a path that is a polynomial of its
    degree in the step (exact to rounding), whatever the weights; for a smooth non-polynomial
    path its error falls with the degree."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal((5, 10, 3))
    for degree in (2, 3, 4):
        path = BranchPath(depth=16, degree=degree, floor=1e-14)

        def z(t, degree=degree):
            return sum(a[k] * t**k for k in range(degree + 1))

        for t in range(12):
            u = z(t) - z(t - 1) if t else z(0)
            noise = 10.0 ** rng.uniform(-14, -12)
            path.add(u, noise, kinked=False)
            if t >= degree:
                pred = path.predict()
                scale = np.max(np.abs(z(t + 1)))  # the predictor works with cumulative z
                np.testing.assert_allclose(pred, z(t + 1) - z(t), rtol=0, atol=1e-12 * scale)
    # a contact change restarts the piece: the first prediction is the step that contained it
    path.add(np.ones((10, 3)), 1e-14, kinked=True)
    np.testing.assert_array_equal(path.predict(), np.ones((10, 3)))


def test_multisecant_correction_is_the_least_squares_combination():
    """Secants.correction against numpy's least squares on the same stored pairs."""
    rng = np.random.default_rng(4)
    sec = Secants(depth=5)
    pairs = [(rng.standard_normal((30, 3)), rng.standard_normal((30, 3))) for _ in range(8)]
    for s_k, y_k in pairs:
        sec.push(s_k, y_k)
    kept = pairs[-5:]  # the ring buffer holds the newest five
    y = np.stack([p[1].ravel() for p in kept], axis=1)
    s = np.stack([p[0].ravel() for p in kept], axis=1)
    r = rng.standard_normal((30, 3))
    coef = np.linalg.lstsq(y, r.ravel(), rcond=None)[0]
    np.testing.assert_allclose(sec.correction(r).ravel(), s @ coef, rtol=1e-8, atol=1e-10)
    # a residual in the span of the y's is removed exactly: r = Y c gives dx = S c
    c = rng.standard_normal(5)
    np.testing.assert_allclose(sec.correction((y @ c).reshape(30, 3)).ravel(), s @ c, atol=1e-8)


def test_network_forces_equal_the_pair_forces_on_the_contact_set():
    """With ``C`` the contacts of a configuration (random, sheared: forces of order one), the
    network forces are the real ones; a pair of ``C`` pulled apart pulls back (tension)."""
    p = affine_to(random_packing(64, 3, 0.75, 3), 0.3)
    nl = sp.NeighborList(p)
    ci, cj, cd = contact_list(p, nl)
    f_net, _, r = network_forces(p, ci, cj)
    np.testing.assert_array_less(r, 1.0)
    f_ref = sp.energy_and_forces(p)[1]
    np.testing.assert_allclose(f_net, f_ref, rtol=0, atol=1e-13 * np.abs(f_ref).max())
    # two spheres at distance 1.2 joined by the network: force 2 (1 − r) n on i, i.e. attraction
    q = sp.Packing(np.array([[1.0, 1.0, 1.0], [2.2, 1.0, 1.0]]), sp.Box(5.0, 3, 0.0))
    f, _, r = network_forces(q, np.array([0]), np.array([1]))
    np.testing.assert_allclose(r, [1.2])
    np.testing.assert_allclose(f, [[0.4, 0, 0], [-0.4, 0, 0]], atol=1e-15)


@pytest.mark.slow
def test_network_continuation_near_jamming_against_fire_and_the_residual():
    """Near jamming (N = 128, p ≈ 1e-5), 30 steps, each from FIRE's minimum of the previous one.

    Independent checks of the event-driven continuation's verdict: where the branch continues,
    FIRE from the affinely sheared start lands in the same minimum; where it ends, FIRE's minimum
    lies below the branch: its trapezoid residual is more negative than ten times the largest
    residual of the continued steps. (The substep continuation used before the fourth session
    disagreed on 9 of these 30 steps; docs/aqs.md.)"""
    from jamlab.spheres.packing import jam

    res = jam(128, 3, seed=1, p_target=1e-5)
    assert res.ok
    cur = res.packing
    params = aqs.AQSParameters()
    elastic_r, plastic_r, events = [], [], 0
    for _ in range(30):
        nl = sp.NeighborList(cur)
        target = cur.strain + DGAMMA
        branch = continue_network(cur, None, target, nl, 1e-12, params)
        fire = minimize(affine_to(cur, target), 1e-12, neighbors=nl).packing
        e0, e1 = sp.evaluate(cur, nl), sp.evaluate(fire, nl)
        r = e1.energy - e0.energy - 0.5 * DGAMMA * (e0.shear_stress + e1.shear_stress)
        if branch.packing is None:
            plastic_r.append(r)
        else:
            elastic_r.append(r)
            events += branch.events  # contact-set switches inside the step
            relaxed = minimize(branch.packing, 1e-12, neighbors=nl).packing
            e2 = sp.evaluate(relaxed, nl)
            assert abs(e2.energy - e1.energy) < 1e-10 * e1.energy
            dr = relaxed.box.minimum_image(relaxed.positions - fire.positions)
            keep = find_backbone(relaxed, nl)
            assert np.max(np.abs(dr[keep] - dr[keep].mean(axis=0))) < 1e-6
        cur = fire
    assert plastic_r and events >= 5
    assert max(plastic_r) < -10 * np.max(np.abs(elastic_r))


def test_the_continuation_preconditions_with_the_switched_network():
    """After contact switches on a backbone large enough to keep its factor (more than
    ``ND_MIN_FREE`` free particles), the factor the continuation returns is corrected for the
    network it ended on: ``P⁻¹`` inverts the network Hessian at the end (built here from the
    contacts of the returned minimum) up to the smooth drift of the step, while the uncorrected
    factor alone is far off (its contacts are those of the start)."""
    p = sp.jam(500, 3, seed=2, p_target=1e-4).packing
    nl = sp.NeighborList(p)
    ci, cj, _ = contact_list(p, nl)
    fac = factorise(p, nl, backbone_mask(ci, cj, p.n, p.dim))
    branch = continue_network(p, fac, p.strain + DGAMMA, nl, 1e-12, aqs.AQSParameters())
    assert branch.packing is not None and branch.events >= 1  # a step with switches, continued
    end, f = branch.packing, branch.factor
    ci, cj, _ = contact_list(end, nl)
    backbone = backbone_mask(ci, cj, end.n, end.dim)
    assert np.array_equal(backbone, f.backbone)  # the factor was kept, not remade
    live = backbone[ci] & backbone[cj]
    ci, cj = ci[live], cj[live]
    k = hessian_matrix(ci, cj, end.box.minimum_image(end.positions[ci] - end.positions[cj]), f)
    r = np.random.default_rng(0).standard_normal(k.shape[0])
    corrected = np.linalg.norm(k @ f.solve(r) - r) / np.linalg.norm(r)
    plain = np.linalg.norm(k @ f.lu.solve(r) - r) / np.linalg.norm(r)
    assert f.corr_keys is not None and f.corr_keys.size >= 1
    assert corrected < 0.5 and plain > 10.0


def test_the_continuation_does_not_approach_a_failed_strain_forever(monkeypatch):
    """Regression: after Newton failed to reach a strain, the continuation bisects towards it;
    on ``jam(250, 3, 27, 1e-7)`` at constant volume Newton then succeeded at every halving, and
    without the rule that retries the failed strain itself once it is within two smallest
    substeps the substep shrank to zero (an endless loop at γ = 6.125e-5). Every step must now
    need few Newton calls — far below the pathological guard of ``10 · max_events`` — and the
    run must end at minima."""
    import jamlab.spheres.aqs.continuation as continuation

    calls = []
    newton = continuation.damped_newton

    def counted(*args, **kwargs):
        calls[-1] += 1
        return newton(*args, **kwargs)

    monkeypatch.setattr(continuation, "damped_newton", counted)
    p = sp.jam(250, 3, seed=27, p_target=1e-7).packing
    calls.append(0)
    r = aqs.shear(p, DGAMMA, n_steps=8, after_step=lambda *_: calls.append(0))
    assert max(calls) <= 200  # (41 at most measured; the loop made 10,000)
    assert r.n_not_converged == 0 and np.all(r.trace.max_force < 1e-12)


def test_switch_positive_definiteness_against_dense_eigenvalues():
    """The inertia test of a contact switch (``K + U S Uᵀ`` positive definite?) against the
    lowest eigenvalue of that matrix built densely, for single removals (both outcomes: a
    particle left with ``d`` contacts is floppy) and an addition."""
    p = _packing_at(128, 0.66, 4)
    nl = sp.NeighborList(p)
    ci, cj, _ = contact_list(p, nl)
    backbone = backbone_mask(ci, cj, p.n, p.dim)
    live = backbone[ci] & backbone[cj]
    ci, cj = ci[live], cj[live]
    _, dr, _ = network_forces(p, ci, cj)
    fac = factorise(p, nl, backbone, (ci, cj, dr))
    assert fac.positive_definite
    d, n_free = p.dim, fac.free.size
    k = hessian_matrix(ci, cj, dr, fac).toarray()
    assert k.shape == (n_free * d, n_free * d)

    def dense_pd(pi, pj, signs):
        m = k.copy()
        for a, b, s in zip(pi, pj, signs, strict=True):
            sep = p.box.minimum_image(p.positions[a] - p.positions[b])
            u = np.zeros(n_free * d)
            for particle, sign in ((a, 1.0), (b, -1.0)):
                f = fac.free_index[particle]
                if f >= 0:
                    u[d * f : d * f + d] = sign * sep / np.linalg.norm(sep)
            m += 2.0 * s * np.outer(u, u)
        return np.linalg.eigvalsh(m)[0] > 0

    count = np.bincount(ci, minlength=p.n) + np.bincount(cj, minlength=p.n)
    params = aqs.AQSParameters()
    outcomes = []
    for c in range(ci.size):
        weak = min(count[ci[c]], count[cj[c]]) == d + 1
        if c % 7 and not weak:
            continue  # every isostatic-end contact, and a sample of the rest
        pi, pj, signs = ci[c : c + 1], cj[c : c + 1], np.array([-1.0])
        verdict, _ = switch_keeps_pd(p, ci, cj, fac, pi, pj, signs, params)
        assert verdict == dense_pd(pi, pj, signs)
        outcomes.append(verdict)
    assert True in outcomes and False in outcomes
    # adding a spring to a positive-definite K keeps it so (a pair of neighbours not in contact)
    bb = np.flatnonzero(backbone)
    sep = p.box.minimum_image(p.positions[bb, None] - p.positions[None, bb])
    gaps = np.linalg.norm(sep, axis=2)
    a, b = np.argwhere((gaps > 1.0) & (gaps < 1.3))[0]
    far = (bb[a], bb[b])
    verdict, _ = switch_keeps_pd(
        p, ci, cj, fac, np.array([far[0]]), np.array([far[1]]), np.array([1.0]), params
    )
    assert verdict and dense_pd([far[0]], [far[1]], [1.0])


def test_a_missed_lean_step_refreshes_an_aged_factor():
    """``refactor_missed``: an elastic step the lean step missed refreshes the factor when it
    is old. On ``prepare(500, 3, 0.8, 2)`` without the rule 14 of 150 steps miss the lean step
    with the single factor of step 0 (its corrections for changed contacts age; docs/aqs.md);
    with it the factor is refreshed and the lean step takes more steps. The minima are the
    same ones either way (the factor only preconditions; each minimum is converged to
    ``max|F| < 1e-12``): the trace agrees with the run without the rule."""
    start = sp.prepare(500, 3, 0.8, 2).packing
    never = dataclasses.replace(aqs.AQSParameters(), refactor_missed=10**6)
    old = aqs.shear(start, DGAMMA, n_steps=150, params=never).trace
    new = aqs.shear(start, DGAMMA, n_steps=150).trace
    assert new.attrs["n_factorisations"] > old.attrs["n_factorisations"]
    assert new.attrs["n_lean"] > old.attrs["n_lean"] + 5
    np.testing.assert_array_equal(new.plastic, old.plastic)
    np.testing.assert_allclose(new.energy, old.energy, rtol=1e-10, atol=0)
    np.testing.assert_allclose(new.shear_stress, old.shear_stress, rtol=1e-8, atol=0)
    assert np.all(new.max_force < 1e-12)


@pytest.mark.parametrize("name", ["refactor_every", "refactor_missed", "max_newton"])
@pytest.mark.parametrize("bad", [0, -3, 2.5])
def test_bad_factor_periods_are_refused(name, bad):
    with pytest.raises(ValueError, match=name):
        aqs.AQSParameters(**{name: bad})
