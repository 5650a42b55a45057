"""Two levers on the number of FIRE iterations at jamming, measured on the inner problems that
the fixed-pressure Newton path hands to FIRE (``docs/aqs.md``, "Cheaper FIRE iterations").

The starts are collected as in ``fire_fallback_probe.py`` (``shear_at_pressure`` on
``jam(N, 3, seed, p_target=p)``, every inner problem the Newton relaxer gave to FIRE), for each
seed. Then:

- ``lbfgs``: an L-BFGS prototype (numpy; two-loop recursion with memory ``m``, a displacement cap
  ``--maxstep`` per particle, backtracking that accepts energy rises at round-off level; stops at
  ``max_i |F_i| < 1e-12``) against FIRE from each start: iterations, force evaluations, the
  distance and relative energy difference of its minimum from FIRE's;
- ``scan``: FIRE's parameters changed one at a time around the defaults; total iterations over
  all starts relative to the defaults, and the non-converged count;
- ``ptail``: FIRE to a loose tolerance ``--loose`` (where the minimum's basin is decided), then
  L-BFGS in the metric of the loose point's Hessian (initial inverse Hessian ``P⁻¹``: the
  backbone ``LDLᵀ`` of :func:`jamlab.spheres.aqs.linalg.factorise` on the free particles, the
  pinned particle held, the rattlers scaled by ``1/(2 z_i)``; Armijo backtracking, or a step that
  lowers ``max|F|`` without raising ``E`` beyond round-off) for at most ``--cap`` iterations,
  and FIRE from wherever it stopped if ``max|F| ≥ 1e-12``: CPU time against plain FIRE to 1e-12,
  per start and in all, and the distance of the minima;
- ``pfire``: FIRE preconditioned by the factor of the *parent* minimum's backbone Hessian ``P``
  (the driving force ``P⁻¹F``, the mixing in the ``P`` metric, one solve per iteration; the
  first ``--count`` starts, at most ``--cap`` iterations, ``--dt-max``), against plain FIRE; and
  the largest eigenvalue of ``P⁻¹K`` (power iteration, ``K`` by finite differences of the
  forces) at the parent and at FIRE's minimum, which sets the stable time step;
- ``abc``: ABC-FIRE (Echeverri Restrepo & Andric, Comput. Mater. Sci. 218, 111978 (2023)): FIRE
  2.0 whose mixed velocity is divided by the bias ``1 − (1 − α)^(N⁺ + 1)`` of the running
  average (``N⁺`` the steps since the last restart), for each ``--alpha0``, against jamlab's
  FIRE 2.0, both to ``max|F| < --ftol`` (the fallback's finish level, 1e-9, by default) or
  ``--max-iter``: iterations, CPU time, non-converged runs, energy and distance of the minima.
  The ABC kernel is jamlab's compiled loop with that one line changed (``kernel_copy.py``: made
  from its source, stops if the line is not found); jamlab's cap ``dmax`` stays the only cap.

    PYTHONPATH=src python scripts/fire_alternatives.py lbfgs --n 1000 --seeds 1
    PYTHONPATH=src python scripts/fire_alternatives.py scan --n 1000 --seeds 1 2
    PYTHONPATH=src python scripts/fire_alternatives.py ptail --n 1000 --seeds 1 --loose 1e-8
    PYTHONPATH=src python scripts/fire_alternatives.py pfire --n 1000 --seeds 1 --count 5
    PYTHONPATH=src python scripts/fire_alternatives.py abc --n 1000 --seeds 1 2 --alpha0 0.25 0.1
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import deque
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fire_fallback_probe import collect  # noqa: E402
from jamlab.spheres import kernels as K
from jamlab.spheres.aqs.linalg import backbone_matrix, factorise
from jamlab.spheres.aqs.network import backbone_mask, contact_list
from jamlab.spheres.fire import FireParameters, kernel_arguments, kernel_start, minimize
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.potential import energy_and_forces
from kernel_copy import edited_fire

SCAN = [
    {}, {"dt_max": 0.25}, {"dt_max": 0.35}, {"dt_max": 0.4}, {"n_delay": 5}, {"n_delay": 10},
    {"alpha0": 0.1}, {"alpha0": 0.15}, {"f_alpha": 0.98}, {"f_alpha": 0.995}, {"f_inc": 1.2},
    {"f_dec": 0.7}, {"variant": "fire"},
]  # fmt: skip


def fmax(f: np.ndarray) -> float:
    return float(np.sqrt((f * f).sum(1)).max())


def two_loop(g: np.ndarray, s_hist: deque, y_hist: deque, h0) -> np.ndarray:
    """L-BFGS two-loop recursion: the inverse-Hessian estimate applied to ``g``, from the
    stored steps ``s_hist`` and gradient changes ``y_hist`` (oldest first) and the initial
    inverse Hessian ``h0`` (a function of a vector)."""
    q = g.copy()
    coef = []
    for s, y in zip(reversed(s_hist), reversed(y_hist), strict=True):
        rho = 1.0 / np.vdot(y, s)
        a = rho * np.vdot(s, q)
        q -= a * y
        coef.append((rho, a))
    q = h0(q)
    for (s, y), (rho, a) in zip(zip(s_hist, y_hist, strict=True), reversed(coef), strict=True):
        q += s * (a - rho * np.vdot(y, q))
    return q


def lbfgs(start, ftol: float = 1e-12, m: int = 10, maxstep: float = 0.02,
          max_iter: int = 200_000) -> tuple[int, int, float, float, np.ndarray]:
    """``(iterations, force evaluations, energy, max|F|, positions)`` of L-BFGS from ``start``."""
    nl = NeighborList(start)
    x = start.positions.copy()
    e, f = energy_and_forces(start.with_positions(x), nl)
    s_hist: deque[np.ndarray] = deque(maxlen=m)
    y_hist: deque[np.ndarray] = deque(maxlen=m)
    evaluations, it = 1, 0
    while fmax(f) >= ftol and it < max_iter:
        it += 1
        g = -f.ravel()
        scale = (s_hist[-1] @ y_hist[-1]) / (y_hist[-1] @ y_hist[-1]) if s_hist else 0.1
        d = -two_loop(g, s_hist, y_hist, lambda q, c=scale: q * c)
        if d @ g >= 0:  # not a descent direction: restart from steepest descent
            s_hist.clear()
            y_hist.clear()
            d = -0.1 * g
        longest = float(np.sqrt((d.reshape(x.shape) ** 2).sum(1)).max())
        t = 1.0 if longest <= maxstep else maxstep / longest
        while True:
            xn = x + t * d.reshape(x.shape)
            en, fn = energy_and_forces(start.with_positions(xn), nl)
            evaluations += 1
            gn = -fn.ravel()
            if (en <= e + 1e-4 * t * (d @ g) or en - e <= 1e-15 * abs(e)
                    or (gn @ d < 0 and en <= e + 1e-13 * abs(e))):
                break
            t *= 0.5
            if t < 1e-12:
                break
        s, y = t * d, gn - g
        if s @ y > 1e-30:
            s_hist.append(s)  # (bounded deques: the oldest pair drops out)
            y_hist.append(y)
        x, e, f = xn, en, fn
    return it, evaluations, float(e), fmax(f), x


def metric(packing, nl):
    """``(P⁻¹, P, number of contacts)`` at ``packing`` as functions of an ``(N, d)`` array: the
    backbone factor on the free particles, the pinned particle held, the rattlers scaled by
    ``1/(2 z_i)`` (module docstring); ``(None, None, …)`` where the backbone Hessian is not
    positive definite. ``P`` assembles the backbone Hessian at its first use."""
    ci, cj, cd = contact_list(packing, nl)
    backbone = backbone_mask(ci, cj, packing.n, packing.dim)
    fac = factorise(packing, nl, backbone, (ci, cj, cd))
    if fac.lu is None or not fac.positive_definite:
        return None, None, ci.size
    z = np.bincount(np.concatenate([ci, cj]), minlength=packing.n)
    scale = 1.0 / np.maximum(2.0 * z, 1.0)
    pinned = backbone.copy()
    pinned[fac.free] = False
    d = packing.dim
    k: list = []

    def inverse(g: np.ndarray) -> np.ndarray:
        out = g * scale[:, None]
        out[pinned] = 0.0  # translations: the free particles move relative to it
        out[fac.free] = fac.lu.solve(g[fac.free].ravel()).reshape(-1, d)
        return out

    def times(v: np.ndarray) -> np.ndarray:
        if not k:
            k.append(backbone_matrix(packing, nl, fac, (ci, cj, cd)))
        out = v / scale[:, None]
        out[pinned] = 0.0
        out[fac.free] = (k[0] @ v[fac.free].ravel()).reshape(-1, d)
        return out

    return inverse, times, ci.size


def metric_lbfgs(start, apply, ftol: float = 1e-12, m: int = 8, cap: int = 200,
                 maxstep: float = 1e-3) -> tuple[int, int, np.ndarray]:
    """L-BFGS with initial inverse Hessian ``apply`` from ``start`` for at most ``cap``
    iterations: ``(iterations, force evaluations, positions)``."""
    nl = NeighborList(start, skin=RELAX_SKIN)
    x = start.positions.copy()
    e, f = energy_and_forces(start, nl)
    s_hist: deque[np.ndarray] = deque(maxlen=m)
    y_hist: deque[np.ndarray] = deque(maxlen=m)
    evaluations = it = 0
    while fmax(f) >= ftol and it < cap:
        it += 1
        g = -f
        d = -two_loop(g, s_hist, y_hist, apply)
        if np.vdot(d, g) >= 0:
            s_hist.clear()
            y_hist.clear()
            d = -apply(g)
        longest = float(np.sqrt((d * d).sum(1)).max())
        t = 1.0 if longest <= maxstep else maxstep / longest
        f0 = fmax(f)
        while True:
            xn = x + t * d
            en, fn = energy_and_forces(start.with_positions(xn), nl)
            evaluations += 1
            if en <= e + 1e-4 * t * np.vdot(d, g) or (fmax(fn) < f0 and en - e <= 1e-14 * abs(e)):
                break
            t *= 0.5
            if t < 1e-6:
                break
        s, y = xn - x, -fn - g
        if np.vdot(s, y) > 0:
            s_hist.append(s)  # (bounded deques: the oldest pair drops out)
            y_hist.append(y)
        x, e, f = xn, en, fn
    return it, evaluations, x


def ptail(starts, loose: float, cap: int) -> None:
    """The ``ptail`` comparison (module docstring), one row per start and the totals."""
    print("| # | FIRE to 1e-12: its, ms | FIRE to loose: its | P positive definite | L-BFGS its, "
          "evaluations | converged by L-BFGS | FIRE after | hybrid ms | dx | dE/E |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    total_fire = total_hybrid = 0.0
    done = 0
    for k, s in enumerate(starts):
        t0 = time.process_time()
        ref = minimize(s, ftol=1e-12, skin=RELAX_SKIN)
        t1 = time.process_time()
        nl = NeighborList(s, skin=RELAX_SKIN)
        lo = minimize(s, ftol=loose, neighbors=nl)
        apply, _, _ = metric(lo.packing, nl)
        its = evaluations = after = 0
        x = lo.packing.positions
        if apply is not None:
            its, evaluations, x = metric_lbfgs(lo.packing, apply, cap=cap)
        end = lo.packing.with_positions(x)
        res = minimize(end, ftol=1e-12, neighbors=nl)  # returns at once if L-BFGS converged
        after = res.iterations
        t2 = time.process_time()
        done += apply is not None and after == 0
        total_fire += t1 - t0
        total_hybrid += t2 - t1
        dx = float(np.max(np.abs(s.box.minimum_image(res.packing.positions
                                                     - ref.packing.positions))))
        print(f"| {k} | {ref.iterations}, {1e3 * (t1 - t0):.0f} | {lo.iterations} | "
              f"{apply is not None} | {its}, {evaluations} | {apply is not None and after == 0} | "
              f"{after} | {1e3 * (t2 - t1):.0f} | {dx:.1e} | "
              f"{(res.energy - ref.energy) / abs(ref.energy):.1e} |", flush=True)
    print(f"\n{done} of {len(starts)} finished by L-BFGS; CPU s in all: plain FIRE "
          f"{total_fire:.2f}, hybrid {total_hybrid:.2f} (FIRE / hybrid = "
          f"{total_fire / total_hybrid:.2f})")


def largest_preconditioned(point, inverse, sweeps: int = 60) -> float:
    """Largest eigenvalue of ``P⁻¹K(point)`` by power iteration (``K v`` by finite differences
    of the forces)."""
    nl = NeighborList(point, skin=RELAX_SKIN)
    f0 = energy_and_forces(point, nl)[1]
    v = np.random.default_rng(0).standard_normal(point.positions.shape)
    lam = 0.0
    for _ in range(sweeps):
        kv = (f0 - energy_and_forces(point.with_positions(point.positions + 1e-9 * v), nl)[1])
        w = inverse(kv / 1e-9)
        lam = float(np.sqrt((w * w).sum() / (v * v).sum()))
        v = w / np.sqrt((w * w).sum())
    return lam


def preconditioned_fire(start, inverse, times, cap: int, dt_max: float, ftol: float = 1e-12,
                        dt0: float = 0.1, n_delay: int = 5, alpha0: float = 0.25,
                        dmax: float = 0.05) -> tuple[int, int, float, np.ndarray]:
    """FIRE on ``ÿ = P^{-1/2} F`` in ``y = P^{1/2} x`` (written in ``x``): ``(iterations,
    velocity resets, max|F|, positions)``."""
    nl = NeighborList(start, skin=RELAX_SKIN)
    x = start.positions.copy()
    f = energy_and_forces(start, nl)[1]
    g = inverse(f)
    v = np.zeros_like(x)
    dt, alpha, n_pos, it, resets = dt0, alpha0, 0, 0, 0
    while fmax(f) >= ftol and it < cap:
        it += 1
        if np.vdot(f, v) > 0:
            n_pos += 1
            if n_pos > n_delay:
                dt, alpha = min(1.1 * dt, dt_max), 0.99 * alpha
        else:
            n_pos, resets = 0, resets + 1
            if it > n_delay:
                dt, alpha = 0.5 * dt, alpha0
            x -= 0.5 * dt * v
            v[:] = 0.0
        v += dt * g
        vy2, fy2 = float(np.vdot(v, times(v))), float(np.vdot(f, g))
        if vy2 > 0 and fy2 > 0:
            v = (1 - alpha) * v + alpha * np.sqrt(vy2 / fy2) * g
        dx = dt * v
        longest = float(np.sqrt((dx * dx).sum(1)).max())
        x = x + (dx * (dmax / longest) if longest > dmax else dx)
        f = energy_and_forces(start.with_positions(x), nl)[1]
        g = inverse(f)
    return it, resets, fmax(f), x


def pfire(pairs, count: int, cap: int, dt_max: float) -> None:
    """The ``pfire`` comparison (module docstring), one row per start."""
    print("| # | FIRE to 1e-12: its, ms | λ_max(P⁻¹K): parent, FIRE's minimum | preconditioned "
          "FIRE: its (resets), max|F|, ms |")
    print("|---|---|---|---|")
    for k, (s, parent) in enumerate(pairs[:count]):
        t0 = time.process_time()
        ref = minimize(s, ftol=1e-12, skin=RELAX_SKIN)
        t1 = time.process_time()
        inverse, times, _ = metric(parent, NeighborList(parent, skin=RELAX_SKIN))
        if inverse is None:
            print(f"| {k} | {ref.iterations}, {1e3 * (t1 - t0):.0f} | parent's Hessian not "
                  "positive definite | — |", flush=True)
            continue
        t2 = time.process_time()
        its, resets, fm, _ = preconditioned_fire(s, inverse, times, cap, dt_max)
        t3 = time.process_time()
        lam = (largest_preconditioned(parent, inverse),
               largest_preconditioned(ref.packing, inverse))
        print(f"| {k} | {ref.iterations}, {1e3 * (t1 - t0):.0f} | {lam[0]:.3f}, {lam[1]:.0f} | "
              f"{its} ({resets}), {fm:.1e}, {1e3 * (t3 - t2):.0f} |", flush=True)


_MIXING = """        if ff > 0.0:
            c1 = 1.0 - alpha
            c2 = alpha * np.sqrt(vv / ff)
