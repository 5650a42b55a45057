"""Cost of the general pair law in the hot kernels, against the hand-written harmonic kernels of
the commit before pair laws existed (09aa8ce), in one process, timed alternately.

The old kernels are loaded from git (``git show 09aa8ce:src/jamlab/spheres/_kernels.py``) into a
temporary module, so both run on the same inputs, interleaved round by round (the machine is
shared). Cases: ``energy_forces_3d`` on a random φ = 0.8 configuration (N = 1000), the paper's
system (``diam=None, alpha=None``: the compile-time harmonic monodisperse specialisation), the
general path with an explicit diameter array (bidisperse-like) and α = 2, and Hertzian α = 5/2;
and the compiled FIRE loop minimising the same configuration (old vs new, paper's system). Prints
best-of times and ratios; asserts only that the paper's system gives identical forces.

Run: ``python benchmarks/bench_pair_law.py [--rounds 30]``
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from jamlab.spheres import kernels as new
from jamlab.spheres.box import box_length_for

ROOT = Path(__file__).resolve().parents[1]
BEFORE = "09aa8ce"


def old_kernels():
    src = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{BEFORE}:src/jamlab/spheres/_kernels.py"],
        check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    path = Path(tempfile.mkdtemp()) / "kernels_before_pair_law.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("kernels_before_pair_law", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def best(fn, rounds: int, inner: int) -> list[float]:
    out = []
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        out.append((time.perf_counter() - t) / inner)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=30)
    args = ap.parse_args(argv)
    old = old_kernels()
    rng = np.random.default_rng(1)
    n, d = 1000, 3
    L = box_length_for(n, d, 0.8)
    pos = rng.uniform(0, L, (n, d))
    start, nbr, shift, _ = old.build_neighbor_list(pos, L, 0.0, 1.2)
    f = np.empty_like(pos)
    ones = np.ones(n)
    lst = (pos, start, nbr, shift)
    cases = {
        "before (hand-written harmonic)": lambda: old.energy_forces_3d(*lst, f),
        "now, paper's system": lambda: new.energy_forces_3d(*lst, None, None, f),
        "now, D array, alpha 2": lambda: new.energy_forces_3d(*lst, ones, 2.0, f),
        "now, Hertzian alpha 5/2": lambda: new.energy_forces_3d(*lst, None, 2.5, f),
    }
    forces = {}
    for k, fn in cases.items():
        fn()
        forces[k] = f.copy()
    same = np.array_equal(forces["now, paper's system"], forces["before (hand-written harmonic)"])
    assert same, "the paper's system must give the forces of the hand-written kernel bit for bit"
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(args.rounds):
        for k, fn in cases.items():
            times[k] += best(fn, 1, 50)
    ref = min(times["before (hand-written harmonic)"])
    print(f"energy_forces_3d, N = {n}, phi = 0.8 (best of {args.rounds} rounds of 50 calls)")
    for k, t in times.items():
        print(f"  {k:32s} {1e6 * min(t):8.1f} us   x{min(t) / ref:.3f}")

    # the compiled FIRE loop from the same start, paper's system
    def fire_old():
        p = pos.copy()
        s, nb, sh, iy = old.build_neighbor_list(p, L, 0.0, 1.2)
        return old.fire(p, L, 0.0, 0.2, 0.2, s, nb, sh, iy, p.copy(), 1e-10, 20000,
                        0.1, 0.3, 0.002, 20, 1.1, 0.5, 0.25, 0.99, 2000, 0.1, True)  # fmt: skip

    def fire_new():
        p = pos.copy()
        s, nb, sh, iy = new.build_neighbor_list(p, L, 0.0, 1.2)
        return new.fire(p, L, 0.0, 0.2, 1.0, 0.2, s, nb, sh, iy, p.copy(), None, None,
                        1e-10, 20000, 0.1, 0.3, 0.002, 20, 1.1, 0.5, 0.25, 0.99, 2000, 0.1,
                        True)  # fmt: skip

    a, b = fire_old(), fire_new()
    assert a[0] == b[0] and a[3] == b[3], "FIRE: same iterations and energy expected"
    ta, tb = [], []
    for _ in range(max(5, args.rounds // 3)):
        ta += best(fire_old, 1, 1)
        tb += best(fire_new, 1, 1)
    print(f"FIRE to max|F| < 1e-10 from the same start ({a[0]} iterations, identical in both):")
    print(f"  before {1e3 * min(ta):8.1f} ms   now {1e3 * min(tb):8.1f} ms   "
          f"x{min(tb) / min(ta):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
