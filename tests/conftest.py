import os

import numpy as np
import pytest

# Headless plotting everywhere in the tests.
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20170214)
