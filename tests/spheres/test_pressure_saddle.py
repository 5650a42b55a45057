"""Saddles at fixed pressure (issue 18): a point where FIRE stopped with ``max|F| < ftol`` at the
target pressure but that is not a minimum is pushed off and minimised again
(:func:`jamlab.spheres.barostat.leave_saddle`).

The fixture ``tests/data/saddle/fixed-pressure-n250-p1e-6.h5`` is such a point, recorded as a
minimum (step 193 of sample 0 of ``jamlab run --phi jamming --n 250 --samples 20 --dgamma 1e-5
--gamma-max 0.01 --pressure 1e-6``, before the fix). That it is a saddle is shown here by
energies alone: along one direction the energy at fixed box falls on both sides.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from jamlab.spheres.barostat import enthalpy, leave_saddle, minimize_enthalpy, pressure_tolerance
from jamlab.spheres.contacts import remove_rattlers
from jamlab.spheres.io import read_packing
from jamlab.spheres.newton_relax import NewtonRelaxer
from jamlab.spheres.potential import energy, hessian, max_force, pressure
from jamlab.spheres.pressure_shear import SADDLE_COUNT
from jamlab.spheres.rigidity import is_jammed

P_TARGET = 1e-6
FTOL = 1e-12
PATH = Path(__file__).resolve().parents[1] / "data" / "saddle" / "fixed-pressure-n250-p1e-6.h5"


@pytest.fixture(scope="module")
def saddle():
    return read_packing(PATH)


def backbone_spectrum(packing):
    """Eigenvalues and eigenvectors of the Hessian restricted to the backbone's coordinates
    (dense ``eigh``: independent of the sparse factorisation the code's test uses)."""
    keep = remove_rattlers(packing).mask
    coords = (packing.dim * np.flatnonzero(keep)[:, None] + np.arange(packing.dim)).ravel()
    h = hessian(packing, backbone=keep).toarray()[np.ix_(coords, coords)]
    w, v = np.linalg.eigh(h)
    return w, v, coords


def lowest_non_translation(w):
    """The lowest eigenvalue once the ``d`` translations (|λ| at rounding) are set aside."""
    return w[0] if w[0] < -1e-12 * abs(w[-1]) else w[3]


def test_the_fixture_passes_the_force_test_at_the_target_pressure(saddle):
    assert max_force(saddle) < FTOL
    assert abs(pressure(saddle) - P_TARGET) <= 1e-6 * P_TARGET
    state = is_jammed(saddle, FTOL)
    assert not state.jammed and state.excess == -1  # what the jammed flag saw: hypostatic


def test_the_fixture_is_a_saddle_by_energies_alone(saddle):
    """Along the lowest eigenvector ``v`` (unit norm) of the backbone Hessian, ``λ ≈ −3e-6``, the
    energy at fixed box falls by ``½ λ t²`` (to 5 %) on one side, ``t = 1e-5`` and ``1e-4``; at
    ``1e-4`` far more than the gradient could give (``t |F|``, ``|F| ≈ 4e-12``): no minimum.
    On the other side it rises at once: a backbone pair 4.4e-10 from touching closes (the
    unstable mode runs into a contact at touching; ``docs/aqs.md``)."""
    from jamlab.spheres.potential import forces

    w, v, coords = backbone_spectrum(saddle)
    lam = w[0]
    assert lam < -1e-8 * w[-1]  # resolved by the saddle rule (NEGATIVE_CURVATURE)
    e0 = energy(saddle)
    f_norm = float(np.linalg.norm(forces(saddle)))

    def change(t):
        pos = saddle.positions.copy().ravel()
        pos[coords] += t * v[:, 0]
        return energy(saddle.with_positions(pos.reshape(saddle.positions.shape))) - e0

    down = -1.0 if change(-1e-6) < change(1e-6) else 1.0
    for t in (1e-5, 1e-4):
        assert change(down * t) == pytest.approx(0.5 * lam * t * t, rel=0.05)
    assert change(down * 1e-4) < -10.0 * 1e-4 * f_norm
    assert change(-down * 1e-6) > 0


def test_leave_saddle_reaches_a_jammed_minimum_of_lower_enthalpy(saddle):
    kw = dict(ftol=FTOL, ptol=1e-6, max_iter=1_000_000, params=None, relax=NewtonRelaxer())
    res = minimize_enthalpy(saddle, P_TARGET, **kw)
    assert np.array_equal(res.packing.positions, saddle.positions)  # converged already
    out, pushes = leave_saddle(res, P_TARGET, kw, test=True)
    assert pushes >= 1 and out.converged
    new = out.packing
    assert max_force(new) < FTOL
    assert abs(pressure(new) - P_TARGET) <= pressure_tolerance(new, P_TARGET, FTOL, 1e-6)
    assert is_jammed(new, FTOL).jammed
    h_saddle = enthalpy(energy(saddle), P_TARGET, saddle)
    assert enthalpy(energy(new), P_TARGET, new) < h_saddle
    w, _, _ = backbone_spectrum(new)
    assert lowest_non_translation(w) > -1e-8 * w[-1]


def test_a_run_started_on_the_saddle_records_a_minimum(saddle):
    """``shear(..., pressure=p)`` from the saddle: row 0 is the minimum below it (jammed), and the
    trace counts the push; every row is jammed."""
    from jamlab.spheres.aqs import shear

    trace = shear(saddle, 1e-5, n_steps=3, pressure=P_TARGET, ftol=FTOL).trace
    assert trace.attrs[SADDLE_COUNT] >= 1
    assert np.all(trace.jammed)
    assert trace.energy[0] < enthalpy(energy(saddle), P_TARGET, saddle)
