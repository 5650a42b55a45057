import os

import numpy as np
import pytest

# Headless plotting everywhere in the tests.
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20170214)


@pytest.fixture(scope="session")
def small_pressure_run(tmp_path_factory):
    """A small fixed-pressure run directory (N = 16, p = 1e-3, 3 samples of 30 steps δγ = 1e-3),
    read by the tests of the scripts that analyse finished runs."""
    from jamlab.runs import Execution, Study, run_study

    out = tmp_path_factory.mktemp("small-pressure-run") / "p"
    study = Study(phi=["jamming"], n=[16], samples=3, dgamma=1e-3, gamma_max=3e-2, seed=4,
                  pressure=1e-3)
    run_study(study, out, Execution(workers=0))
    return out

@pytest.fixture(scope="session")
def pressure_runs_by_size(tmp_path_factory):
    """``{N: run directory}``: tiny fixed-pressure studies of N = 16 and 24 (4 samples, 200 steps
    δγ = 1e-3) and N = 32 (4 samples, 100 steps), p = 1e-3, study seed 5, read by the tests of
    the scripts that compare sizes (``size_dependence.py``, ``rate_collapse.py``,
    ``tau_summary.py``). Read only: a test that changes a run copies it first."""
    from jamlab.runs import Execution, Study, run_study

    root = tmp_path_factory.mktemp("pressure-runs-by-size")
    out = {}
    for n, gmax in ((16, 0.2), (24, 0.2), (32, 0.1)):
        study = Study(phi=["jamming"], n=[n], samples=4, dgamma=1e-3, gamma_max=gmax, seed=5,
                      pressure=1e-3)
        run_study(study, root / f"n{n}", Execution(workers=0))
        out[n] = root / f"n{n}"
    return out


@pytest.fixture(scope="session")
def jam64_packing():
    """``jam(64, 3, seed=5, p_target=1e-4)``: a small packing above jamming, shared by the
    tests of the FIRE probes."""
    from jamlab.spheres import jam

    return jam(64, 3, seed=5, p_target=1e-4).packing


@pytest.fixture(scope="session")
def fire_start(jam64_packing):
    """:func:`jam64_packing` with every coordinate moved by ``2e-3`` Gaussian noise (seed 1):
    a start FIRE needs some hundred iterations from."""
    rng = np.random.default_rng(1)
    pk = jam64_packing
    return pk.with_positions(pk.positions + 2e-3 * rng.standard_normal(pk.positions.shape))


# Property tests: deterministic in CI (a failure there must be reproducible), random locally.
try:
    from hypothesis import settings

    settings.register_profile("ci", derandomize=True, print_blob=True)
    if os.environ.get("CI"):
        settings.load_profile("ci")
except ImportError:  # pragma: no cover - hypothesis is a test dependency
    pass
