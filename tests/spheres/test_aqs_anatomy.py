"""The avalanche records of a trace (``shear(..., keep_avalanches=True)``) against a brute-force
diff of the stored configurations before and after each plastic step: every pair, explicit
periodic images (``spheres_brute``), rattlers and bucklers counted by hand, the elastic response
of the minimum before by dense least squares on the hand-written Hessian."""

from __future__ import annotations

import numpy as np
import pytest
from spheres_brute import brute_elastic_response, brute_force, image_shifts, pair_terms, wrap

import jamlab.spheres as sp
from jamlab.analysis.anatomy import event_extent
from jamlab.spheres.aqs import checkpoint_paths, shear
from jamlab.spheres.io import read_packing
from jamlab.spheres.trace import read_trace


def contact_set(pos, L, gamma, diam) -> set[tuple[int, int]]:
    i, j, _ = pair_terms(wrap(pos, L, gamma), L, gamma, diam)
    return {(int(a), int(b)) for a, b in zip(i, j, strict=True)}


AMBIGUOUS_GAP = 1e-12
"""Pairs with ``|r − σ| < AMBIGUOUS_GAP σ`` are contacts or not by the last bits: a minimum at
``max|F| < 1e-12`` does not decide them (met at fixed pressure near jamming)."""


def contact_bounds(pos, L, gamma, diam) -> tuple[set, set]:
    """``(sure, maybe)``: the pairs that are contacts whatever the rounding, and those that may
    be (:data:`AMBIGUOUS_GAP`)."""
    diam = np.asarray(diam, dtype=float)
    return (contact_set(pos, L, gamma, diam * (1 - AMBIGUOUS_GAP)),
            contact_set(pos, L, gamma, diam * (1 + AMBIGUOUS_GAP)))


def rattlers_by_hand(pairs: set, n: int, dim: int) -> np.ndarray:
    keep = np.ones(n, dtype=bool)
    changed = True
    while changed:
        changed = False
        for p in range(n):
            if keep[p] and sum(1 for a, b in pairs if p in (a, b) and keep[a] and keep[b]) <= dim:
                keep[p] = False
                changed = True
    return keep


def displacement_by_hand(before, after, L, g0, g1) -> np.ndarray:
    affine = np.array(before, dtype=float)
    affine[:, 0] += (g1 - g0) * affine[:, 1]
    a, b = wrap(after, L, g1), wrap(affine, L, g1)
    shifts = image_shifts(L, a.shape[1], g1)
    cand = (a - b)[:, None, :] - shifts[None, :, :]
    k = np.argmin((cand**2).sum(axis=2), axis=1)
    return cand[np.arange(a.shape[0]), k]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("anatomy") / "trace.h5"
    packing = sp.prepare(64, 3, 0.8, seed=3).packing
    res = shear(packing, 2e-3, n_steps=60, keep_avalanches=True, out=out, save_every=1)
    last, snapshots = checkpoint_paths(out)
    trace = read_trace(out)

    def config(step: int):
        if step == 0:
            return packing
        if step == trace.n_steps:
            return read_packing(last)
        return read_packing(snapshots / f"step_{step:08d}.h5")

    return res, trace, config


