"""The probes' copies of the compiled FIRE loop (``scripts/kernel_copy.py``: the kernel's source
with lines edited in) against the package's FIRE: the line-search probe's
(``scripts/fire_line_probe.py``) without line searches, and the unjamming probe's counters
(``scripts/fire_unjamming_probe.py``), must retrace :func:`jamlab.spheres.fire.minimize` to the
last bit (a probe's baseline is only meaningful if its copy is FIRE); with line searches it must
still reach ``ftol``; an edit that no longer matches the kernel's text must fail loudly."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module

from jamlab.spheres.fire import FireParameters, minimize
from jamlab.spheres.neighbors import RELAX_SKIN
from jamlab.spheres.potential import forces


def test_copy_retraces_fire(fire_start):
    probe = script_module("fire_line_probe")
    ref = minimize(fire_start, ftol=1e-12, skin=RELAX_SKIN)
    (its, fmax, conv, e, evals, jumps, _), pos = probe.run_lines(fire_start, 1e-12, False)
    assert ref.converged and conv
    assert its == ref.iterations and evals == 0 and jumps == 0
    assert e == ref.energy
    assert np.array_equal(pos, ref.packing.positions)


def test_counted_copy_retraces_fire(fire_start):
    probe = script_module("fire_unjamming_probe")
    ref = minimize(fire_start, ftol=1e-12, skin=RELAX_SKIN)
    its, fmax, conv, e, n_restart, n_small, trace = probe.run(
        probe.instrumented_fire(), fire_start, FireParameters(), 1e-12, 1_000_000)
    assert conv and its == ref.iterations and e == ref.energy
    # max|F| at iteration 1 is the fire_start's: the counters see the loop's own state
    assert trace[0] == pytest.approx(float(np.max(np.linalg.norm(forces(fire_start), axis=1))),
                                     rel=1e-12)
    assert 0 < n_restart < its and 0 <= n_small <= its


def test_stale_edit_fails_loudly():
    copy = script_module("kernel_copy")
    with pytest.raises(SystemExit, match="cannot place"):
        copy.edited_fire("fire_stale", [("    this line is not in the kernel\n", "")])


def test_lines_still_converge(fire_start):
    probe = script_module("fire_line_probe")
    saved = dict(probe.OPTS)
    probe.OPTS.update(every=20, cos=0.5)  # jump often
    try:
        (its, fmax, conv, e, evals, jumps, _), _ = probe.run_lines(fire_start, 1e-12, True)
    finally:
        probe.OPTS.clear()
        probe.OPTS.update(saved)
    assert conv and fmax < 1e-12
    assert jumps > 0 and evals >= jumps


def test_line_search_returns_to_the_minimum_along_its_line(jam64_packing):
    """From a minimum moved back by δ along a unit direction ``u``, the force along ``u`` points
    to the minimum and vanishes there (harmonic at this δ): the line search of the ``line``
    variant (the compiled one on a fresh list) lands within its tolerance, ``|g| < g(0)/10``,
    i.e. within about 10 % of δ; and a direction with the force against it is refused."""
    probe = script_module("fire_line_probe")
    pk0 = minimize(jam64_packing, ftol=1e-13, skin=RELAX_SKIN).packing
    u = np.random.default_rng(2).standard_normal(pk0.positions.shape)
    u /= np.linalg.norm(u)
    delta = 1e-4
    start = pk0.with_positions(pk0.positions - delta * u)
    counts = {"evaluations": 0}
    moved = probe.line_search(start, u, 0.3 * delta, counts)
    assert moved is not None and counts["evaluations"] >= 3
    s = float(np.sum((moved.positions - start.positions) * u))
    assert abs(s - delta) < 0.12 * delta
    assert probe.line_search(start, -u, 0.3 * delta, counts) is None
