"""Fixed pressure at p = 1e-6: FIRE's straight saddle escapes followed by a line search (probe).

``scripts/fire_slide_probe.py`` found that most of FIRE's iterations at p = 1e-6 are spent on
straight lines: the configuration leaves a near-saddle along a weakly unstable mode, the
displacement growing geometrically over ~10k iterations at max|F| ≈ 1e-10 – 5e-9. This probe
asks whether following such a line by a line search pays: every FIRE run of the Newton relaxer
(:mod:`jamlab.spheres.newton_relax`) in the first ``--steps`` steps of a run is caught (its start
and tolerance), and each is redone five ways:

* ``plain``: FIRE (:func:`jamlab.spheres.fire.minimize`) from the start to its tolerance (what
  the relaxer did);
* ``kernel``: the probe's compiled FIRE 2.0 (:func:`fire_lines`: the package's kernel, copied
  from its source with the line search edited in by ``scripts/kernel_copy.py``) without line
  searches — a check of the edits: the same iterations and minima as ``plain``;
* ``kernel+lines``: the same loop, and every ``--every`` iterations, where the last two
  windows' displacements are aligned (cosine ≥ ``--cos``) and growing, a line search along the
  last one: the force along the line, ``g(s) = F(x + s u)·u``, bracketed by doubling ``s``
  (from the window's length; any particle's move capped at ``--cap`` and inside the neighbour
  list's budget) until ``g ≤ 0`` and bisected to ``|g| < g(0)/10`` or 30 halvings; the
  configuration jumps to the last ``s`` with ``g > 0``, FIRE's velocity kept but for its part
  along ``u``, ``Δt`` and ``α`` kept;
* ``chunks``: :func:`minimize` in runs of ``--chunk`` iterations, each restarted from rest
  (FIRE's velocity and Δt are not carried across calls) — what restarts alone cost;
* ``line``: those chunks with the same line search between them.

``--variants a,b,…`` runs a subset (``plain``, the reference, always first).

Printed per variant: FIRE iterations, force evaluations of the line searches (each costs about
one FIRE iteration), the number of jumps (for ``kernel+lines`` with their mean length in units
of the window's displacement), whether every run converged, and how many runs end in a
different minimum from ``plain``: energy differs by more than 1e-9 relative / by more than
``--de`` (default 1e-11 ε, the plastic flag's threshold at N = 250, p = 1e-6) / a particle
(rattlers included) ends more than 1e-6 away; and the largest energy difference from ``plain``
(to compare with the avalanche sizes, ≥ 1e-10 ε counted at p = 1e-6). A relative 1e-9 can be
one minimum reached along a very soft mode; ``--de`` cannot.

    PYTHONPATH=src python scripts/fire_line_probe.py \\
        --sample RUNS/n250-p1e-6-fix40/samples/phi=jamming/N=250/sample-00000.h5 --steps 100
"""

from __future__ import annotations

import functools
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_pressure import parse_sample_arguments  # noqa: E402
from fire_slide_probe import caught_fire_runs  # noqa: E402
from kernel_copy import edited_fire  # noqa: E402

# isort: split
import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

from jamlab.spheres.fire import (  # noqa: E402
    FireParameters,
    kernel_arguments,
    kernel_start,
    minimize,
)
from jamlab.spheres.kernel_choice import threshold_for  # noqa: E402
from jamlab.spheres.kernels.pairs import energy_forces_any  # noqa: E402
from jamlab.spheres.neighbors import RELAX_SKIN  # noqa: E402

OPTS = {"chunk": 1000, "every": 1000, "cos": 0.99, "cap": 1e-2, "de": 1e-11,
        "variants": "plain,kernel,kernel+lines,chunks,line"}


def pop_option(name: str, kind=float):
    """``--name value`` taken out of ``sys.argv`` into ``OPTS`` (a bad value: one line, exit 2)."""
    if f"--{name}" in sys.argv:
        i = sys.argv.index(f"--{name}")
        try:
            OPTS[name] = kind(sys.argv[i + 1])
        except (IndexError, ValueError):
            print(f"error: --{name} needs a {kind.__name__} value", file=sys.stderr)
            raise SystemExit(2) from None
        del sys.argv[i:i + 2]


