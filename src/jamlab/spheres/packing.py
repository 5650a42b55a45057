"""Jammed and over-jammed (UNSAT) packings (``SPEC.md`` §3, §5).

Conventions are those of ``SPEC.md`` §3 and §5 (diameters ``D_i``, pair law
``V(r) = (1 − r/σ_ij)^α``, total energy ``E``, pressure ``p = −(1/(d L^d)) Σ_{i<j} V'(r_ij) r_ij``,
contacts ``r_ij < σ_ij``, ``z = 2N_c/N``, rattlers removed repeatedly when they have fewer than
``d + 1`` contacts, ``z_nr = 2N_c'/N'``, isostatic ``N_c' = d(N' − 1) + 1``:
:mod:`jamlab.spheres.describe`).

Minimisation: FIRE 2.0 with :data:`~jamlab.spheres.relax.JAM_FIRE` until ``max_i |F_i| < ftol``
(:mod:`jamlab.spheres.relax`). The jamming protocol (:func:`jam`, its search in
:mod:`jamlab.spheres.jam_search`) and its stopping rule are documented in ``docs/packings.md``.
The names of :mod:`~jamlab.spheres.relax`, :mod:`~jamlab.spheres.describe` and
:mod:`~jamlab.spheres.compression` are re-exported here.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

from jamlab import validation
from jamlab.spheres.compression import (
    CoordinationCurve,
    coordination_curve,
    fit_power_law,
    fit_power_law_corrected,
)
from jamlab.spheres.describe import PackingState, describe, isostatic_contacts, z_iso
from jamlab.spheres.jam_search import (
    PHI_MAX,
    MinimizationStep,
    ProgressCallback,
    quench_seed,
    run_attempt,
)
from jamlab.spheres.pair import HARMONIC, check_alpha
from jamlab.spheres.relax import JAM_FIRE, RelaxResult, compress_to, relax, rescale
from jamlab.spheres.rigidity import jammed_verdict, pressure_floor
from jamlab.spheres.state import Packing, parse_sizes, random_packing

__all__ = [
    "jam_at_pressure",
    "RelaxResult",
    "PackingState",
    "PreparedPacking",
    "CoordinationCurve",
    "JAM_FIRE",
    "JammingError",
    "MinimizationStep",
    "rescale",
    "relax",
    "compress_to",
    "describe",
    "isostatic_contacts",
    "z_iso",
    "jam",
    "prepare",
    "coordination_curve",
    "fit_power_law",
    "fit_power_law_corrected",
]


class JammingError(RuntimeError):
    """Raised by :func:`jam` with ``strict=True`` when the protocol fails; carries ``result``."""

    def __init__(self, result: PreparedPacking) -> None:
        super().__init__(result.reason)
        self.result = result


@dataclass(frozen=True, eq=False)
class PreparedPacking:
    """A prepared packing and how it was made.

    ``protocol`` is ``"jamming"`` (:func:`jam`) or ``"direct"`` (:func:`prepare`). ``state`` holds
    the contact statistics; ``phi_j`` is ``φ_J`` (the final packing fraction of a jamming run, NaN
    for ``"direct"``). ``converged`` says the last minimisation met ``ftol``; ``ok`` says the
    packing satisfies its protocol's stopping rule; if not, ``reason`` says why. ``history`` lists
    ``(φ, p, jammed)`` for every minimisation in order (over all attempts), ``steps`` the same
    minimisations in full (:class:`MinimizationStep`: start, tolerances, role; :func:`jam` only);
    ``params`` the protocol parameters; ``n_restarts`` how many failed attempts :func:`jam`
    discarded.
    """

    packing: Packing
    state: PackingState
    protocol: str
    phi_j: float
    converged: bool
    ok: bool
    reason: str
    n_minimizations: int
    fire_iterations: int
    time: float
    params: dict[str, float | int | str] = field(default_factory=dict)
    history: tuple[tuple[float, float, bool], ...] = ()
    n_restarts: int = 0
    steps: tuple[MinimizationStep, ...] = ()

    def attrs(self) -> dict[str, float | int | str | bool]:
        """Flat HDF5 attributes: the state, ``phi_j``, flags, ``reason``, counts and
        ``param_*``."""
        out: dict[str, float | int | str | bool] = dict(self.state.as_attrs())
        out.pop("phi")
        out.update(
            protocol=self.protocol,
            phi_j=self.phi_j,
            converged=self.converged,
            ok=self.ok,
            reason=self.reason,
            n_minimizations=self.n_minimizations,
            fire_iterations=self.fire_iterations,
            n_restarts=self.n_restarts,
            time_seconds=self.time,
        )
        out.update({f"param_{k}": v for k, v in self.params.items()})
        return out


def _check_common(n: int, dim: int, seed: int, ftol: float, sizes: str, alpha: float) -> float:
    """Check the arguments every preparation takes; return ``ftol`` as a float."""
    if not (validation.is_integer(n) and n >= 2):
        raise ValueError(f"number of particles must be an integer >= 2, got n={n!r}")
    if not (validation.is_integer(dim) and dim >= 2):
        raise ValueError(f"dimension must be an integer >= 2, got dim={dim!r}")
    if not (validation.is_integer(seed) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got seed={seed!r}")
    if not (validation.is_real(ftol) and math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be finite and > 0, got ftol={ftol!r}")
    parse_sizes(sizes)
    check_alpha(alpha)
    return float(ftol)


def jam(
    n: int,
    dim: int = 3,
    seed: int = 0,
    p_target: float = 1e-7,
    phi_init: float = 0.66,
    ftol: float = 1e-12,
    p_floor_factor: float = 1e-3,
    compress_factor: float = 1.01,
    max_minimizations: int = 60,
    max_restarts: int = 10,
    max_iter: int = 1_000_000,
    strict: bool = False,
    progress: ProgressCallback | None = None,
    confirm_ftol_factor: float = 0.1,
    sizes: str = "mono",
    alpha: float = HARMONIC,
) -> PreparedPacking:
    """A packing at the jamming point by quench and decompression/compression steps.

    1. Uniformly random positions at ``φ_init`` (:func:`~jamlab.spheres.state.random_packing`
       with ``seed``, diameters ``sizes``, pair exponent ``alpha``), minimised (an infinitely fast
       quench, O'Hern et al. 2003).
    2. If that minimum is not jammed (small ``N`` jams over a wide range of ``φ``), compress it
       affinely and minimise again, ``φ_{k+1} = φ_k (1 + (compress_factor − 1) 2^k)``, until it is
       (or ``φ`` would exceed 0.95).
    3. Every later minimisation starts from the last *jammed* minimum (``p > p_target ×
       p_floor_factor / 10`` and a backbone that is not hypostatic), affinely rescaled to the next
       ``φ``, chosen by a secant step on ``p(φ) ≈ k (φ − φ_J)`` towards the goal pressure
       ``p_goal`` (slope ``k`` from the last two jammed minima; ``k = 1`` at first; aiming at
       no less than a tenth of the current pressure), or by
       bisection between the last jammed and the highest unjammed ``φ`` when the secant step
       would leave that bracket. A decompression that ends on a *stressed* hypostatic minimum
       (``p > 0`` but ``N_c' < d(N'−1)+1``: a saddle, seen at ``N = 16``) does not bound
       ``φ_J``: the next decompression from the jammed state is halved. If the bracket closes on
       a finite pressure its lower end came from another branch (a rearrangement) and is
       dropped. Every converged minimum with ``p ≤ 2 p_target`` and
       ``|N_c' − N_c,iso| ≤ 1`` is first polished to ``ftol × confirm_ftol_factor`` (its
       contact count is decided there).
    4. Stop when ``p ∈ [p_target/2, 2 p_target]`` and the backbone is isostatic,
       ``N_c' = d(N' − 1) + 1``. With excess contacts inside the window the search
       lowers ``p_goal`` by 0.7 while it stays in the window, then halves it; an isostatic
       minimum found below the window is re-compressed along its branch (secant in ``φ``
       towards ``0.625 p_target``, then bisection between the highest isostatic minimum below
       the window and the lowest one with excess contacts) until an isostatic state inside the
       window is found; if a contact is added below ``p_target/2`` there is none and the
       attempt fails (restart).
    5. An attempt that fails for a structural reason — excess contacts that survive down to
       ``p_floor = p_target × p_floor_factor`` (a non-generic, hyperstatic jammed state, e.g.
       local crystalline order at small ``N``), only saddles below the jammed state, no jammed
       state below ``φ = 0.95``, no isostatic state in the window on the re-compressed branch,
       or ``max_minimizations`` used up — is discarded and the protocol
       restarts from new random positions (seed derived from ``(seed, attempt)``, see
       :func:`~jamlab.spheres.jam_search.quench_seed`), at most ``max_restarts`` times. The
       number of restarts is recorded (``n_restarts``).

    Every minimisation is listed in ``steps`` (:class:`MinimizationStep`), so the schedule can
    be replayed exactly.

    Parameters
    ----------
    n, dim : int
        Number of particles (``>= 2``) and dimension (``>= 2``).
    seed : int
        Seed of the random start (``>= 0``); restarts derive theirs from it.
    p_target : float
        Goal pressure; the packing ends with ``p ∈ [p_target/2, 2 p_target]``.
    phi_init : float
        Packing fraction of the quench.
    ftol : float
        Convergence of every minimisation: ``max_i |F_i| < ftol``.
    p_floor_factor, compress_factor, max_minimizations, max_restarts, max_iter, \
