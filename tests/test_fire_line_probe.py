"""The line-search probe's own FIRE loop (``scripts/fire_line_probe.py``) against the package's
FIRE: without line searches it must retrace :func:`jamlab.spheres.fire.minimize` (the probe's
baseline is only meaningful if its copy is FIRE), and with them still reach ``ftol``."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module

from jamlab.spheres.fire import minimize
from jamlab.spheres.neighbors import RELAX_SKIN
from jamlab.spheres.packing import jam


@pytest.fixture(scope="module")
def start():
    pk = jam(64, 3, seed=5, p_target=1e-4).packing
    rng = np.random.default_rng(1)
    return pk.with_positions(pk.positions + 2e-3 * rng.standard_normal(pk.positions.shape))


def test_copy_retraces_fire(start):
    probe = script_module("fire_line_probe")
    ref = minimize(start, ftol=1e-12, skin=RELAX_SKIN)
    (its, fmax, conv, e, evals, jumps, _), pos = probe.run_lines(start, 1e-12, False)
    assert ref.converged and conv
    assert its == ref.iterations and evals == 0 and jumps == 0
    assert e == pytest.approx(ref.energy, rel=1e-12, abs=1e-20)
    dx = start.box.minimum_image(pos - ref.packing.positions)
    assert float(np.max(np.abs(dx))) < 1e-9


def test_lines_still_converge(start):
    probe = script_module("fire_line_probe")
    saved = dict(probe.OPTS)
    probe.OPTS.update(every=20, cos=0.5)  # jump often
    try:
        (its, fmax, conv, e, evals, jumps, _), _ = probe.run_lines(start, 1e-12, True)
    finally:
        probe.OPTS.clear()
        probe.OPTS.update(saved)
    assert conv and fmax < 1e-12
    assert jumps > 0 and evals >= jumps
