"""``scripts/stress_precision.py``: the first-order stress change to the exact minimum,
``δΣ = −Ξ · H⁻¹F``, checked against a minimum displaced on purpose (the stress difference
computed directly), and the script's table on a small run."""

from __future__ import annotations

import numpy as np
import pytest
from tests.script_helpers import exit_code, script_module

from jamlab.spheres import potential
from jamlab.spheres.contacts import remove_rattlers
from jamlab.spheres.packing import jam


def test_the_stress_change_of_a_known_displacement():
    """Displace the backbone of a jammed minimum by ``ε`` (random, 1e-9): the residual forces
    grow by ``≈ −H ε`` and the predicted ``δΣ`` by ``Σ(minimum) − Σ(displaced)``, computed
    directly (the minimum's own ``δΣ``, from its residual forces below ``ftol``, is the
    baseline); the lowest eigenvalue is positive (a stable minimum)."""
    sp = script_module("stress_precision")
    res = jam(64, 3, 1, p_target=1e-4)
    assert res.ok
    minimum = res.packing
    keep = remove_rattlers(minimum).mask
    rng = np.random.default_rng(2)
    eps = 1e-9 * rng.standard_normal(minimum.positions.shape) * keep[:, None]
    displaced = minimum.with_positions(minimum.positions + eps)
    lam, fmax, d_sigma = sp.precision(displaced)
    base = sp.precision(minimum)
    direct = potential.shear_stress(minimum) - potential.shear_stress(displaced)
    assert lam > 0 and base[0] > 0 and fmax > 1e-12 > base[1]  # forces well above ftol now
    assert abs(direct) > 100 * abs(base[2])  # a change the check can see
    assert d_sigma - base[2] == pytest.approx(direct, rel=1e-3)


def test_the_table_and_a_refusal(monkeypatch, capsys):
    sp = script_module("stress_precision")
    assert sp.main(["--n", "64", "--pressure", "1e-3", "--steps", "3", "--seeds", "1"]) == 0
    rows = [r for r in capsys.readouterr().out.splitlines() if r.startswith("| 64 |")]
    assert len(rows) == 1
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert int(cells[3]) == 4 and float(cells[8]) < 1e-3  # 4 minima; the stress error is small
    assert exit_code(sp, ["--steps", "1"], monkeypatch) == 2
