"""Helpers of the run tests: comparing two run directories sample by sample, bit for bit."""

from pathlib import Path

import h5py
import numpy as np

# attributes that legitimately differ between two computations of the same sample
VOLATILE_ATTRS = {"seconds", "cpu_seconds", "provenance"}  # provenance: the host, and
# one record per invocation (a resumed sample has more)


def sample_files(run_dir: Path) -> dict[str, Path]:
    """The finished samples' files (``sample-XXXXX.h5``; not a failure's kept trace,
    ``sample-XXXXX.failed.h5`` or ``.retried.h5``)."""
    return {str(p.relative_to(run_dir)): p for p in sorted(run_dir.rglob("sample-*.h5"))
            if p.name.count(".") == 1}


def read_all(path: Path) -> tuple[dict, dict]:
    """(attrs, {dataset path: array}) of one sample file."""
    arrays: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as h5:
        attrs = {k: v for k, v in h5.attrs.items() if k not in VOLATILE_ATTRS}
        h5.visititems(
            lambda name, obj: (
                arrays.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None
            )
        )
    return attrs, arrays


def assert_same_runs(a: Path, b: Path) -> None:
    """Every sample file of ``a`` and ``b`` exists in both and is identical bit for bit."""
    fa, fb = sample_files(a), sample_files(b)
    assert fa, f"no samples in {a}"
    assert sorted(fa) == sorted(fb)
    for rel in fa:
        attrs_a, arrays_a = read_all(fa[rel])
        attrs_b, arrays_b = read_all(fb[rel])
        assert sorted(arrays_a) == sorted(arrays_b), rel
        for name in arrays_a:
            x, y = arrays_a[name], arrays_b[name]
            assert x.dtype == y.dtype and x.shape == y.shape, (rel, name)
            # bit-for-bit, NaN included
            assert x.tobytes() == y.tobytes(), (rel, name)
        assert sorted(attrs_a) == sorted(attrs_b), rel
        for k in attrs_a:
            x, y = np.asarray(attrs_a[k]), np.asarray(attrs_b[k])
            # NaN attributes (e.g. φ_J of a direct preparation) are equal to themselves here
            assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), (rel, k)


class Stop(Exception):
    """The interruption of a sample by its ``progress`` hook: the process stops there as a
    killed worker would (what is on disk is what the saves wrote)."""


def stop_after(step):
    """A ``progress`` hook that raises :class:`Stop` after strain step ``step``."""

    def progress(n, total):
        if n == step:
            raise Stop

    return progress
