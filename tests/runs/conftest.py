"""Fixtures of the run tests."""

import pytest
from runs_helpers import assert_same_runs


@pytest.fixture
def same_runs():
    return assert_same_runs
