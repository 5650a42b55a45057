"""The caches of `jamlab reproduce`: a stored coordination curve and a stored exact law read back
unchanged; damaged entries are named."""

import numpy as np

from jamlab.reproduce.cache import CURVE_ARRAYS, cache_file, load_curve, save_curve
from jamlab.spheres.packing import CoordinationCurve


def test_curve_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(3)
    arrays = {k: rng.random(7) for k in CURVE_ARRAYS}
    arrays["n_rattlers"] = rng.integers(0, 9, 7)
    arrays["converged"] = rng.random(7) > 0.3
    curve = CoordinationCurve(phi_j=0.6412345678901234, dim=3, n=128, **arrays)
    path = cache_file(tmp_path, 128, 5, 7)
    assert path.name == "coordination_N128_seed5_steps7.npz"
    save_curve(path, curve)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary file left
    back = load_curve(path)
    assert (back.phi_j, back.dim, back.n) == (curve.phi_j, 3, 128)
    assert type(back.dim) is int and type(back.n) is int and type(back.phi_j) is float
    for k in CURVE_ARRAYS:
        got, want = getattr(back, k), getattr(curve, k)
        assert got.dtype == want.dtype and np.array_equal(got, want), k


def test_a_damaged_entry_is_named(tmp_path):
    """A truncated file, a text file and an ``.npz`` without the curve's fields each give a
    ``ValueError`` naming the file (a one-line error of ``jamlab reproduce``), not a traceback."""
    import pytest

    curve = CoordinationCurve(phi_j=0.64, dim=3, n=8,
                              **{k: np.arange(3, dtype=float) for k in CURVE_ARRAYS})
    good = cache_file(tmp_path, 8, 1, 3)
    save_curve(good, curve)
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[:100])
    text = tmp_path / "text.npz"
    text.write_text("not a cache entry")
    other = tmp_path / "other.npz"
    np.savez(other, x=np.ones(2))
    for path in (cut, text, other):
        with pytest.raises(ValueError, match=f"unreadable cached coordination curve {path}"):
            load_curve(path)


def test_exact_law_round_trip_is_exact_and_ordered(tmp_path):
    import pytest

    from jamlab.reproduce.cache import exact_law_file, load_exact_law, save_exact_law
    from jamlab.reproduce.theory_checks import ExponentCheck

    rng = np.random.default_rng(4)
    mus = (0.706346389557222, 0.5)
    checks = tuple(ExponentCheck(mu=m, tau_exact=2 * m + 1e-3, tau_exact_min=1.3999999999999999,
                                 tau_exact_max=1.0 / 3.0, tau_printed=2 * m) for m in mus)
    tables = {m: {dg: {"abs_dE": rng.random(5), "pdf_exact": rng.random(5),
                       "n": np.arange(5)} for dg in (1e-2, 1e-3)} for m in mus}
    path = exact_law_file(tmp_path)
    assert path.parent == tmp_path and path.name.startswith("exact_law_")
    assert exact_law_file(tmp_path) == path  # one key per code
    save_exact_law(path, checks, tables)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary file left
    back_checks, back_tables = load_exact_law(path)
    assert back_checks == checks
    assert list(back_tables) == list(mus)
    for m in mus:
        assert list(back_tables[m]) == [1e-2, 1e-3]
        for dg in (1e-2, 1e-3):
            assert list(back_tables[m][dg]) == ["abs_dE", "pdf_exact", "n"]
            for k, v in tables[m][dg].items():
                got = back_tables[m][dg][k]
                assert got.dtype == v.dtype and np.array_equal(got, v)
    cut = tmp_path / "cut.npz"
    cut.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match=f"unreadable cached exact law {cut}"):
        load_exact_law(cut)


def test_writing_the_exact_law_removes_other_codes_entries_only(tmp_path):
    from jamlab.reproduce.cache import exact_law_file, save_exact_law
    from jamlab.reproduce.theory_checks import ExponentCheck

    stale = tmp_path / ("exact_law_" + "0123456789abcdef0123" + ".npz")  # another code's key
    keep = {
        "exact_law_notes.npz": b"a user's file",  # not a key of ours
        "exact_law_0123.npz": b"short key",
        "coordination_N64_seed1_steps40.npz": b"curve",
    }
    stale.write_bytes(b"old entry")
    for name, data in keep.items():
        (tmp_path / name).write_bytes(data)
    path = exact_law_file(tmp_path)
    assert path != stale
    check = ExponentCheck(mu=0.5, tau_exact=1.0, tau_exact_min=0.9, tau_exact_max=1.1,
                          tau_printed=1.0)
    save_exact_law(path, (check,), {0.5: {1e-2: {"n": np.arange(3)}}})
    assert not stale.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([path.name, *keep])
    for name, data in keep.items():
        assert (tmp_path / name).read_bytes() == data