def line_search(pk, u: np.ndarray, s0: float, counts: dict):
    """The point along the unit direction ``u`` from ``pk`` where the force along ``u`` vanishes
    (the compiled :func:`search_line` of ``kernel+lines``, first trial ``s0``, on a fresh
    neighbour list: any particle's move capped at ``--cap`` and at half the list's skin); ``None``
    when the force along ``u`` is not positive at the start or no trial has it positive."""
    pos, nl = kernel_start(pk, skin=RELAX_SKIN)
    pos = np.ascontiguousarray(pos)
    lists = (nl.start, nl.nbr, nl.shift, nl.diameters, nl.alpha,
             threshold_for(nl.nbr.size, pos.shape[1], nl.alpha))  # as kernel_arguments passes
    last = np.ascontiguousarray(nl.sorted(u * s0))
    trial, g = np.empty_like(pos), np.empty_like(pos)
    g0 = force_along(pos, 0.0, last, s0, trial, g, *lists)
    counts["evaluations"] += 1
    s_cap = min(OPTS["cap"], 0.5 * nl.skin) / float(np.max(np.linalg.norm(u, axis=1)))
    if not (g0 > 0.0 and s_cap > 0.0):
        return None
    lo, k = search_line(pos, last, s0, g0, s_cap, trial, g, *lists)
    counts["evaluations"] += k
    return pk.with_positions(pk.positions + lo * u) if lo > 0 else None


def chunked(start, ftol: float, jump: bool, counts: dict):
    pk, last_d, spent = start, None, 0
    while spent < 1_000_000:
        res = minimize(pk, ftol=ftol, max_iter=int(OPTS["chunk"]), skin=RELAX_SKIN)
        spent += res.iterations
        if res.converged:
            return res, spent
        d = pk.box.minimum_image(res.packing.positions - pk.positions)
        pk = res.packing
        if jump and last_d is not None:
            nd, nl = np.linalg.norm(d), np.linalg.norm(last_d)
            if nd > nl > 0 and float(np.sum(d * last_d)) / (nd * nl) >= OPTS["cos"]:
                moved = line_search(pk, d / nd, nd, counts)
                if moved is not None:
                    counts["jumps"] += 1
                    pk, d = moved, None
        last_d = d
    return res, spent


@njit(cache=False)
def force_along(pos, s, last, dn, trial, g, start, nbr, shift, diam, pair_alpha,
                branch_free_pairs):
    """``F(x + s u)·u`` with ``u = last/dn`` (``trial``, ``g``: work arrays)."""
    n, d = pos.shape
    for i in range(n):
        for a in range(d):
            trial[i, a] = pos[i, a] + s * last[i, a] / dn
    energy_forces_any(trial, start, nbr, shift, diam, pair_alpha, g, branch_free_pairs)
    gs = 0.0
    for i in range(n):
        for a in range(d):
            gs += g[i, a] * last[i, a]
    return gs / dn


@njit(cache=False)
def search_line(pos, last, dn, g0, s_cap, trial, g, start, nbr, shift, diam, pair_alpha,
                branch_free_pairs):
    """``(s, evaluations)``: the line search of the module docstring along ``u = last/dn`` from
    ``pos`` (``g0 = F·u`` there, ``> 0``), ``s ≤ s_cap``; ``s = 0`` where not even the first
    trial has ``g > 0``."""
    lo = 0.0
    hi = -1.0
    k = 0
    s = min(dn, s_cap)
    while True:
        gs = force_along(pos, s, last, dn, trial, g, start, nbr, shift, diam, pair_alpha,
                         branch_free_pairs)
        k += 1
        if gs > 0.0:
            lo = s
            if s >= s_cap:
                break
            s = min(2.0 * s, s_cap)
        else:
            hi = s
            break
    if hi > 0.0:
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            gs = force_along(pos, mid, last, dn, trial, g, start, nbr, shift, diam, pair_alpha,
                             branch_free_pairs)
            k += 1
            if gs > 0.0:
                lo = mid
            else:
                hi = mid
            if abs(gs) < 0.1 * g0:
                lo = mid
                break
    return lo, k


