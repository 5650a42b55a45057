"""Athermal quasi-static (AQS) simple shear with linear-response elastic steps.

Protocol (``SPEC.md`` §3): from a minimum at strain ``γ_n``, shear affinely ``x_i += δγ y_i``,
``γ_{n+1} = γ_n + δγ``, and minimise the energy at fixed strain. Recorded per step: see
:mod:`jamlab.spheres.trace`.

Fast elastic steps (``minimizer="linear"``). Let ``H`` be the Hessian at the minimum ``x_n``
restricted to the *backbone* (rattlers removed, :func:`~jamlab.spheres.potential.remove_rattlers`)
with one backbone particle pinned (removing the ``d`` global translations), ``K = H[b,b]``,
factorised with SuperLU in symmetric mode (no row pivoting, METIS nested-dissection order), so
that ``K = L D Lᵀ`` and the pivots ``D`` have the signs of the eigenvalues of ``K`` (Sylvester's
law of inertia): all pivots ``> 0`` ⇔ ``K`` positive definite. The factorisation is reused over
many steps; contacts that open or close since are added to it as rank-one (Woodbury)
corrections (:class:`Factor`), and it is redone after plastic steps, backbone changes, failures
and periodically (``docs/aqs.md``). The step is the chord-Newton iteration

    x⁰ = x_n + δγ y e_x (affine),      x^{k+1} = x^k + K⁻¹ F_b(x^k),

whose first iterate is the linear-response prediction ``u = K⁻¹ F_b(x⁰) ≈ δγ K⁻¹ Ξ``
(``Ξ = ∂F/∂γ``, :func:`~jamlab.spheres.potential.dforce_dstrain`), iterated until
``max_i |F_i| < ftol`` on the backbone. Rattlers are held at their affinely moved positions during
the Newton solve; if their (contact) forces then exceed ``ftol`` FIRE relaxes the whole system from
there (it only moves rattlers in practice). The step is accepted as *elastic* when

1. the (damped) Newton iteration converges within ``max_newton`` iterations, every iteration
   lowering ``max |F_b|`` and, from the second on, at most ``max_strikes`` of them reducing it
   by less than the factor ``contraction`` (0.5);
2. it stays in the linear-response basin: the Newton corrections after the first step add up to
   at most ``linear_basin`` (0.5) times the linear prediction ``max_i |u_i|``;
3. the backbone Hessian at the new minimum is positive definite (all LDLᵀ pivots ``> 0``).

The common step is taken by :func:`lean_step`: the same chord iteration in the neighbour
list's order with one fused kernel per iterate (forces, virial, contact state per list slot),
a weighted least-squares predictor over the minima of the current smooth piece of the branch
(:class:`BranchPath`) and a multisecant correction from the recent chord steps before each solve
(:class:`Secants`); anything unusual hands the step to the general continuation below, so the
classification does not depend on which path took it.

If any test fails, the step goes to the general continuation of the branch ``x(γ)``
(``AQSParameters.continuation``). The default, ``"network"`` (:func:`continue_network`), is
event-driven: between contact changes the branch is the minimum of the smooth energy of the
current contact network (every backbone contact a harmonic spring, in tension too), followed by
Newton; a substep whose end shows a contact of the set in tension or a new overlap between
backbone particles is cut back to the first crossing (linear interpolation of the overlaps in
``γ``), the set is switched there at zero force, the backbone recomputed (a particle left with
``d`` contacts is a rattler: all its forces vanished together) and positive definiteness
re-tested (refactorisation, or inertia additivity of the rank-one changes). Rattlers are ghosts
on the way and are moved out of their overlaps at the end. ``"substep"``
(:func:`continue_substep`, the only one before the fourth session) halves the step
(``δγ/2, δγ/4, …``, doubling again after each success) with a fresh factorisation each time; near
jamming it is slow and its verdicts are wrong on some steps (``docs/aqs.md``). If the branch can
be continued to ``γ_{n+1}`` the step is elastic and the continued minimum is recorded; if it
cannot (the Hessian loses positive definiteness, at an event or inside a smooth piece, or Newton
fails even at substeps below ``δγ · min_substep``), the branch of ``x_n`` ends inside the step:
the step is *plastic* and FIRE minimises from the affinely sheared ``x_n``, carrying the
avalanche.

With ``minimizer="fire"`` every step is plain FIRE from the affinely sheared ``x_n``; the same
continuation (when ``classify=True``) then decides whether FIRE's minimum is the continuation of
``x_n`` (same energy and positions, :func:`same_minimum`).

``plastic[n]`` is therefore: *the recorded minimum at γ_n is not the continuation of the minimum
at γ_{n-1}* — the branch ended, or (plain FIRE only) FIRE left a branch that continues. This does
not look at the sign of ``ΔE``; see ``docs/aqs.md``. A minimum without a backbone (every
particle a rattler: unjammed, ``E ≈ 0``) has no branch to end; its steps are plain FIRE and
elastic.
"""

from jamlab.spheres.aqs.checkpoint import checkpoint_paths
from jamlab.spheres.aqs.driver import MINIMIZERS, ShearResult, n_steps_for, shear
from jamlab.spheres.aqs.parameters import AQSParameters

__all__ = [
    "MINIMIZERS",
    "AQSParameters",
    "ShearResult",
    "checkpoint_paths",
    "n_steps_for",
    "shear",
]