confirm_ftol_factor
        Protocol limits (steps 2–5 above).
    strict : bool
        Raise :class:`JammingError` instead of returning ``ok=False``.
    progress : callable, optional
        Called with a one-line message after each minimisation.
    sizes : str
        Diameters: ``"mono"`` (``D = 1``), ``"bidisperse"`` (1 : 1.4) or
        ``"polydisperse[:w]"`` (:mod:`jamlab.spheres.state`).
    alpha : float
        Pair exponent, ``V = (1 − r/σ_ij)^α`` (2: harmonic, 2.5: Hertzian).

    Returns
    -------
    PreparedPacking
        The packing, its contact statistics (``state``), ``phi_j`` and the schedule; ``ok=False``
        with a ``reason`` if a minimisation does not converge (no restart: that is a numerical
        failure) or if every attempt fails.

    Examples
    --------
    >>> from jamlab.spheres import jam
    >>> r = jam(64, 3, seed=1, p_target=1e-4)
    >>> r.ok, r.state.isostatic, 0.5e-4 <= r.state.pressure <= 2e-4
    (True, True, True)
    >>> round(r.phi_j, 4)
    0.6262

    A 2D bidisperse glass former (O'Hern et al. 2003: ``φ_J ≈ 0.842`` for large ``N``):

    >>> r = jam(128, 2, seed=2, p_target=1e-4, sizes="bidisperse")
    >>> r.ok, r.state.isostatic, round(r.phi_j, 3)
    (True, True, 0.843)
    """
    ftol = _check_common(n, dim, seed, ftol, sizes, alpha)
    if not (validation.is_real(p_target) and math.isfinite(p_target) and p_target > 0):
        raise ValueError(f"target pressure must be finite and > 0, got p_target={p_target!r}")
    if not (validation.is_real(phi_init) and 0 < phi_init < PHI_MAX):
        raise ValueError(
            f"initial packing fraction must be in (0, {PHI_MAX}), got phi_init={phi_init!r}"
        )
    if not 0 < p_floor_factor <= 0.5:
        raise ValueError(f"p_floor_factor must be in (0, 0.5], got {p_floor_factor!r}")
    if not (validation.is_real(compress_factor) and 1 < compress_factor < 2):
        raise ValueError(f"compress_factor must be in (1, 2), got {compress_factor!r}")
    if not (validation.is_integer(max_restarts) and max_restarts >= 0):
        raise ValueError(f"max_restarts must be an integer >= 0, got {max_restarts!r}")
    for name, value in (("max_minimizations", max_minimizations), ("max_iter", max_iter)):
        if not (validation.is_integer(value) and value >= 1):
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if not (validation.is_real(confirm_ftol_factor) and 0 < confirm_ftol_factor <= 1):
        raise ValueError(f"confirm_ftol_factor must be in (0, 1], got {confirm_ftol_factor!r}")
    p_target, phi_init = float(p_target), float(phi_init)
    compress_factor, confirm_ftol_factor = float(compress_factor), float(confirm_ftol_factor)
    t0 = time.perf_counter()
    params: dict[str, float | int | str] = dict(
        p_target=float(p_target),
        phi_init=float(phi_init),
        ftol=float(ftol),
        p_floor_factor=float(p_floor_factor),
        compress_factor=float(compress_factor),
        max_minimizations=int(max_minimizations),
        max_restarts=int(max_restarts),
        max_iter=int(max_iter),
        fire_dt_max=JAM_FIRE.dt_max,
        n=int(n),
        dim=int(dim),
        seed=int(seed),
        search="window",
        confirm_ftol_factor=float(confirm_ftol_factor),
    )
    if sizes != "mono" or alpha != HARMONIC:
        params.update(sizes=str(sizes), alpha=float(alpha))
    steps: list[MinimizationStep] = []
    fire_it = 0
    reasons: list[str] = []
    for attempt in range(int(max_restarts) + 1):
        a = run_attempt(
            int(n),
            int(dim),
            quench_seed(int(seed), attempt),
            float(p_target),
            float(phi_init),
            float(ftol),
            float(p_floor_factor),
            float(compress_factor),
            int(max_minimizations),
            int(max_iter),
            progress,
            steps,
            attempt,
            float(confirm_ftol_factor),
            sizes,
            check_alpha(alpha),
        )
        fire_it += a.fire_iterations
        reason = a.reason
        if not a.ok and a.restartable:
            reasons.append(f"attempt {attempt}: {a.reason}")
            if attempt < max_restarts:
                if progress is not None:
                    progress(f"restart {attempt + 1}: {a.reason}")
                continue
            reason = f"all {attempt + 1} attempts failed ({'; '.join(reasons)})"
        break
    res = PreparedPacking(
        packing=a.last.packing,
        state=a.state,
        protocol="jamming",
        phi_j=a.last.packing.phi,
        converged=a.last.converged,
        ok=a.ok,
        reason=reason,
        n_minimizations=len(steps),
        fire_iterations=fire_it,
        time=time.perf_counter() - t0,
        params=params,
        history=tuple((s.phi, s.pressure, s.jammed) for s in steps),
        n_restarts=attempt,
        steps=tuple(steps),
    )
    if strict and not res.ok:
        raise JammingError(res)
    return res


def prepare(
    n: int,
    dim: int,
    phi: float,
    seed: int,
    ftol: float = 1e-12,
    max_iter: int = 1_000_000,
    sizes: str = "mono",
    alpha: float = HARMONIC,
) -> PreparedPacking:
    """An UNSAT packing: uniformly random positions at ``φ`` minimised directly there.

    Parameters
    ----------
    n, dim : int
        Number of particles (``>= 2``) and dimension (``>= 2``).
    phi : float
        Packing fraction ``Σ_i v_d(D_i/2)/L^d``, in ``(0, 1)``.
    seed : int
        Seed of the random positions (:func:`~jamlab.spheres.state.random_packing`).
    ftol, max_iter : float, int
        FIRE stops when ``max_i |F_i| < ftol`` or after ``max_iter`` iterations.
    sizes : str
        Diameters: ``"mono"``, ``"bidisperse"`` or ``"polydisperse[:w]"``.
    alpha : float
        Pair exponent, ``V = (1 − r/σ_ij)^α``.

    Returns
    -------
    PreparedPacking
        ``ok`` iff FIRE converged and the packing is jammed by the rule of
        :mod:`jamlab.spheres.rigidity` (a non-empty backbone with ``N_c' ≥ d(N' − 1) + 1``
        contacts and ``p`` above the resolution floor of ``ftol``); otherwise ``reason`` says
        why.

    Examples
    --------
    >>> from jamlab.spheres import prepare
    >>> u = prepare(128, 3, 0.8, seed=1)
    >>> u.ok, round(u.packing.phi, 12), u.state.z_nr > 6
    (True, 0.8, True)
    >>> prepare(128, 3, 0.7, seed=1, alpha=2.5).packing.alpha
    2.5
    """
    ftol = _check_common(n, dim, seed, ftol, sizes, alpha)
    if not (validation.is_real(phi) and 0 < phi < 1):
        raise ValueError(f"packing fraction must be in (0, 1), got phi={phi!r}")
    start = random_packing(int(n), int(dim), float(phi), int(seed), sizes=sizes, alpha=alpha)
    r = relax(start, ftol, max_iter)
    state = describe(r.packing, r.energy)
    reason = ""
    if not r.converged:
        reason = f"minimisation did not converge (max force {r.max_force:.3e} >= ftol {ftol:.1e})"
    elif state.n_contacts_nr == 0:
        reason = f"not jammed at phi={phi} (p={state.pressure:.3e}): below jamming"
    else:
        # the project's rule (jamlab.spheres.rigidity): a backbone that survives rattler removal
        # can still be floppy (hypostatic, p at the force resolution: N = 16 in 2D at 0.8)
        verdict = jammed_verdict(
            r.packing.dim,
            r.packing.n - state.n_rattlers,
            state.n_contacts_nr,
            state.pressure,
            pressure_floor(r.packing.n, r.packing.dim, r.packing.box.length, ftol),
        )
        if verdict:
            reason = f"not jammed at phi={phi}: {verdict}"
    return PreparedPacking(
        packing=r.packing,
        state=state,
        protocol="direct",
        phi_j=math.nan,
        converged=r.converged,
        ok=not reason,
        reason=reason,
        n_minimizations=1,
        fire_iterations=r.iterations,
        time=r.time,
        params=dict(
            phi=float(phi),
            ftol=float(ftol),
            max_iter=int(max_iter),
            n=int(n),
            dim=int(dim),
            seed=int(seed),
            fire_dt_max=JAM_FIRE.dt_max,
            **({} if sizes == "mono" and alpha == HARMONIC else {"sizes": sizes, "alpha": alpha}),
        ),
        history=((r.packing.phi, state.pressure, state.n_contacts_nr > 0),),
    )


def jam_at_pressure(
    n: int,
    dim: int = 3,
    seed: int = 0,
    pressure: float = 1e-4,
    *,
    p_target: float = 1e-7,
    ptol: float = validation.DEFAULT_PTOL,
    phi_init: float = 0.66,
    ftol: float = 1e-12,
    sizes: str = "mono",
    alpha: float = HARMONIC,
    progress: ProgressCallback | None = None,
) -> PreparedPacking:
    """A packing at the target ``pressure``: the jamming packing of :func:`jam` (at its
    ``p_target``, default 1e-7), then :func:`jamlab.spheres.barostat.minimize_enthalpy` to
    ``|p − pressure| ≤ max(ptol·pressure, p_floor)`` at ``max|F_i| < ftol`` (positions and box side
    relaxed: a compression when ``pressure > p_target``).

    Why this route: the fixed-pressure packings are then the constant-volume protocol's packings
    (same seeds, same ``jam``) brought to ``pressure``, so both protocols start from one ensemble.
    Not ``jam(p_target=pressure)``: its stopping rule wants an *isostatic* backbone with ``p``
    within a factor 2 of the target, which does not exist above ``p ≈ 1e-4`` at small N (a contact
    is added first; measured N = 64 at 1e-3: 11 attempts failed). Not an enthalpy minimisation
    from a random dense state: a different (deeper-quenched) ensemble. ``protocol`` is
    ``"jamming+enthalpy"``; ``ok`` needs both stages; ``params`` gain ``pressure``, ``ptol``."""
    from jamlab.spheres.barostat import minimize_enthalpy, polish_recorded

    if not (validation.is_real(pressure) and math.isfinite(pressure) and pressure > 0):
        raise ValueError(f"pressure must be finite and > 0, got pressure={pressure!r}")
    if not (validation.is_real(ptol) and math.isfinite(ptol) and ptol > 0):
        raise ValueError(f"ptol must be finite and > 0, got ptol={ptol!r}")
    pressure, ptol = float(pressure), float(ptol)
    t0 = time.perf_counter()
    first = jam(
        n,
        dim,
        seed,
        p_target=p_target,
        phi_init=phi_init,
        ftol=ftol,
        progress=progress,
        sizes=sizes,
        alpha=alpha,
    )
    if not first.ok:
        return first
    if progress is not None:
        progress(f"enthalpy minimisation to p={pressure:g}")
    res = minimize_enthalpy(first.packing, pressure, ftol=ftol, ptol=ptol)
    res = polish_recorded(res, {})[0]  # converged as the stored packing reads
    reason = (
        ""
        if res.converged
        else (
            f"enthalpy minimisation did not converge (p={res.pressure:.6e}, "
            f"max|F|={res.max_force:.3e})"
        )
    )
    return replace(
        first,
        packing=res.packing,
        state=describe(res.packing),
        protocol="jamming+enthalpy",
        converged=res.max_force < ftol,
        ok=res.converged,
        reason=reason,
        fire_iterations=first.fire_iterations + res.iterations,
        time=time.perf_counter() - t0,
        params={**first.params, "pressure": float(pressure), "ptol": float(ptol)},
    )
