"""One rule for the numbers a library function takes (``validation.is_integer``, ``is_real``):
a count takes a Python or numpy integer, never a ``bool`` (``True`` had been read as 1), a float
or a string; a real number takes a Python or numpy integer or float, never a ``bool`` or a
string. A refusal is a one-line ``ValueError`` naming the argument, not a ``TypeError`` from
inside the computation; a numpy integer gives the result of the same Python integer.

The functions below had their own checks (``isinstance(x, int)``, ``int | np.integer``,
``int | float``), which refused a numpy integer, or accepted a ``bool``, or both.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from jamlab import warmup
from jamlab.analysis import avalanches, exponent_fit, finite_size, order, shape_test
from jamlab.analysis.rate_collapse import rate_collapse
from jamlab.reproduce import measurements
from jamlab.spheres import barostat, compression, fire, packing, state
from jamlab.spheres.aqs import AQSParameters
from jamlab.spheres.box import Box

RNG = np.random.default_rng(7)
SIZES = {n: [RNG.pareto(0.4, 60) + 1.0 for _ in range(4)] for n in (64, 128)}
JUMPS = RNG.exponential(1.0, 12)
POSITIONS = RNG.random((8, 3)) * 3.0


def small_packing():
    return state.random_packing(16, 3, 0.7, 3)


COUNTS = {
    "fire.minimize max_iter": lambda v: fire.minimize(small_packing(), max_iter=v),
    "barostat max_volume_steps": lambda v: barostat.minimize_enthalpy(
        small_packing(), 1e-2, max_volume_steps=v),
    "jam max_restarts": lambda v: packing.jam(16, 3, 1, 1e-4, max_restarts=v),
    "jam max_minimizations": lambda v: packing.jam(16, 3, 1, 1e-4, max_minimizations=v),
    "compression steps": lambda v: compression.compression_schedule(0.64, 1e-4, 1e-2, v),
    "random_packing n": lambda v: state.random_packing(v, 3, 0.5, 1),
    "coarsen_steps k": lambda v: avalanches.coarsen_steps(JUMPS, JUMPS, 1e-4, v),
    "fit_exponent n_boot": lambda v: exponent_fit.fit_exponent(SIZES[64], (2.0, 50.0),
                                                               n_boot=v),
    "fit_exponent n_points": lambda v: exponent_fit.fit_exponent(SIZES[64], (2.0, 50.0),
                                                                 n_boot=0, n_points=v),
    "fit_cutoff_scaling n_boot": lambda v: finite_size.fit_cutoff_scaling(SIZES, n_boot=v),
    "fit_joint_scaling n_boot": lambda v: finite_size.fit_joint_scaling(SIZES, 1.0, n_boot=v),
    "fit_joint_scaling min_tail": lambda v: finite_size.fit_joint_scaling(
        SIZES, 1.0, n_boot=2, min_tail=v),
    "rate_collapse least": lambda v: rate_collapse(SIZES, 1.0, 1.0, least=v),
    "rate_collapse boot": lambda v: rate_collapse(SIZES, 1.0, 1.0, boot=v),
    "bond_order l": lambda v: order.bond_order(POSITIONS, 3.0, l=v),
    "converged_window min_tail": lambda v: measurements.converged_window(
        SIZES[64][0], SIZES[64][1], 1.0, min_tail=v),
    "warmup jobs": lambda v: warmup.warmup(jobs=v),
}


@pytest.mark.parametrize("bad", [True, 2.0, "2"], ids=["bool", "float", "str"])
@pytest.mark.parametrize("case", sorted(COUNTS))
def test_a_count_refuses_bool_float_and_string(case, bad):
    """Each refusal happens before any work (``jam``, ``warmup`` would otherwise run for
    seconds) and names the argument."""
    name = case.split()[-1]
    with pytest.raises(ValueError, match=name if name != "n" else "particles"):
        COUNTS[case](bad)


@pytest.mark.parametrize("case, value", [
    ("fire.minimize max_iter", 40),
    ("compression steps", 5),
    ("random_packing n", 12),
    ("coarsen_steps k", 3),
    ("fit_exponent n_boot", 20),
    ("bond_order l", 4),
])
def test_a_numpy_count_gives_the_python_count_result(case, value):
    a, b = COUNTS[case](value), COUNTS[case](np.int64(value))
    assert type(a) is type(b)
    if isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
        return
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "time":
            continue
        if isinstance(x, state.Packing):
            np.testing.assert_array_equal(x.positions, y.positions)
        elif isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            assert x == y or (x != x and y != y), f.name


@pytest.mark.parametrize("name", [f.name for f in dataclasses.fields(AQSParameters)
                                  if f.type == "int"])
def test_aqs_parameters_counts(name):
    """Every integer field of the fast path's parameters takes a numpy integer (stored as a
    Python int: the parameters are written to manifests) and refuses a bool, a float and a
    negative count (``max_chord=-1`` never met its ``its == max_chord`` exit)."""
    default = getattr(AQSParameters(), name)
    p = AQSParameters(**{name: np.int64(default)})
    assert p == AQSParameters() and type(getattr(p, name)) is int
    for bad in (True, float(default), -1):
        with pytest.raises(ValueError, match=name):
            AQSParameters(**{name: bad})


@pytest.mark.parametrize("name", [f.name for f in dataclasses.fields(AQSParameters)
                                  if f.type == "float"])
def test_aqs_parameters_reals(name):
    default = getattr(AQSParameters(), name)
    p = AQSParameters(**{name: np.float64(default)})
    assert p == AQSParameters() and type(getattr(p, name)) is float
    for bad in (True, str(default), float("inf"), float("nan")):
        with pytest.raises(ValueError, match=name):
            AQSParameters(**{name: bad})


@pytest.mark.parametrize("kwargs, name", [
    ({"length": True}, "length"),
    ({"length": "3.0"}, "length"),
    ({"length": 3.0, "strain": True}, "strain"),
    ({"length": 3.0, "strain": "0.1"}, "strain"),
])
def test_box_refuses_bool_and_string(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Box(**kwargs)


def test_box_widens_numpy_reals():
    b = Box(np.float32(3.5), 3, np.float16(0.25))
    assert (b.length, b.strain) == (3.5, 0.25)
    assert type(b.length) is float and type(b.strain) is float


@pytest.mark.parametrize("call", [
    lambda v: rate_collapse(SIZES, 1.0, v),
    lambda v: rate_collapse(SIZES, v, 1.0),
    lambda v: shape_test.clustered_shape_test(SIZES, v),
], ids=["rate_collapse s_min", "rate_collapse strain", "clustered_shape_test floor"])
def test_reals_refuse_bool(call):
    with pytest.raises(ValueError):
        call(True)


@pytest.mark.parametrize("dim", [1, 65, True])
def test_box_dimension_in_range(dim):
    """A configuration file with 65 coordinates per line was imported and then failed every
    reader with numpy's "array is too big"; the limit of the command line (``MAX_DIM``) now
    holds for every box."""
    with pytest.raises(ValueError, match="dimension"):
        Box(5.0, dim)
