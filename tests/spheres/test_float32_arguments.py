"""Numpy scalar arguments of the spheres API: a ``float32`` is accepted and computed with in
float64 (its value widened exactly, so the run equals the run given ``float(x)`` bit for bit);
a ``bool`` is refused, not read as 0 or 1."""

import numpy as np
import pytest

from jamlab.spheres.aqs import shear
from jamlab.spheres.barostat import minimize_enthalpy
from jamlab.spheres.fire import minimize
from jamlab.spheres.packing import jam, prepare
from jamlab.spheres.relax import rescale
from jamlab.spheres.state import random_packing


@pytest.fixture(scope="module")
def packing():
    return prepare(32, 2, 0.86, seed=3).packing


def _same_trace(a, b):
    for name in ("gamma", "energy", "shear_stress", "max_force", "pressure", "plastic"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_fire_ftol_float32_is_its_float64_value(packing):
    start = rescale(packing, 0.87)
    f32 = np.float32(1e-9)
    a = minimize(start, ftol=f32)
    b = minimize(start, ftol=float(f32))
    assert a.iterations == b.iterations
    np.testing.assert_array_equal(a.packing.positions, b.packing.positions)


def test_shear_dgamma_float32_is_its_float64_value(packing):
    d32 = np.float32(1e-4)
    a = shear(packing, d32, n_steps=12)
    b = shear(packing, float(d32), n_steps=12)
    assert a.trace.gamma.dtype == np.float64
    _same_trace(a.trace, b.trace)
    # the strains are n·δγ in float64, not float32 arithmetic
    np.testing.assert_array_equal(a.trace.gamma, np.arange(13) * float(d32))


def test_fixed_pressure_float32_arguments(packing):
    p32, t32 = np.float32(1e-3), np.float32(1e-5)
    a = shear(packing, t32, n_steps=4, pressure=p32)
    b = shear(packing, float(t32), n_steps=4, pressure=float(p32))
    _same_trace(a.trace, b.trace)
    np.testing.assert_array_equal(a.trace.phi, b.trace.phi)


def test_enthalpy_float32_target(packing):
    a = minimize_enthalpy(packing, np.float32(1e-3), ptol=np.float32(1e-6))
    b = minimize_enthalpy(packing, float(np.float32(1e-3)), ptol=float(np.float32(1e-6)))
    assert a.converged and b.converged
    assert a.pressure == b.pressure
    np.testing.assert_array_equal(a.packing.positions, b.packing.positions)


def test_jam_float32_target():
    a = jam(16, 2, seed=1, p_target=np.float32(1e-3), ftol=np.float32(1e-12))
    b = jam(16, 2, seed=1, p_target=float(np.float32(1e-3)), ftol=float(np.float32(1e-12)))
    assert type(a.params["p_target"]) is float
    assert a.params == b.params
    np.testing.assert_array_equal(a.packing.positions, b.packing.positions)


@pytest.mark.parametrize(
    "call",
    [
        lambda p: minimize(p, ftol=True),
        lambda p: shear(p, 1e-4, n_steps=2, ftol=True),
        lambda p: minimize_enthalpy(p, True),
        lambda p: rescale(p, True),
        lambda p: random_packing(16, 2, True, 0),
        lambda p: jam(16, 2, seed=1, p_target=True),
    ],
)
def test_bool_is_not_a_number(packing, call):
    with pytest.raises(ValueError, match="True"):
        call(packing)
