"""FIRE energy minimisation at fixed strain, the whole loop in compiled code.

FIRE 2.0: J. Guénolé, W. G. Nöhring, A. Vaid, F. Houllé, Z. Xie, A. Prakash, E. Bitzek,
Comput. Mater. Sci. 175, 109584 (2020), Algorithm 2 (semi-implicit Euler, initial delay, half step
back on ``P = F·v ≤ 0``). FIRE (original): E. Bitzek, P. Koskinen, F. Gähler, M. Moseler,
P. Gumbsch, Phys. Rev. Lett. 97, 170201 (2006). Unit masses.

Default parameters are the papers' standard ones, in units of the time step ``Δt₀ = 0.1`` used
for the LAMMPS reference data (``timestep 0.1``): ``Δt_min = 0.02 Δt₀``, ``N_delay = 20``,
``f_inc = 1.1``, ``f_dec = 0.5``, ``α₀ = 0.25``, ``f_α = 0.99``, ``N⁻_max = 2000``, and a cap
``dmax = 0.1`` on any particle's displacement per step (as LAMMPS) — except ``Δt_max = 3 Δt₀ = 0.3``
(the papers and LAMMPS use ``10 Δt₀``). For ``V = (1 − r)²`` (the default pair law) the pair
stiffness is ``V'' = 2``, so the largest Hessian eigenvalue is at most ``2·2·z_max`` (Gershgorin)
and ``ω_max ≤ 2√z_max ≈ 6.9`` in 3D (``z_max = 12``); in practice ``ω_max ≈ 5–6``. Semi-implicit
Euler is stable for ``Δt < 2/ω_max ≈ 0.3–0.4``: with ``Δt_max = 1`` FIRE runs unstable and relies
on its ``P ≤ 0`` restarts, which near jamming stalls (measured in ``docs/spheres.md``: N = 1000
near jamming, no convergence to 1e-12 in 2e5 steps with ``Δt_max = 1``, 1.3e4–1e5 steps with 0.3;
at φ = 0.8, 2.9× fewer steps). In ``d ≥ 4`` (``z_max = 24`` → ``2/ω_max ≈ 0.2``) a smaller
``dt_max`` may pay.

Converged when the largest per-particle force ``max_i |F_i| < ftol`` (a maximum, not a norm).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from jamlab import validation
from jamlab.spheres import kernels as K
from jamlab.spheres.box import Box
from jamlab.spheres.kernel_choice import threshold_for
from jamlab.spheres.neighbors import DEFAULT_SKIN, NeighborList
from jamlab.spheres.potential import Evaluation, evaluate
from jamlab.spheres.state import Packing

__all__ = ["FireParameters", "MinimizeResult", "POLISH_RUNS", "kernel_arguments", "minimize",
           "polish_reading"]


@dataclass(frozen=True)
class FireParameters:
    """FIRE parameters (see the module docstring); ``variant`` is ``"fire2"`` or ``"fire"``."""

    dt: float = 0.1
    dt_max: float = 0.3
    dt_min: float = 0.002
    n_delay: int = 20
    f_inc: float = 1.1
    f_dec: float = 0.5
    alpha0: float = 0.25
    f_alpha: float = 0.99
    n_negative_max: int = 2000
    dmax: float = 0.1
    variant: str = "fire2"

    def __post_init__(self) -> None:
        if self.variant not in ("fire2", "fire"):
            raise ValueError(f"variant must be 'fire2' or 'fire', got variant={self.variant!r}")
        for name in ("dt", "dt_max", "dt_min", "f_inc", "f_dec", "alpha0", "f_alpha"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"FIRE parameter {name} must be finite and > 0, got {value!r}")
        if not self.dt_min <= self.dt <= self.dt_max:
            raise ValueError(
                f"need dt_min <= dt <= dt_max, got {self.dt_min}, {self.dt}, {self.dt_max}"
            )


@dataclass(frozen=True, eq=False)
class MinimizeResult:
    """Outcome of :func:`minimize`.

    ``packing`` holds the final positions (a periodic representative, wrapped into the box at
    the last neighbour-list rebuild; ``packing.wrapped()`` maps them in), ``energy`` the total
    energy there, ``max_force = max_i |F_i|``, ``converged`` whether ``max_force < ftol`` was
    reached (False when ``max_iter`` ran out or FIRE stalled), ``iterations`` the number of FIRE
    steps, ``time`` the wall-clock seconds spent, ``n_rebuilds`` the neighbour-list rebuilds.
    """

    packing: Packing
    energy: float
    max_force: float
    iterations: int
    converged: bool
    time: float
    ftol: float
    n_rebuilds: int = 0

    def __repr__(self) -> str:
        return (
            f"MinimizeResult(converged={self.converged}, iterations={self.iterations}, "
            f"energy={self.energy!r}, max_force={self.max_force:.3e}, time={self.time:.3f}s)"
        )


def kernel_arguments(
    pos: np.ndarray,
    box: Box,
    neighbors: NeighborList,
    ftol: float,
    max_iter: int,
    params: FireParameters,
) -> tuple:
    """The arguments of the compiled loop :func:`jamlab.spheres.kernels.fire` for the positions
    ``pos`` (in ``neighbors``' order, wrapped into ``box``), as :func:`minimize` passes them."""
    return (
        pos,
        float(box.length),
        float(box.strain),
        float(neighbors.skin),
        float(neighbors.sigma_max),
        float(neighbors.budget(box.strain)),
        neighbors.start,
        neighbors.nbr,
        neighbors.shift,
        neighbors.img_y,
        neighbors.affine_reference(),
        neighbors.diameters,
        neighbors.alpha,
        float(ftol),
        int(max_iter),
        float(params.dt),
        float(params.dt_max),
        float(params.dt_min),
        int(params.n_delay),
        float(params.f_inc),
        float(params.f_dec),
        float(params.alpha0),
        float(params.f_alpha),
        int(params.n_negative_max),
        float(params.dmax),
        params.variant == "fire2",
        threshold_for(neighbors.nbr.size, pos.shape[1], neighbors.alpha),
    )


def kernel_start(
    packing: Packing, neighbors: NeighborList | None = None, skin: float = DEFAULT_SKIN
) -> tuple[np.ndarray, NeighborList]:
    """The positions the compiled FIRE loop starts from, in the list's order, and the list:
    ``packing``'s positions wrapped into the box and a fresh list of ``skin``, or ``neighbors``
    updated to them (it must match the packing's box, particle number and pair law). As
    :func:`minimize` prepares its run; for code that calls a FIRE kernel itself (with
    :func:`kernel_arguments`), e.g. the probes of ``scripts/``."""
    box = packing.box
    pos = np.array(packing.positions, dtype=np.float64, order="C")
    if neighbors is None:
        K.wrap_positions(pos, box.length, box.strain)
        neighbors = NeighborList(packing.with_positions(pos), skin=skin)
    else:
        if not neighbors.matches(packing):
            raise ValueError(
                "neighbour list belongs to a different box, particle number or pair law"
            )
        neighbors.update(pos, box.strain)
    return neighbors.sorted(pos), neighbors


def minimize(
    packing: Packing,
    ftol: float = 1e-12,
    max_iter: int = 1_000_000,
    params: FireParameters | None = None,
    neighbors: NeighborList | None = None,
    skin: float = DEFAULT_SKIN,
) -> MinimizeResult:
    """Minimise the energy at fixed box and strain with FIRE until ``max_i |F_i| < ftol``.

    ``neighbors`` (optional) is a :class:`NeighborList` to reuse, e.g. across AQS steps; it is
    updated in place to the final positions. Non-convergence is reported in the result
    (``converged=False``), not raised: callers must check it.
    """
    if not (validation.is_real(ftol) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    ftol = float(ftol)
    if not (validation.is_integer(max_iter) and 0 <= max_iter <= validation.MAX_ITER):
        raise ValueError(f"max_iter must be an integer in [0, {validation.MAX_ITER}], "
                         f"got max_iter={max_iter!r}")
    params = FireParameters() if params is None else params
    t0 = time.perf_counter()
    box = packing.box
    pos, neighbors = kernel_start(packing, neighbors, skin)
    out = K.fire(*kernel_arguments(pos, box, neighbors, ftol, max_iter, params))
    iterations, fmax, converged, energy, n_rebuild, start, nbr, shift, img_y, ref = out
    if n_rebuild > 0:
        neighbors.adopt(start, nbr, shift, img_y, ref, box.strain)
        neighbors.n_builds += int(n_rebuild) - 1
    elapsed = time.perf_counter() - t0
    final = replace(packing, positions=neighbors.unsorted(pos), check_coincidence=False)
    return MinimizeResult(
        packing=final,
        energy=float(energy),
        max_force=float(fmax),
        iterations=int(iterations),
        converged=bool(converged),
        time=elapsed,
        ftol=float(ftol),
        n_rebuilds=int(n_rebuild),
    )


POLISH_RUNS = 2
"""FIRE runs at most per minimum in :func:`polish_reading`."""


def polish_reading(
    result: MinimizeResult,
    read: float,
    max_iter: int = 1_000_000,
    params: FireParameters | None = None,
    accept: Callable[[Evaluation], bool] | None = None,
) -> tuple[MinimizeResult, Evaluation | None, int]:
    """``result`` converged as a reader of its packing sees it: ``(result, evaluation, runs)``.

    :func:`minimize` tests ``max_i |F_i| < ftol`` with its own neighbour list; a reader (a
    trace, a file read back, :func:`jamlab.spheres.potential.evaluate`) builds its own, which
    maps the positions into the box along the sheared images, and in a sheared box the
    separations then round differently: the forces differ by ~1e-15 (measured 5–7e-15 at N =
    128, p = 1e-6, γ = 1e-5 … 5e-5; ≤ 1e-21 at γ = 0). So a minimum accepted just below ``ftol``
    can read just above it (measured: 4 of 26,026 fixed-pressure minima of
    ``data/runs/n500-p1e-6-vg`` read 1.00007–1.00099e-12 at ``ftol = 1e-12``). ``read`` is the
    caller's fresh reading of ``max_i |F_i|`` on ``result.packing``. While the result is
    converged and reads ``≥ ftol``, FIRE relaxes it again at fixed box to ``ftol / 2`` (a margin
    far above the rounding; ``max_iter`` and ``params`` per run), at most :data:`POLISH_RUNS`
    times, and its packing is evaluated afresh (``evaluation``; None when nothing ran). The
    result stays converged only if its reading is ``< ftol`` and ``accept(evaluation)`` holds
    (e.g. a pressure within tolerance). A result that is not converged, or reads ``< ftol``, is
    returned as it is (``runs = 0``). The returned result's ``max_force`` is the reading,
    ``ftol`` the caller's, ``iterations`` and ``time`` include the polish."""
    ftol = result.ftol
    runs, ev = 0, None
    while result.converged and read >= ftol and runs < POLISH_RUNS:
        runs += 1
        out = minimize(result.packing, 0.5 * ftol, max_iter, params)
        ev = evaluate(out.packing)
        read = ev.max_force
        result = replace(
            out,
            max_force=read,
            ftol=ftol,
            iterations=result.iterations + out.iterations,
            time=result.time + out.time,
            n_rebuilds=result.n_rebuilds + out.n_rebuilds,
            converged=bool(out.converged and read < ftol and (accept is None or accept(ev))),
        )
    if result.converged and read >= ftol:
        result = replace(result, converged=False)
    return result, ev, runs
