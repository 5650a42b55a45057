"""The jackknife variance against exact identities computed without it."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jamlab.analysis import jackknife_variance


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=2, max_size=40))
def test_of_the_mean_is_the_squared_standard_error(x):
    """For the mean the leave-one-out estimates are (Σx − x_i)/(m − 1), and the jackknife
    variance is exactly s²/m (Efron & Tibshirani, ch. 11)."""
    x = np.array(x)
    m = x.size
    loo = (x.sum() - x) / (m - 1)
    expected = np.var(x, ddof=1) / m
    assert jackknife_variance(loo) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_columns_are_separate_parameters():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(15, 3)) * [1.0, 10.0, 0.1]
    m = x.shape[0]
    loo = (x.sum(axis=0) - x) / (m - 1)
    v = jackknife_variance(loo)
    assert v.shape == (3,)
    np.testing.assert_allclose(v, np.var(x, axis=0, ddof=1) / m, rtol=1e-12)
    assert jackknife_variance(loo[:, 1]) == pytest.approx(v[1], rel=1e-15)


def test_fewer_than_two_estimates_are_refused():
    with pytest.raises(ValueError, match="at least two"):
        jackknife_variance([1.0])
    with pytest.raises(ValueError, match="at least two"):
        jackknife_variance(2.0)
