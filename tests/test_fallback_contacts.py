"""``scripts/fallback_contacts.py``: the wrapped run is the plain run (same rows, wrappers
restored), and each fallback's contact changes and displacements against a brute-force recount
(all pairs, minimum image, contact where the distance is below the diameter)."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import script_module

import jamlab.spheres.newton_relax as nr
import jamlab.spheres.pressure_shear as ps


def brute_contacts(packing) -> set[tuple[int, int]]:
    i, j = np.triu_indices(packing.n, 1)
    r = np.linalg.norm(packing.box.minimum_image(packing.positions[i] - packing.positions[j]),
                       axis=1)
    touching = r < 0.5 * (packing.diameters[i] + packing.diameters[j])
    return set(zip(i[touching].tolist(), j[touching].tolist(), strict=True))


def test_fallbacks_against_a_recount_and_the_plain_run(tmp_path, capsys):
    fc = script_module("fallback_contacts")
    argv = ["--n", "64", "--steps", "60", "--pressure", "1e-3", "--dgamma", "1e-4",
            "--cache", str(tmp_path)]
    a = fc.parse_sample_arguments(fc.__doc__, argv)
    packing = fc.sample_start(a)
    newton = nr.damped_newton
    run, rows, n_fire = fc.fallbacks(packing, a.dgamma, a.pressure, a.steps)
    assert nr.damped_newton is newton  # restored
    plain = ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps)
    assert run.columns.keys() == plain.columns.keys()
    for key, column in plain.columns.items():
        np.testing.assert_array_equal(np.asarray(run.columns[key]), np.asarray(column))
    assert 0 < len(rows) <= n_fire
    for r in rows:
        before, after = brute_contacts(r.start), brute_contacts(r.minimum)
        assert (r.lost, r.gained) == (len(before - after), len(after - before))
        d = r.minimum.positions - r.start.positions
        d -= np.round(d / r.start.box.length) * r.start.box.length  # the same box, small moves
        norms = np.linalg.norm(d, axis=1)
        assert r.max_dx == pytest.approx(norms.max(), rel=1e-9)
        assert r.rms_dx == pytest.approx(np.sqrt(np.mean(norms**2)), rel=1e-9)
        assert r.reason
    assert fc.main(argv) == 0
    out = capsys.readouterr().out
    assert f"{len(rows)} after a failed Newton run" in out and "| contacts lost |" in out
