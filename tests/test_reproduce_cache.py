"""The coordination-curve cache of `jamlab reproduce`: a stored curve reads back unchanged."""

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