@njit(cache=False)
def line_step(pos, v, f, mark, last, have_last, ref, half_budget2, cos_min, cap, trial, g,
              start, nbr, shift, diam, pair_alpha, branch_free_pairs):
    """At the end of a window: the window's displacement (``pos − mark``) into ``last`` and,
    where it is aligned with the last one (cosine ≥ ``cos_min``) and longer, the line search
    along it, ``pos`` moved to its end and ``v`` less its part along the line. Returns
    ``(have_last, reach, evaluations)``, ``reach`` the jump's length in units of the window's
    displacement (0: no jump; the caller then has the forces at ``pos`` already)."""
    n, d = pos.shape
    dn = 0.0
    ln = 0.0
    dl = 0.0
    for i in range(n):
        for a in range(d):
            x = pos[i, a] - mark[i, a]
            dn += x * x
            ln += last[i, a] * last[i, a]
            dl += x * last[i, a]
            last[i, a] = x
            mark[i, a] = pos[i, a]
    dn = np.sqrt(dn)
    ln = np.sqrt(ln)
    if not (have_last and dn > ln > 0.0 and dl / (dn * ln) >= cos_min):
        return True, 0.0, 0
    # u = last / |last|; the force along u at s = 0
    umax = 0.0
    g0 = 0.0
    for i in range(n):
        t = 0.0
        for a in range(d):
            t += last[i, a] * last[i, a]
            g0 += f[i, a] * last[i, a]
        umax = max(umax, np.sqrt(t))
    umax /= dn
    g0 /= dn
    # the list stays valid while every particle is within half the budget of ref
    room = 1e300
    for i in range(n):
        u2 = 0.0
        for a in range(d):
            u = pos[i, a] - ref[i, a]
            u2 += u * u
        room = min(room, np.sqrt(half_budget2) - np.sqrt(u2))
    s_cap = min(cap, room) / umax
    if not (g0 > 0.0 and s_cap > 0.0):
        return True, 0.0, 0
    lo, k = search_line(pos, last, dn, g0, s_cap, trial, g, start, nbr, shift, diam,
                        pair_alpha, branch_free_pairs)
    if lo <= 0.0:
        return True, 0.0, k
    vu = 0.0
    for i in range(n):
        for a in range(d):
            vu += v[i, a] * last[i, a]
    vu /= dn
    for i in range(n):
        for a in range(d):
            pos[i, a] += lo * last[i, a] / dn
            v[i, a] -= vu * last[i, a] / dn
            mark[i, a] = pos[i, a]
    return False, lo / dn, k


@njit(cache=False)
def copy_into(dst, src):
    """``dst[:, :] = src`` as plain loops (see the kernel's note on slice assignment)."""
    for i in range(src.shape[0]):
        for a in range(src.shape[1]):
            dst[i, a] = src[i, a]


# The kernel's FIRE loop (``jamlab/spheres/kernels/fire.py``) with the line search added
# (``scripts/kernel_copy.py``): four more arguments, the window's state, the window reset at a
# neighbour-list rebuild, the line step after the force evaluation of every ``every``-th
# iteration (forces recomputed after a jump, so the next kick uses them), the counts returned.
EDITS = [
    ("    branch_free_pairs,\n):\n",
     "    branch_free_pairs,\n    every,\n    cos_min,\n    cap,\n    lines,\n):\n"),
    ("    w = np.zeros((n, d), np.float64)\n",
     "    w = np.zeros((n, d), np.float64)\n    g = np.empty((n, d), np.float64)\n"
     "    trial = np.empty((n, d), np.float64)\n    mark = pos.copy()\n"
     "    last = np.zeros((n, d), np.float64)\n    have_last = False\n    evals = 0\n"
     "    jumps = 0\n    reach = 0.0\n"),
    ("            half_budget2 = 0.25 * skin * skin\n",
     "            half_budget2 = 0.25 * skin * skin\n            copy_into(mark, pos)\n"
     "            have_last = False\n"),
    ("        # the next kick, made now",
     "        if lines and it % every == 0:\n"
     "            have_last, r, k = line_step(pos, v, f, mark, last, have_last, ref,\n"
     "                                        half_budget2, cos_min, cap, trial, g, start,\n"
     "                                        nbr, shift, diam, pair_alpha,\n"
     "                                        branch_free_pairs)\n"
     "            evals += k\n"
     "            if r > 0.0:\n"
     "                jumps += 1\n"
     "                reach += r\n"
     "                e = energy_forces_any(pos, start, nbr, shift, diam, pair_alpha, f,\n"
     "                                      branch_free_pairs)\n"
     "        # the next kick, made now"),
    ("    return it, fmax, fmax < ftol, e, n_rebuild, start, nbr, shift, img_y, ref\n",
     "    return it, fmax, fmax < ftol, e, evals, jumps, reach\n"),
]