def check_records(trace, config, pressure: float = 0.0, allow_ambiguous: bool = False) -> None:
    """Every row of ``trace.avalanches`` against the brute-force diff of the stored minima
    before and after its step. ``pressure``: the target of a fixed-pressure run, whose affine
    step includes the dilation ``L_a/L_b`` and whose potential is the enthalpy ``E + p L^d``.
    ``allow_ambiguous``: steps with contacts decided by the last bits are checked against bounds
    (most rows must still be exact)."""
    av = trace.avalanches
    assert av is not None
    steps = av["step"]
    # one row per plastic step, in order
    np.testing.assert_array_equal(steps, np.flatnonzero(trace.plastic))
    assert steps.size >= 3, "the run should have a few plastic steps"
    thr = av["attrs"]["threshold"]
    offs = av["moved_offsets"]
    n_ambiguous = 0
    for row, n in enumerate(steps):
        b, a = config(n - 1), config(n)
        L, dim, diam = b.box.length, b.dim, np.asarray(b.diameters)
        La = a.box.length
        g0, g1 = b.strain, a.strain
        # the affine map of the step: shear by g1 - g0 and the dilation La / L (1 at fixed volume)
        raw = displacement_by_hand(np.asarray(b.positions) * (La / L), a.positions, La, g0, g1)
        c0, c1 = contact_set(b.positions, L, g0, diam), contact_set(a.positions, La, g1, diam)
        keep0, keep1 = rattlers_by_hand(c0, b.n, dim), rattlers_by_hand(c1, a.n, dim)
        # the event: raw minus the linear elastic response, minus the backbone-mean translation
        el = brute_elastic_response(wrap(b.positions, L, g0), L, g0, keep0, g1 - g0, diam, b.alpha)
        u = raw - el
        u -= u[keep0].mean(axis=0)
        fraction = ((raw - u) ** 2).sum() / (raw**2).sum()
        assert av["elastic_fraction"][row] == pytest.approx(fraction, rel=1e-6)
        s2 = (u**2).sum(axis=1)
        pr = s2.sum() ** 2 / (len(s2) * (s2**2).sum())
        assert av["participation"][row] == pytest.approx(pr, rel=1e-9)
        assert av["n_eff"][row] == pytest.approx(pr * b.n, rel=1e-9)
        assert av["max_displacement"][row] == pytest.approx(np.sqrt(s2.max()), rel=1e-9)
        assert bool(av["localized"][row]) == (pr * b.n <= av["attrs"]["n_eff_max"])
        # contacts decided by the last bits bound the counts; without them the counts are exact
        (s0, m0), (s1, m1) = contact_bounds(b.positions, L, g0, diam), contact_bounds(
            a.positions, La, g1, diam)
        assert len(s0 - m1) <= av["n_opened"][row] <= len(m0 - s1)
        assert len(s1 - m0) <= av["n_closed"][row] <= len(m1 - s0)
        ambiguous = s0 != m0 or s1 != m1
        assert allow_ambiguous or not ambiguous
        n_ambiguous += ambiguous
        zb = np.zeros(b.n, int)
        for i, j in c0:
            if keep0[i] and keep0[j]:
                zb[i] += 1
                zb[j] += 1
        special = ~keep0 | ~keep1 | (keep0 & (zb == dim + 1))
        changed = (c0 - c1) | (c1 - c0)
        only = bool(changed) and all(special[i] or special[j] for i, j in changed)
        if not ambiguous:
            assert av["n_opened"][row] == len(c0 - c1)
            assert av["n_closed"][row] == len(c1 - c0)
            assert bool(av["only_bucklers_rattlers"][row]) == only
        # the extent: event_extent (tested on exact cases in tests/analysis) of this event field
        # at the positions before the step, in the box after it
        radii, axis = event_extent(u, np.asarray(b.positions) * (La / L), La, g0)
        np.testing.assert_allclose(av["radii"][row], radii, rtol=1e-6)
        np.testing.assert_allclose(np.abs(av["thin_axis"][row] @ axis), 1.0, atol=1e-6)
        moved = np.flatnonzero(np.sqrt(s2) > thr)
        np.testing.assert_array_equal(av["moved_index"][offs[row] : offs[row + 1]], moved)
        np.testing.assert_allclose(
            av["moved_displacement"][offs[row] : offs[row + 1]], u[moved], rtol=1e-9, atol=1e-13
        )
        # ΔE = E_n − E_{n−1} − δγ Σ_{n−1} (E → E + p L^d at fixed pressure), ΔΣ = Σ_n − Σ_{n−1}
        # from the brute-force sums
        e0 = brute_force(wrap(b.positions, L, g0), L, g0, diam, b.alpha)
        e1 = brute_force(wrap(a.positions, La, g1), La, g1, diam, a.alpha)
        h0, h1 = e0["energy"] + pressure * L**dim, e1["energy"] + pressure * La**dim
        de = h1 - h0 - (g1 - g0) * e0["shear_stress"]
        assert av["energy_jump"][row] == pytest.approx(de, rel=1e-6, abs=1e-12)
        ds = e1["shear_stress"] - e0["shear_stress"]
        assert av["stress_jump"][row] == pytest.approx(ds, rel=1e-6, abs=1e-10)
    assert av["n_moved"].sum() == offs[-1]
    assert n_ambiguous < steps.size, "no row left with unambiguous contacts"


