"""The hand-written heapsort of the AQS kernels and ``contact_changes``, against numpy.

``sort_by_key`` replaces ``np.argsort`` inside ``contact_changes`` (numba's generic quicksort
costs ~1.5 s of compilation on a first run); with distinct keys the order is unique, so the
results must equal numpy's exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.spheres.kernels import contact_changes
from jamlab.spheres.kernels.aqs import sort_by_key


@pytest.mark.parametrize("size", [0, 1, 2, 3, 7, 64, 1000])
def test_sort_by_key_matches_argsort(size):
    rng = np.random.default_rng(size)
    keys = rng.choice(10 * size + 1, size=size, replace=False).astype(np.int64)
    values = rng.integers(0, 1_000_000, size=size).astype(np.int64)
    order = np.argsort(keys, kind="stable")
    k, v = keys.copy(), values.copy()
    sort_by_key(k, v)
    np.testing.assert_array_equal(k, keys[order])
    np.testing.assert_array_equal(v, values[order])


def test_contact_changes_against_sets():
    rng = np.random.default_rng(3)
    n = 40
    all_pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    pick = rng.choice(len(all_pairs), size=120, replace=False)
    ref = sorted(all_pairs[p] for p in pick[:80])
    now = [all_pairs[p] for p in pick[40:]]  # 40 kept, 40 opened, 40 closed (new)
    now = [(j, i) if rng.random() < 0.5 else (i, j) for i, j in now]  # either orientation
    keys0 = np.array([i * n + j for i, j in ref], np.int64)
    row0 = np.searchsorted(keys0 // n, np.arange(n + 1)).astype(np.int64)
    ci = np.array([p[0] for p in now], np.int64)
    cj = np.array([p[1] for p in now], np.int64)
    closed, where, opened = contact_changes(keys0, row0, ci, cj, n)

    now_keys = {min(i, j) * n + max(i, j): p for p, (i, j) in enumerate(now)}
    expect_closed = sorted(set(now_keys) - set(keys0.tolist()))
    expect_opened = sorted(set(keys0.tolist()) - set(now_keys))
    assert len(expect_closed) == 40 and len(expect_opened) == 40
    np.testing.assert_array_equal(closed, expect_closed)
    np.testing.assert_array_equal(where, [now_keys[k] for k in expect_closed])
    np.testing.assert_array_equal(opened, expect_opened)
