"""Speed of the zero-temperature SK Parisi solver (``jamlab.theory.sk``). Never asserts a time.

For k = 1 .. K (each warm-started from k - 1, as ``sk_ground_state`` does): the time of
``sk_k_rsb`` (BFGS with reverse-mode gradients, Newton polish) beside a finite-difference BFGS
on the same public ``Q`` (``sk_q_functional``; the method of the first solver), with the
energies of both and their ratio of times.

    .venv/bin/python benchmarks/bench_sk.py [--k-max 10] [--fd-k-max 6]

BLAS is pinned to one thread (one core).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy import optimize  # noqa: E402

from jamlab.theory.sk import sk_k_rsb, sk_q_functional  # noqa: E402


def fd_bfgs(k: int, q0: np.ndarray, y0: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Finite-difference BFGS over (logit of 1 - q_i / 1 - q_{i-1}, log of the y increments)."""
    def unpack(p):
        s = 1.0 / (1.0 + np.exp(-p[:k - 1]))
        return 1.0 - np.concatenate(([1.0], np.cumprod(s))), np.cumsum(np.exp(p[k - 1:]))

    u = 1.0 - q0
    s = u[1:] / u[:-1]
    p0 = np.concatenate((np.log(s / (1 - s)), np.log(np.diff(np.concatenate(([0.0], y0))))))
    res = optimize.minimize(lambda p: sk_q_functional(*unpack(p)), p0, method="BFGS",
                            options={"gtol": 1e-8, "maxiter": 4000})
    q, y = unpack(res.x)
    return -float(res.fun), q, y


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--k-max", type=int, default=10)
    ap.add_argument("--fd-k-max", type=int, default=6)
    args = ap.parse_args()
    print("k | exact-gradient solver: time, E_k | finite-difference BFGS: time, E_k | ratio")
    prev = None
    fq, fy = np.array([0.0]), np.array([1.0])
    for k in range(1, args.k_max + 1):
        t0 = time.perf_counter()
        prev = sk_k_rsb(k, prev)
        t_new = time.perf_counter() - t0
        line = f"{k:2d} | {t_new:7.2f} s  {prev.energy:.12f}"
        if k <= args.fd_k_max:
            if k > 1:  # the same warm start as sk_k_rsb: a level added at the top
                fq = np.append(fq, 1.0 - 0.5 * (1.0 - fq[-1]))
                fy = np.append(fy, fy[-1] * 1.6)
            t0 = time.perf_counter()
            e_fd, fq, fy = fd_bfgs(k, fq, fy)
            t_fd = time.perf_counter() - t0
            line += f" | {t_fd:7.2f} s  {e_fd:.12f} | x{t_fd / t_new:.1f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