def test_records_match_brute_force_diff(run):
    res, trace, config = run
    check_records(trace, config)


@pytest.fixture(scope="module")
def run_at_pressure(tmp_path_factory):
    """60 steps of δγ = 1e-3 at fixed pressure p = 1e-3 (N = 64, d = 3), a snapshot per step."""
    out = tmp_path_factory.mktemp("anatomy_p") / "trace.h5"
    packing = sp.jam(64, 3, 3, p_target=1e-3).packing
    res = shear(packing, 1e-3, n_steps=60, pressure=1e-3, keep_avalanches=True, out=out,
                save_every=1)  # fmt: skip
    last, snapshots = checkpoint_paths(out)
    trace = read_trace(out)

    def config(step: int):
        # row 0 (the input brought to the pressure) has no snapshot; no plastic step starts there
        assert step > 0, "a plastic first step: its start minimum is not stored"
        if step == trace.n_steps:
            return read_packing(last)
        return read_packing(snapshots / f"step_{step:08d}.h5")

    return res, trace, config


def test_records_at_fixed_pressure_match_brute_force_diff(run_at_pressure):
    """At fixed pressure the box side changes in every step: the records are those of the
    brute-force diff with the dilation taken out, and ΔE is the enthalpy jump."""
    res, trace, config = run_at_pressure
    lengths = [config(n).box.length for n in np.flatnonzero(trace.plastic)]
    assert len(set(lengths)) == len(lengths), "the box should move with the steps"
    check_records(trace, config, pressure=1e-3, allow_ambiguous=True)
    # the group is in memory as on disk
    for k, v in res.trace.avalanches.items():
        if k != "attrs":
            np.testing.assert_array_equal(v, trace.avalanches[k])


def test_fixed_pressure_refuses_options_it_cannot_honour(run_at_pressure, tmp_path):
    _, trace, config = run_at_pressure
    packing = config(trace.n_steps)
    with pytest.raises(ValueError, match="after_step"):
        shear(packing, 1e-3, n_steps=2, pressure=1e-3, after_step=lambda *a: None)
    with pytest.raises(ValueError, match="constant-volume shear only"):
        shear(packing, 1e-3, n_steps=2, pressure=1e-3, classify=False)
    with pytest.raises(ValueError, match="cannot resume"):
        shear(packing, 1e-3, n_steps=70, pressure=1e-3, keep_avalanches=True, previous=trace)
    short = shear(packing, 1e-3, n_steps=2, pressure=1e-3)  # a run without records
    with pytest.raises(ValueError, match="cannot resume"):
        shear(short.packing, 1e-3, n_steps=4, pressure=1e-3, on_plastic=lambda *a: None,
              previous=short.trace)


@pytest.mark.parametrize("protocol", ["constant volume", "fixed pressure"])
def test_on_plastic_hands_out_the_stored_minima_of_the_plastic_steps(
    protocol, run, run_at_pressure, tmp_path
):
    """``on_plastic(row, before, after)``: the same run again (same checkpoints, since they are
    restart points) with the hook sees exactly the rows flagged plastic, in order, and its two
    minima are the stored snapshots of rows ``row − 1`` and ``row``, bit for bit; the hook
    changes nothing in the trace."""
    res, trace, config = run if protocol == "constant volume" else run_at_pressure
    if protocol == "constant volume":
        start, dgamma, extra = sp.prepare(64, 3, 0.8, seed=3).packing, 2e-3, {}
    else:
        start, dgamma, extra = sp.jam(64, 3, 3, p_target=1e-3).packing, 1e-3, {"pressure": 1e-3}
    seen = []
    again = shear(start, dgamma, n_steps=60, keep_avalanches=True, out=tmp_path / "t.h5",
                  save_every=1, on_plastic=lambda n, b, a: seen.append((n, b, a)), **extra)
    rows = [int(n) for n in np.flatnonzero(trace.plastic)]
    assert rows and [n for n, _, _ in seen] == rows
    for n, b, a in seen:
        for got, want in ((b, config(n - 1)), (a, config(n))):
            np.testing.assert_array_equal(got.positions, want.positions)
            assert got.box.length == want.box.length and got.strain == want.strain
    for column in ("gamma", "energy", "shear_stress", "plastic"):
        np.testing.assert_array_equal(getattr(again.trace, column), getattr(trace, column))