@functools.cache
def fire_lines():
    """FIRE 2.0 as :func:`jamlab.spheres.kernels.fire.fire` (the kernel itself, copied with
    :data:`EDITS`, compiled once per process), and, with ``lines``, every ``every`` iterations
    the line search of the module docstring along the last window's displacement, FIRE's
    velocity kept except its part along the line (``Δt`` and ``α`` kept). Arguments: the
    kernel's, then ``every, cos_min, cap, lines``. Returns ``(iterations, max_force, converged,
    energy, evaluations, jumps, reach)``, ``reach`` the sum over jumps of the jump's length in
    units of the window's displacement."""
    return edited_fire("fire_lines", EDITS, {"line_step": line_step, "copy_into": copy_into})


def run_lines(start_pk, ftol: float, lines: bool):
    """:func:`fire_lines` from ``start_pk`` (a fresh neighbour list, as :func:`minimize`)."""
    pos, nl = kernel_start(start_pk, skin=RELAX_SKIN)
    args = kernel_arguments(pos, start_pk.box, nl, ftol, 1_000_000, FireParameters())
    out = fire_lines()(*args, int(OPTS["every"]), OPTS["cos"], OPTS["cap"], lines)
    return out, nl.unsorted(pos)


def main() -> None:
    for name in ("chunk", "every", "cos", "cap", "de"):
        pop_option(name)
    pop_option("variants", str)
    if not (OPTS["every"] >= 1 and OPTS["chunk"] >= 1 and OPTS["cap"] > 0 and OPTS["de"] > 0):
        print("error: --every and --chunk must be >= 1, --cap and --de > 0", file=sys.stderr)
        raise SystemExit(2)
    variants = ["plain"] + [v for v in OPTS["variants"].split(",") if v != "plain"]
    unknown = set(variants) - {"plain", "kernel", "kernel+lines", "chunks", "line"}
    if unknown:
        print(f"error: --variants: unknown {sorted(unknown)}", file=sys.stderr)
        raise SystemExit(2)
    a = parse_sample_arguments(__doc__)
    caught = caught_fire_runs(a)
    print(f"{len(caught)} FIRE runs caught in {a.steps} steps, "
          f"{sum(c[1] for c in caught)} iterations; options {OPTS}")
    print("| variant | FIRE iterations | line evaluations | jumps (mean length / window's) | "
          "all converged | other energy / \\|ΔE\\| > de / a particle moved | max \\|ΔE\\| | "
          "CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    ref = {}
    for name in variants:
        counts = {"evaluations": 0, "jumps": 0, "reach": 0.0}
        its, ok, des, moved = 0, True, [], 0
        t = time.process_time()
        for k, (tol, _, start) in enumerate(caught):
            if name == "plain":
                res = minimize(start, ftol=tol, skin=RELAX_SKIN)
                n_it, conv, e, pos = res.iterations, res.converged, res.energy, None
                ref[k] = res
            elif name.startswith("kernel"):
                (n_it, _, conv, e, ev, jp, rch), pos = run_lines(start, tol, name != "kernel")
                counts["evaluations"] += ev
                counts["jumps"] += jp
                counts["reach"] += rch
            else:
                res, n_it = chunked(start, tol, name == "line", counts)
                conv, e, pos = res.converged, res.energy, res.packing.positions
            its += n_it
            ok &= bool(conv)
            if pos is not None:
                r0 = ref[k]
                des.append((abs(e - r0.energy), abs(r0.energy)))
                dx = start.box.minimum_image(pos - r0.packing.positions)
                moved += float(np.max(np.abs(dx))) > 1e-6
        cpu = time.process_time() - t
        de = np.array(des).reshape(-1, 2)
        other = int(np.sum(de[:, 0] > 1e-9 * de[:, 1]))
        big = int(np.sum(de[:, 0] > OPTS["de"]))
        jumps = (f"{counts['jumps']} ({counts['reach'] / counts['jumps']:.2f})"
                 if name == "kernel+lines" and counts["jumps"] else f"{counts['jumps']}")
        print(f"| {name} | {its} | {counts['evaluations']} | {jumps} | "
              f"{'yes' if ok else 'no'} | {other} / {big} / {moved} of {len(caught)} | "
              f"{float(de[:, 0].max(initial=0.0)):.1e} | {cpu:.1f} |", flush=True)

if __name__ == "__main__":
    main()
