"""The pair sum split into passes so that its arithmetic vectorises: measured, not kept.

jamlab's 3D force kernel (:func:`jamlab.spheres.kernels.pairs.energy_forces_3d`) walks the
half neighbour list once: per pair a gather of ``r_j``, the contact test, a square root and a
division, and a scatter of ``−F`` onto ``j``. LLVM leaves that loop scalar (the gathers and the
scatter). This benchmark times three splittings of the same sum that keep every floating-point
operation and its order — so the same bits, checked — against the kernel itself:

- ``two-pass``: per pair ``c·r_ij`` and ``V`` into one ``(pairs, 4)`` buffer (a loop without
  scatter), then the accumulation and scatter in the kernel's order;
- ``two-pass SoA``: the same with one array per component;
- ``three-pass``: the separations gathered into contiguous arrays first, so that the middle pass
  (square roots, divisions, the select) has no gather and vectorises (``vsqrtpd``/``vdivpd`` on
  ``ymm``; its assembly is counted below), then the scatter.

Harmonic monodisperse spheres relaxed near jamming (``random_packing(N, 3, 0.645, seed)``, FIRE
to ``1e-6``), the relaxations' skin (``RELAX_SKIN``), best of 5 rounds
(``bench_force_kernel.per_particle``'s timer), µs per evaluation. The pair law is the project's
(``harmonic_terms_masked``), not a copy.
Asserts nothing about time; exits non-zero if a splitting changes a bit.

Run: ``python benchmarks/bench_pair_sum_split.py [--n 1000 2000] [--seeds 1 2]``
"""

from __future__ import annotations

import argparse
import re

import numpy as np
from numba import njit

from bench_force_kernel import per_particle  # benchmarks run as scripts
from jamlab.spheres.fire import minimize
from jamlab.spheres.kernels import pairs as P
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.pair import harmonic_terms_masked
from jamlab.spheres.state import random_packing


@njit(cache=True, inline="always")
def _separation(pos, shift, i, j, k):
    """``r_ij`` of list entry ``k`` (as the kernel forms it)."""
    return (pos[i, 0] - pos[j, 0] + shift[k, 0], pos[i, 1] - pos[j, 1] + shift[k, 1],
            pos[i, 2] - pos[j, 2] + shift[k, 2])


@njit(cache=True, inline="always")
def _factor(dx, dy, dz):
    """``(c·r_ij, V)`` with ``c = −V'/r``: the project's harmonic law with the contact test as a
    select (:func:`jamlab.spheres.pair.harmonic_terms_masked`, σ = 1)."""
    r2 = dx * dx + dy * dy + dz * dz
    r = np.sqrt(r2)
    v, dv = harmonic_terms_masked(r2, r, 1.0)
    c = -dv / r
    return c * dx, c * dy, c * dz, v


@njit(cache=True)
def _scatter(start, nbr, forces, bx, by, bz, bv):
    """The kernel's accumulation, in its order, from per-pair ``c·r_ij`` and ``V``."""
    n = forces.shape[0]
    forces[:, :] = 0.0
    e = 0.0
    for i in range(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            e += bv[k]
            fx += bx[k]
            fy += by[k]
            fz += bz[k]
            forces[j, 0] -= bx[k]
            forces[j, 1] -= by[k]
            forces[j, 2] -= bz[k]
        forces[i, 0] += fx
        forces[i, 1] += fy
        forces[i, 2] += fz
    return e


@njit(cache=True)
def two_pass(pos, start, nbr, shift, pi, forces, buf):
    """Per-pair factors into one ``(m, 4)`` buffer, then the scatter."""
    for k in range(nbr.shape[0]):
        dx, dy, dz = _separation(pos, shift, pi[k], nbr[k], k)
        buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3] = _factor(dx, dy, dz)
    return _scatter(start, nbr, forces, buf[:, 0], buf[:, 1], buf[:, 2], buf[:, 3])


@njit(cache=True)
def two_pass_soa(pos, start, nbr, shift, pi, forces, bx, by, bz, bv):
    """The same with one array per component."""
    for k in range(nbr.shape[0]):
        dx, dy, dz = _separation(pos, shift, pi[k], nbr[k], k)
        bx[k], by[k], bz[k], bv[k] = _factor(dx, dy, dz)
    return _scatter(start, nbr, forces, bx, by, bz, bv)


@njit(error_model="numpy")  # not cached: numba gives no assembly for cached code
def three_pass(pos, start, nbr, shift, pi, forces, bx, by, bz, bv):
    """The separations gathered first, so the factors' pass reads contiguous arrays."""
    m = nbr.shape[0]
    for k in range(m):
        bx[k], by[k], bz[k] = _separation(pos, shift, pi[k], nbr[k], k)
    for k in range(m):
        bx[k], by[k], bz[k], bv[k] = _factor(bx[k], by[k], bz[k])
    return _scatter(start, nbr, forces, bx, by, bz, bv)


def make_cases(pos, start, nbr, shift, pi):
    """The force arrays and the four evaluations (the kernel and the three splittings)."""
    m = pi.size
    f = {k: np.empty_like(pos) for k in ("kernel", "two", "soa", "three")}
    buf = np.empty((m, 4))
    cols = [np.empty(m) for _ in range(4)]
    cases = {
        "kernel": lambda: P.energy_forces_3d(pos, start, nbr, shift, None, None, f["kernel"]),
        "two": lambda: two_pass(pos, start, nbr, shift, pi, f["two"], buf),
        "soa": lambda: two_pass_soa(pos, start, nbr, shift, pi, f["soa"], *cols),
        "three": lambda: three_pass(pos, start, nbr, shift, pi, f["three"], *cols),
    }
    return f, cases


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1000, 2000])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    a = ap.parse_args()
    print("| N | seed | pairs | kernel (µs) | two-pass | two-pass SoA | three-pass | "
          "kernel / best split |")
    print("|---|---|---|---|---|---|---|---|")
    for n in a.n:
        for seed in a.seeds:
            pk = minimize(random_packing(n, 3, 0.645, seed), ftol=1e-6, max_iter=20_000).packing
            nl = NeighborList(pk, skin=RELAX_SKIN)
            pos = np.ascontiguousarray(nl.sorted(pk.positions))
            start, nbr, shift = nl.start, nl.nbr, nl.shift
            pi = np.repeat(np.arange(n), np.diff(start))  # i of every list entry
            m = pi.size
            f, cases = make_cases(pos, start, nbr, shift, pi)
            energies = {k: fn() for k, fn in cases.items()}
            for k in ("two", "soa", "three"):
                if energies[k] != energies["kernel"] or not np.array_equal(f[k], f["kernel"]):
                    raise SystemExit(f"N={n} seed={seed}: {k} changed a bit")
            t = {k: 1e-3 * n * per_particle(fn, n, 5) for k, fn in cases.items()}  # µs
            best = min(t[k] for k in ("two", "soa", "three"))
            print(f"| {n} | {seed} | {m} | {t['kernel']:.1f} | {t['two']:.1f} | {t['soa']:.1f} | "
                  f"{t['three']:.1f} | {t['kernel'] / best:.2f} |", flush=True)
    asm = three_pass.inspect_asm(three_pass.signatures[0])
    print("\nthree-pass assembly: " + ", ".join(
        f"{p} {len(re.findall(p, asm))}" for p in ("vsqrtpd", "vdivpd", "vsqrtsd", "ymm", "zmm")))


if __name__ == "__main__":
    main()
