"""The pair sum split into passes so that its arithmetic vectorises: measured, not kept.

jamlab's 3D force kernel (:func:`jamlab.spheres.kernels.pairs.energy_forces_3d`) walks the
half neighbour list once: per pair a gather of ``r_j``, the contact test, a square root and a
division, and a scatter of ``−F`` onto ``j``. LLVM leaves that loop scalar (the gathers and the
scatter). This benchmark times three splittings of the same sum that keep every floating-point
operation and its order — so the same bits, checked — against the kernel itself:

- ``two-pass``: per pair ``c·r_ij`` and ``V`` into a buffer (a loop without scatter), then the
  accumulation and scatter in the kernel's order;
- ``two-pass SoA``: the same with one array per component;
- ``three-pass``: the separations gathered into contiguous arrays first, so that the middle pass
  (square roots, divisions, the select) has no gather and vectorises (``vsqrtpd``/``vdivpd`` on
  ``ymm``; its assembly is counted below), then the scatter.

Harmonic monodisperse spheres relaxed near jamming (``random_packing(N, 3, 0.645, seed)``, FIRE
to ``1e-6``), the relaxations' skin (``RELAX_SKIN``), best of 5 rounds, µs per evaluation.
Asserts nothing about time; exits non-zero if a splitting changes a bit.

Run: ``python benchmarks/bench_pair_sum_split.py [--n 1000 2000] [--seeds 1 2]``
"""

from __future__ import annotations

import argparse
import re
import time

import numpy as np
from numba import njit

from jamlab.spheres.fire import minimize
from jamlab.spheres.kernels import pairs as P
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList
from jamlab.spheres.state import random_packing


@njit(cache=True)
def owners(start):
    """``i`` of every list entry ``k`` (the list's rows expanded)."""
    n = start.shape[0] - 1
    pi = np.empty(start[n], np.int64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            pi[k] = i
    return pi


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
    for k in range(nbr.shape[0]):
        i = pi[k]
        j = nbr[k]
        dx = pos[i, 0] - pos[j, 0] + shift[k, 0]
        dy = pos[i, 1] - pos[j, 1] + shift[k, 1]
        dz = pos[i, 2] - pos[j, 2] + shift[k, 2]
        r2 = dx * dx + dy * dy + dz * dz
        r = np.sqrt(r2)
        h = 1.0 - r / 1.0
        h = h if r2 < 1.0 else 0.0
        c = -(-2.0 * h / 1.0) / r
        buf[0, k] = c * dx
        buf[1, k] = c * dy
        buf[2, k] = c * dz
        buf[3, k] = h * h
    return _scatter(start, nbr, forces, buf[0], buf[1], buf[2], buf[3])


@njit(cache=True)
def two_pass_soa(pos, start, nbr, shift, pi, forces, bx, by, bz, bv):
    for k in range(nbr.shape[0]):
        i = pi[k]
        j = nbr[k]
        dx = pos[i, 0] - pos[j, 0] + shift[k, 0]
        dy = pos[i, 1] - pos[j, 1] + shift[k, 1]
        dz = pos[i, 2] - pos[j, 2] + shift[k, 2]
        r2 = dx * dx + dy * dy + dz * dz
        r = np.sqrt(r2)
        h = 1.0 - r / 1.0
        h = h if r2 < 1.0 else 0.0
        c = -(-2.0 * h / 1.0) / r
        bx[k] = c * dx
        by[k] = c * dy
        bz[k] = c * dz
        bv[k] = h * h
    return _scatter(start, nbr, forces, bx, by, bz, bv)


@njit(cache=True, error_model="numpy")
def three_pass(pos, start, nbr, shift, pi, forces, bx, by, bz, bv):
    m = nbr.shape[0]
    for k in range(m):
        i = pi[k]
        j = nbr[k]
        bx[k] = pos[i, 0] - pos[j, 0] + shift[k, 0]
        by[k] = pos[i, 1] - pos[j, 1] + shift[k, 1]
        bz[k] = pos[i, 2] - pos[j, 2] + shift[k, 2]
    for k in range(m):
        dx = bx[k]
        dy = by[k]
        dz = bz[k]
        r2 = dx * dx + dy * dy + dz * dz
        r = np.sqrt(r2)
        h = 1.0 - r / 1.0
        h = h if r2 < 1.0 else 0.0
        c = -(-2.0 * h / 1.0) / r
        bx[k] = c * dx
        by[k] = c * dy
        bz[k] = c * dz
        bv[k] = h * h
    return _scatter(start, nbr, forces, bx, by, bz, bv)


def make_cases(pos, start, nbr, shift, pi):
    """The force arrays and the four evaluations (the kernel and the three splittings)."""
    m = pi.size
    f = {k: np.empty_like(pos) for k in ("kernel", "two", "soa", "three")}
    buf = np.empty((4, m))
    cols = [np.empty(m) for _ in range(4)]
    cases = {
        "kernel": lambda: P.energy_forces_3d(pos, start, nbr, shift, None, None, f["kernel"]),
        "two": lambda: two_pass(pos, start, nbr, shift, pi, f["two"], buf),
        "soa": lambda: two_pass_soa(pos, start, nbr, shift, pi, f["soa"], *cols),
        "three": lambda: three_pass(pos, start, nbr, shift, pi, f["three"], *cols),
    }
    return f, cases


def best_us(fn, reps: int = 3000, rounds: int = 5) -> float:
    fn()
    best = np.inf
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(reps):
            fn()
        best = min(best, (time.perf_counter() - t) / reps)
    return 1e6 * best


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
            pi = owners(start)
            m = pi.size
            f, cases = make_cases(pos, start, nbr, shift, pi)
            energies = {k: fn() for k, fn in cases.items()}
            for k in ("two", "soa", "three"):
                if energies[k] != energies["kernel"] or not np.array_equal(f[k], f["kernel"]):
                    raise SystemExit(f"N={n} seed={seed}: {k} changed a bit")
            t = {k: best_us(fn) for k, fn in cases.items()}
            best = min(t[k] for k in ("two", "soa", "three"))
            print(f"| {n} | {seed} | {m} | {t['kernel']:.1f} | {t['two']:.1f} | {t['soa']:.1f} | "
                  f"{t['three']:.1f} | {t['kernel'] / best:.2f} |", flush=True)
    asm = three_pass.inspect_asm(three_pass.signatures[0])
    print("\nthree-pass assembly: " + ", ".join(
        f"{p} {len(re.findall(p, asm))}" for p in ("vsqrtpd", "vdivpd", "vsqrtsd", "ymm", "zmm")))


if __name__ == "__main__":
    main()
