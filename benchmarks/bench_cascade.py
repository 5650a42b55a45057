"""Throughput of the exact cascade sampler: samples per second on one core vs the target.

Setting (issue 3): ``y(q) = 2.5 q`` on ``[0, 0.9]`` (``q_max = 0.9``) discretised into ``k = 16``
levels (``q_i = 0.9 (i-1)/15``, ``y_i`` the mean of ``y`` over ``[q_i, q_{i+1}]``,
``y_16 = y(0.9)``), ``δγ = 0.1``. Target: 10,000 samples/s per core. Prints the ratio; asserts
nothing about time. Run: ``.venv/bin/python benchmarks/bench_cascade.py``.
"""

from __future__ import annotations

import time

import numpy as np

from jamlab.theory.cascade import sample_cascade_jumps

TARGET = 10_000.0


def linear_levels(slope: float, q_max: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    q = q_max * np.arange(k) / (k - 1)
    y = np.empty(k)
    y[:-1] = slope * 0.5 * (q[:-1] + q[1:])
    y[-1] = slope * q_max
    return q, y


def main() -> None:
    print(f"{'k':>4} {'dgamma':>7} {'samples/s':>11} {'target':>8} {'ratio':>6} {'states':>7}")
    for k, dg in [(16, 0.1), (4, 0.1), (64, 0.1), (16, 0.3), (16, 0.5)]:
        q, y = linear_levels(2.5, 0.9, k)
        sample_cascade_jumps(q, y, dg, 100, seed=0)  # compile / load cache
        n = 200_000 if k <= 16 else 50_000
        t0 = time.perf_counter()
        r = sample_cascade_jumps(q, y, dg, n, seed=1)
        rate = n / (time.perf_counter() - t0)
        print(
            f"{k:>4} {dg:>7.2f} {rate:>11.0f} {TARGET:>8.0f} {rate / TARGET:>6.1f} "
            f"{r.n_states.mean():>7.2f}"
        )


if __name__ == "__main__":
    main()
