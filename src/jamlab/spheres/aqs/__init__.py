"""Athermal quasi-static (AQS) simple shear with linear-response elastic steps.

Protocol (``SPEC.md`` §3): from a minimum at strain ``γ_n``, shear affinely ``x_i += δγ y_i``,
``γ_{n+1} = γ_n + δγ``, and minimise the energy at fixed strain. Recorded per step: see
:mod:`jamlab.spheres.trace`.

Fast elastic steps (``minimizer="linear"``). Let ``H`` be the Hessian at the minimum ``x_n``
restricted to the *backbone* (rattlers removed, :func:`~jamlab.spheres.potential.remove_rattlers`)
with one backbone particle pinned (removing the ``d`` global translations), ``K = H[b,b]``,
factorised by CHOLMOD's supernodal Cholesky (METIS nested-dissection order), which succeeds
exactly where ``K`` is positive definite (where it fails, SuperLU's ``K = L D Lᵀ`` without row
pivoting, whose pivots ``D`` have the signs of the eigenvalues of ``K`` by Sylvester's law of
inertia; :mod:`jamlab.spheres.aqs.linalg`). The factorisation is reused over
many steps; contacts that open or close since are added to it as rank-one (Woodbury)
corrections, whose positive definiteness is decided by inertia additivity
(:class:`~jamlab.spheres.aqs.linalg.Factor`), and it is redone after plastic steps, backbone
changes, failures and periodically (``docs/aqs.md``).

The common step is the *lean step* (:func:`~jamlab.spheres.aqs.lean.lean_step`): the chord
iteration ``x^{k+1} = x^k + K⁻¹ F_b(x^k)`` from the affinely sheared ``x_n`` plus a predicted
non-affine displacement (a weighted least-squares fit over the minima of the current smooth
piece of the branch, :class:`~jamlab.spheres.aqs.predictor.BranchPath`, and a multisecant
correction from recent chord steps, :class:`~jamlab.spheres.aqs.predictor.Secants`), one fused
kernel per iterate, until ``max_i |F_i| < ftol``. It is accepted as elastic when every chord
step contracts the force, the backbone does not change, no rattler is left with a force, and
the trapezoid residual ``|ΔE − ½ δγ (Σ_n + Σ_{n+1})|`` stays below ``energy_tol δγ²``.

Anything unusual hands the step to the continuation of the branch ``x(γ)``
(:func:`~jamlab.spheres.aqs.continuation.continue_network`), so the classification does not
depend on which path took it. It is event-driven: between contact changes the branch is the
minimum of the smooth energy of the current contact network (every backbone contact a harmonic
spring, in tension too), found by damped Newton (:func:`~jamlab.spheres.aqs.newton.damped_newton`);
a substep whose end shows a contact of the set in tension or a new overlap between backbone
particles is cut back to the first crossing (linear interpolation of the overlaps in ``γ``), the
set is switched there at zero force, the backbone recomputed (a particle left with ``d``
contacts is a rattler: all its forces vanished together) and positive definiteness re-tested
(refactorisation, or inertia additivity of the rank-one changes). Rattlers are ghosts on the
way and are moved out of their overlaps at the end. If the branch can be continued to
``γ_{n+1}`` the step is elastic and the continued minimum is recorded; if it cannot (the
Hessian loses positive definiteness at an event, or Newton fails even at substeps below
``δγ · min_substep``), the branch of ``x_n`` ends inside the step: the step is *plastic* and
FIRE minimises from the affinely sheared ``x_n``, carrying the avalanche.

With ``minimizer="fire"`` every step is plain FIRE from the affinely sheared ``x_n``; the same
continuation (when ``classify=True``) then decides whether FIRE's minimum is the continuation of
``x_n`` (same energy and positions, :func:`~jamlab.spheres.aqs.classify.same_minimum`).

``plastic[n]`` is therefore: *the recorded minimum at γ_n is not the continuation of the minimum
at γ_{n-1}* — the branch ended, or (plain FIRE only) FIRE left a branch that continues. This does
not look at the sign of ``ΔE``; see ``docs/aqs.md``. A minimum without a backbone (every
particle a rattler: unjammed, ``E ≈ 0``) has no branch to end; its steps are plain FIRE and
elastic.

Modules: :mod:`~jamlab.spheres.aqs.driver` (:func:`shear`, the loop) delegates each step to a
strategy in :mod:`~jamlab.spheres.aqs.steps`; below them :mod:`~jamlab.spheres.aqs.lean`,
:mod:`~jamlab.spheres.aqs.continuation`, :mod:`~jamlab.spheres.aqs.newton`,
:mod:`~jamlab.spheres.aqs.predictor`, :mod:`~jamlab.spheres.aqs.classify`,
:mod:`~jamlab.spheres.aqs.linalg`, :mod:`~jamlab.spheres.aqs.network`; the trace rows in
:mod:`~jamlab.spheres.aqs.record`, saving in :mod:`~jamlab.spheres.aqs.checkpoint`, the
tolerances in :mod:`~jamlab.spheres.aqs.parameters`.
"""

from jamlab.spheres.aqs.checkpoint import checkpoint_paths, resume_configuration
from jamlab.spheres.aqs.driver import MINIMIZERS, ShearResult, n_steps_for, shear
from jamlab.spheres.aqs.parameters import AQSParameters

__all__ = [
    "MINIMIZERS",
    "AQSParameters",
    "ShearResult",
    "checkpoint_paths",
    "n_steps_for",
    "resume_configuration",
    "shear",
]