def test_hook_sees_every_step_and_records_equal_in_memory(run):
    res, trace, _ = run
    mem = res.trace.avalanches
    for key, value in trace.avalanches.items():
        if key != "attrs":
            np.testing.assert_array_equal(np.asarray(mem[key]), value)
    seen = []
    packing = sp.prepare(32, 2, 0.9, seed=1).packing
    shear(packing, 1e-3, n_steps=5, after_step=lambda b, a, s: seen.append((b.strain, a.strain)))
    assert [round(g1 - g0, 12) for g0, g1 in seen] == [1e-3] * 5
    assert seen[0][0] == pytest.approx(packing.strain) and seen[-1][1] == pytest.approx(5e-3)


def test_cli_keep_avalanches_writes_the_same_group(run, tmp_path):
    from cli_helpers import jamlab
    from jamlab.spheres.io import write_packing

    packing = sp.prepare(64, 3, 0.8, seed=3).packing
    cfg = tmp_path / "start.h5"
    write_packing(cfg, packing)
    out = tmp_path / "cli.h5"
    r = jamlab(
        "shear", cfg, "--dgamma", "2e-3", "--gamma-max", "0.12", "--out", out, "--keep-avalanches"
    )
    assert r.returncode == 0, r.stderr
    got = read_trace(out).avalanches
    ref = run[1].avalanches
    for key in ("step", "n_opened", "n_closed", "moved_offsets", "moved_index"):
        np.testing.assert_array_equal(got[key], ref[key])
    np.testing.assert_allclose(got["participation"], ref["participation"], rtol=1e-9)


def test_resume_from_a_trace_without_elastic_fraction(run, tmp_path):
    """A trace written before ``elastic_fraction`` and the extent (``radii``, ``thin_axis``)
    existed still loads and resumes: its rows get NaN there, the new rows are those of the
    whole run."""
    import h5py

    res, trace, _ = run
    packing = sp.prepare(64, 3, 0.8, seed=3).packing
    out = tmp_path / "old.h5"
    shear(packing, 2e-3, n_steps=30, keep_avalanches=True, out=out, save_every=1)
    with h5py.File(out, "r+") as f:
        for key in ("elastic_fraction", "radii", "thin_axis"):
            del f[f"avalanches/{key}"]
    old = read_trace(out)
    assert "elastic_fraction" not in old.avalanches and "radii" not in old.avalanches
    n_old = old.avalanches["step"].size
    last, _ = checkpoint_paths(out)
    shear(read_packing(last), 2e-3, n_steps=60, keep_avalanches=True, out=out, save_every=1,
          previous=old)  # fmt: skip
    got = read_trace(out).avalanches
    ref = trace.avalanches
    np.testing.assert_array_equal(got["step"], ref["step"])
    assert np.all(np.isnan(got["elastic_fraction"][:n_old]))
    np.testing.assert_allclose(got["elastic_fraction"][n_old:], ref["elastic_fraction"][n_old:],
                               rtol=1e-6)  # fmt: skip
    np.testing.assert_allclose(got["participation"], ref["participation"], rtol=1e-6)
    assert np.all(np.isfinite(ref["elastic_fraction"]))
    for key in ("radii", "thin_axis"):  # the same for the extent, (rows, d)
        assert got[key].shape == ref[key].shape == (ref["step"].size, 3)
        assert np.all(np.isnan(got[key][:n_old]))
        np.testing.assert_allclose(got[key][n_old:], ref[key][n_old:], rtol=1e-6)
        assert np.all(np.isfinite(ref[key]))


