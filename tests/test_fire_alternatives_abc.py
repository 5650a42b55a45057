"""``scripts/fire_alternatives.py abc``: its FIRE 2.0 baseline must be jamlab's FIRE to the last
bit, its ABC copy must differ only by the mixing and still reach ``ftol`` (checked by an
independent force evaluation); and ``newton_vs_fire_pressure.print_size_comparison`` must say
when there are too few sizes to fit instead of failing."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module

from jamlab.spheres import kernels as K
from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.neighbors import RELAX_SKIN
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import forces


@pytest.fixture(scope="module")
def start():
    pk = jam(64, 3, seed=5, p_target=1e-4).packing
    rng = np.random.default_rng(3)
    return pk.with_positions(pk.positions + 2e-3 * rng.standard_normal(pk.positions.shape))


def test_baseline_is_fire(start):
    probe = script_module("fire_alternatives")
    ref = minimize(start, ftol=1e-12, skin=RELAX_SKIN)
    its, conv, e, _, x = probe.run_kernel(K.fire, start, 1e-12, FireParameters(), 1_000_000)
    assert ref.converged and conv
    assert its == ref.iterations and e == ref.energy
    assert np.array_equal(x, ref.packing.positions)


def test_abc_copy_converges_and_differs(start):
    probe = script_module("fire_alternatives")
    kernel = probe.abc_kernel()
    ref = minimize(start, ftol=1e-12, skin=RELAX_SKIN)
    its, conv, e, _, x = probe.run_kernel(kernel, start, 1e-12, FireParameters(), 1_000_000)
    assert conv
    fmax = float(np.max(np.linalg.norm(forces(start.with_positions(x)), axis=1)))
    assert fmax < 1e-12
    assert its != ref.iterations  # the edit took effect
    assert e == pytest.approx(ref.energy, rel=1e-6)


def test_size_comparison_with_few_sizes(capsys):
    probe = script_module("newton_vs_fire_pressure")
    sizes = {"a": np.geomspace(1e-9, 1e-7, 10), "b": np.geomspace(1e-9, 1e-7, 12)}
    probe.print_size_comparison(sizes, "a", "b")
    out = capsys.readouterr().out
    assert "two-sample KS" in out
    assert "tau not fitted: 12 reference sizes, fewer than 50" in out


def test_size_comparison_of_one_sample_with_itself(capsys):
    probe = script_module("newton_vs_fire_pressure")
    x = 1e-9 * (1.0 - np.random.default_rng(4).random(400)) ** (-1.0 / 0.5)  # τ = 1.5
    probe.print_size_comparison({"a": x, "b": x.copy()}, "a", "b")
    out = capsys.readouterr().out
    assert "p-value = 1.000" in out and "difference 0.000 = 0.00 sigma" in out