"""
_ABC_MIXING = """        if ff > 0.0:
            m = 1.0 / (1.0 - (1.0 - alpha) ** (n_pos + 1))
            c1 = m * (1.0 - alpha)
            c2 = m * alpha * np.sqrt(vv / ff)
"""


def abc_kernel():
    """jamlab's compiled FIRE loop with the mixing divided by ABC-FIRE's bias correction
    (``scripts/kernel_copy.py``: the kernel's own source with that line edited)."""
    return edited_fire("fire_abc", [(_MIXING, _ABC_MIXING)])


def run_kernel(kernel, packing, ftol: float, params: FireParameters, max_iter: int):
    """One FIRE run of ``kernel`` from ``packing`` as :func:`minimize` makes it (the relaxations'
    skin): ``(iterations, converged, energy, CPU s, positions)``."""
    pos, nl = kernel_start(packing, skin=RELAX_SKIN)
    t = time.process_time()
    out = kernel(*kernel_arguments(pos, packing.box, nl, ftol, max_iter, params))
    cpu = time.process_time() - t
    return int(out[0]), bool(out[2]), float(out[3]), cpu, nl.unsorted(pos)


def abc(starts, alphas: list[float], ftol: float, max_iter: int) -> None:
    variants = [("FIRE 2.0", K.fire, FireParameters())]
    kernel = abc_kernel()
    variants += [(f"ABC α₀={a0:g}", kernel, FireParameters(alpha0=a0)) for a0 in alphas]
    for _, kern, params in variants:  # compile
        run_kernel(kern, starts[0], 1e-3, params, max_iter)
    totals = {name: [0, 0.0, 0] for name, _, _ in variants}
    print("| # | " + " | ".join(f"{name}: its, ms, dE/E, dx" for name, _, _ in variants) + " |")
    print("|---|" + "---|" * len(variants))
    for k, s in enumerate(starts):
        cells, ref = [], None
        for name, kern, params in variants:
            it, conv, e, cpu, x = run_kernel(kern, s, ftol, params, max_iter)
            ref = (e, x) if ref is None else ref
            dx = float(np.max(np.abs(s.box.minimum_image(x - ref[1]))))
            totals[name][0] += it
            totals[name][1] += cpu
            totals[name][2] += not conv
            cells.append(f"{it}{'' if conv else ' (not converged)'}, {cpu * 1e3:.0f}, "
                         f"{(e - ref[0]) / abs(ref[0]):+.1e}, {dx:.1e}")
        print(f"| {k} | " + " | ".join(cells) + " |", flush=True)
    base = totals["FIRE 2.0"][0]
    for name, (its, cpu, nc) in totals.items():
        print(f"{name}: {its} iterations ({its / base:.2f} of FIRE 2.0), {cpu:.2f} CPU s, "
              f"{nc} not converged")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=["lbfgs", "scan", "ptail", "pfire", "abc"])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--memory", type=int, nargs="+", default=[5, 10, 20])
    ap.add_argument("--maxstep", type=float, default=0.02)
    ap.add_argument("--loose", type=float, default=1e-8, help="ptail: FIRE's loose tolerance")
    ap.add_argument("--cap", type=int, default=200,
                    help="ptail: L-BFGS iterations at most; pfire: iterations at most")
    ap.add_argument("--count", type=int, default=5, help="pfire: starts measured")
    ap.add_argument("--dt-max", type=float, default=0.3, help="pfire: largest time step")
    ap.add_argument("--alpha0", type=float, nargs="+", default=[0.25, 0.1],
                    help="abc: FIRE's initial mixing α₀ of each ABC run")
    ap.add_argument("--ftol", type=float, default=1e-9, help="abc: the tolerance of both")
    ap.add_argument("--max-iter", type=int, default=200_000, help="abc: iterations at most")
    a = ap.parse_args()
    pairs = [pair for seed in a.seeds for pair in collect(a.n, a.pressure, a.dgamma, a.steps, seed)]
    starts = [s for s, _ in pairs]
    print(f"N = {a.n}, p = {a.pressure:g}, δγ = {a.dgamma:g}, {a.steps} steps, seeds {a.seeds}: "
          f"{len(starts)} inner problems handed to FIRE")
    minimize(starts[0], ftol=1e-6)  # compile
    if a.what == "ptail":
        ptail(starts, a.loose, a.cap)
        return
    if a.what == "pfire":
        pfire(pairs, a.count, a.cap, a.dt_max)
        return
    if a.what == "abc":
        abc(starts, a.alpha0, a.ftol, a.max_iter)
        return
    if a.what == "scan":
        base = None
        for change in SCAN:
            runs = [minimize(s, ftol=1e-12, params=FireParameters(**change)) for s in starts]
            its = sum(r.iterations for r in runs)
            base = its if base is None else base
            print(f"{change or 'defaults'}: {its} iterations ({its / base:.3f} of the defaults), "
                  f"{sum(not r.converged for r in runs)} not converged", flush=True)
        return
    print("| # | FIRE its | " + " | ".join(f"L-BFGS m={m}: its, evaluations, max|F|, dE/E, dx"
                                        for m in a.memory) + " |")
    print("|---|---|" + "---|" * len(a.memory))
    fire_total, evals = 0, dict.fromkeys(a.memory, 0)
    for k, s in enumerate(starts):
        ref = minimize(s, ftol=1e-12)
        fire_total += ref.iterations
        cells = []
        for m in a.memory:
            it, ev, e, fm, x = lbfgs(s, m=m, maxstep=a.maxstep)
            evals[m] += ev
            dx = float(np.max(np.abs(s.box.minimum_image(x - ref.packing.positions))))
            cells.append(f"{it}, {ev}, {fm:.1e}, {(e - ref.energy) / abs(ref.energy):.1e}, "
                         f"{dx:.1e}")
        print(f"| {k} | {ref.iterations} | " + " | ".join(cells) + " |", flush=True)
    print(f"\nFIRE iterations in all: {fire_total}; L-BFGS force evaluations in all: "
          + ", ".join(f"m={m}: {v}" for m, v in evals.items()))


if __name__ == "__main__":
    main()