def test_cli_keep_avalanches_at_fixed_pressure(run_at_pressure, tmp_path):
    """``jamlab shear --pressure --keep-avalanches`` writes the group of the API run, bit for
    bit (it was dropped before); ``--resume`` with it is refused with exit code 2, the trace
    untouched."""
    from cli_helpers import jamlab
    from jamlab.spheres.io import write_packing

    cfg = tmp_path / "start.h5"
    write_packing(cfg, sp.jam(64, 3, 3, p_target=1e-3).packing)
    out = tmp_path / "cli.h5"
    args = ("shear", cfg, "--dgamma", "1e-3", "--out", out, "--pressure", "1e-3",
            "--keep-avalanches")  # fmt: skip
    r = jamlab(*args, "--gamma-max", "0.06")
    assert r.returncode == 0, r.stderr
    got = read_trace(out).avalanches
    # the same run through the API (without the fixture's checkpoints, which restart the solver
    # at every step and so move the last bits of the minima)
    ref = shear(sp.jam(64, 3, 3, p_target=1e-3).packing, 1e-3, n_steps=60, pressure=1e-3,
                keep_avalanches=True).trace.avalanches  # fmt: skip
    for key in ref:
        if key != "attrs":
            np.testing.assert_array_equal(got[key], ref[key])
    np.testing.assert_array_equal(got["step"], run_at_pressure[1].avalanches["step"])
    # keeping the minima changes nothing of the run
    plain = shear(sp.jam(64, 3, 3, p_target=1e-3).packing, 1e-3, n_steps=60,
                  pressure=1e-3).trace  # fmt: skip
    kept = read_trace(out)
    for name in ("energy", "shear_stress", "pressure", "phi", "plastic", "iterations"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(plain, name))
    before = out.read_bytes()
    r = jamlab(*args, "--gamma-max", "0.08", "--resume")
    assert r.returncode == 2
    assert "cannot resume" in r.stderr
    assert out.read_bytes() == before


def test_resume_after_an_interruption_keeps_the_earlier_records(run, tmp_path):
    """A run stopped after a checkpoint and resumed with ``keep_avalanches`` has the rows of the
    plastic steps before the checkpoint (they were lost when the checkpoints had no group)."""

    class Stop(Exception):
        pass

    def stop_at_45(n, total):
        if n == 45:
            raise Stop

    packing = sp.prepare(64, 3, 0.8, seed=3).packing
    out = tmp_path / "cut.h5"
    with pytest.raises(Stop):
        shear(packing, 2e-3, n_steps=60, keep_avalanches=True, out=out, save_every=20,
              progress=stop_at_45)  # fmt: skip
    cut = read_trace(out)
    assert cut.n_steps == 40 and cut.avalanches is not None
    last, _ = checkpoint_paths(out)
    shear(read_packing(last), 2e-3, n_steps=60, keep_avalanches=True, out=out, save_every=20,
          previous=cut)  # fmt: skip
    got, ref = read_trace(out).avalanches, run[1].avalanches
    assert np.any(ref["step"] <= 40), "the reference should have plastic steps before the cut"
    np.testing.assert_array_equal(got["step"], ref["step"])
    for key in ("n_opened", "n_closed", "localized", "n_moved"):
        np.testing.assert_array_equal(got[key], ref[key])
    for key in ("participation", "energy_jump"):
        np.testing.assert_allclose(got[key], ref[key], rtol=1e-6)
    # the reference restarts at every step (save_every=1), this run every 20: their minima agree
    # to the minimiser's precision, not bit for bit, and a small elastic fraction (a ratio of
    # squared displacements) differs by 3.6e-7 of 1 (0.0128 against 0.0128 + 3.6e-7, measured
    # with the CHOLMOD preconditioner; 1e-6 relative with SuperLU's): compared on its own scale
    np.testing.assert_allclose(got["elastic_fraction"], ref["elastic_fraction"], rtol=1e-6,
                               atol=1e-6)


def test_resume_without_the_records_is_refused(run, tmp_path):
    """Resuming a run that kept avalanche records without ``--keep-avalanches`` would write the
    trace without them: refused (exit code 2 from the CLI), the file untouched."""
    from cli_helpers import jamlab
    from jamlab.spheres.io import write_packing

    cfg = tmp_path / "start.h5"
    write_packing(cfg, sp.prepare(64, 3, 0.8, seed=3).packing)
    out = tmp_path / "t.h5"
    args = ("shear", cfg, "--dgamma", "2e-3", "--out", out)
    assert jamlab(*args, "--gamma-max", "0.02", "--keep-avalanches").returncode == 0
    before = out.read_bytes()
    r = jamlab(*args, "--gamma-max", "0.04", "--resume")
    assert r.returncode == 2
    assert "kept avalanche records" in r.stderr
    assert out.read_bytes() == before
    with pytest.raises(ValueError, match="kept avalanche records"):
        last, _ = checkpoint_paths(out)
        shear(read_packing(last), 2e-3, n_steps=20, previous=read_trace(out))
