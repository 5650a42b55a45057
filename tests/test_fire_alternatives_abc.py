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
from jamlab.spheres.potential import forces


def test_baseline_is_fire(fire_start):
    probe = script_module("fire_alternatives")
    ref = minimize(fire_start, ftol=1e-12, skin=RELAX_SKIN)
    its, conv, e, _, x = probe.run_kernel(K.fire, fire_start, 1e-12, FireParameters(), 1_000_000)
    assert ref.converged and conv
    assert its == ref.iterations and e == ref.energy
    assert np.array_equal(x, ref.packing.positions)


def test_abc_copy_converges_and_differs(fire_start):
    probe = script_module("fire_alternatives")
    kernel = probe.abc_kernel()
    ref = minimize(fire_start, ftol=1e-12, skin=RELAX_SKIN)
    its, conv, e, _, x = probe.run_kernel(kernel, fire_start, 1e-12, FireParameters(), 1_000_000)
    assert conv
    fmax = float(np.max(np.linalg.norm(forces(fire_start.with_positions(x)), axis=1)))
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
