"""``jamlab.threads.one_blas_thread``: the small fits run with one BLAS thread (many times faster
on busy cores, docs in the module) and give the same numbers, bit for bit, as with the BLAS's own
threads."""

from __future__ import annotations

import contextlib
import dataclasses

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from jamlab.threads import one_blas_thread


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpool_info() if i.get("user_api") == "blas"]


def test_one_thread_inside_the_block_and_the_setting_restored_after():
    import scipy.linalg  # noqa: F401  (scipy's BLAS loaded, as in every fit)

    with threadpool_limits(2, user_api="blas"):
        before = _blas_threads()
        assert before and max(before) == 2
        with one_blas_thread():
            assert _blas_threads() == [1] * len(before)
        assert _blas_threads() == before


def _draws(rng, tau, x_c, m):
    x = (1 - rng.random(6 * m)) ** (-1 / (tau - 1))
    return x[rng.random(x.size) < np.exp(-x / x_c)][:m]


@pytest.mark.parametrize("threads", [2, 4])
def test_fits_are_bit_identical_with_the_blas_threads(monkeypatch, threads):
    """fit_cutoff_power_law (KS rule, 3 starts of L-BFGS-B per candidate) and the shape-free
    fit of shape_test with their one-thread block, against the same code with it replaced by a
    no-op under `threads` BLAS threads."""
    from jamlab.analysis import cutoff_powerlaw, shape_test
    from jamlab.analysis.cutoff_powerlaw import fit_cutoff_power_law
    from jamlab.analysis.shape_test import clustered_shape_test

    x = _draws(np.random.default_rng(7), 1.4, 300.0, 3000)
    samples = np.array_split(x, 10)
    one = fit_cutoff_power_law(x, max_candidates=8)
    one_shape = clustered_shape_test(samples, 1.0)
    with monkeypatch.context() as m:
        m.setattr(cutoff_powerlaw, "one_blas_thread", contextlib.nullcontext)
        m.setattr(shape_test, "one_blas_thread", contextlib.nullcontext)
        with threadpool_limits(threads, user_api="blas"):
            many = fit_cutoff_power_law(x, max_candidates=8)
            many_shape = clustered_shape_test(samples, 1.0)
    for first, second in ((one, many), (one_shape, many_shape)):
        for f in dataclasses.fields(first):
            a, b = getattr(first, f.name), getattr(second, f.name)
            assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), f.name
