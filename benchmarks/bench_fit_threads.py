"""The small fits with one BLAS thread (``jamlab.threads.one_blas_thread``) against the BLAS's
own threads, side by side in one run, on several seeds of the ``size_difference`` workload
(two sizes, 60 packings, 100 packing resamples, 202 fits of 3 L-BFGS-B starts each).

    PYTHONPATH=src python benchmarks/bench_fit_threads.py [--seeds 1 2 3] [--boot 100]

The ratio depends on how busy the cores are: idle, the two are close; beside a study that fills
the cores the BLAS's own threads wait for them (measured 6–11×, docs in ``jamlab.threads``).
Both variants give the same numbers bit for bit (checked here and in tests/test_threads.py).
"""

from __future__ import annotations

import argparse
import contextlib
import time

import numpy as np

from jamlab.analysis import cutoff_powerlaw, shape_test, size_difference


def _draw(rng, tau: float, s_c: float, m: int) -> np.ndarray:
    out = np.empty(0)
    while out.size < m:
        s = (1 - rng.random(4 * m)) ** (-1 / (tau - 1))
        out = np.concatenate([out, s[rng.random(s.size) < np.exp(-(s - 1.0) / s_c)]])
    return out[:m]


def _time(groups, boot: int, one: bool):
    block = cutoff_powerlaw.one_blas_thread if one else contextlib.nullcontext
    saved = cutoff_powerlaw.one_blas_thread, shape_test.one_blas_thread
    cutoff_powerlaw.one_blas_thread = shape_test.one_blas_thread = block
    try:
        wall, cpu = time.perf_counter(), time.process_time()
        r = size_difference(groups, 1.0, boot=boot, seed=0)
        return time.perf_counter() - wall, time.process_time() - cpu, repr(r)
    finally:
        cutoff_powerlaw.one_blas_thread, shape_test.one_blas_thread = saved


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--boot", type=int, default=100)
    a = ap.parse_args()
    print(f"{'seed':>4} {'own threads s':>14} {'(CPU s)':>8} {'one thread s':>13} {'(CPU s)':>8} "
          f"{'ratio':>6} same")
    ratios = []
    for seed in a.seeds:
        rng = np.random.default_rng(seed)
        groups = {500: [_draw(rng, 1.5, 50.0, 60) for _ in range(40)],
                  1000: [_draw(rng, 1.5, 100.0, 120) for _ in range(20)]}
        w_many, c_many, r_many = _time(groups, a.boot, one=False)
        w_one, c_one, r_one = _time(groups, a.boot, one=True)
        ratios.append(w_many / w_one)
        print(f"{seed:>4} {w_many:>14.2f} {c_many:>8.2f} {w_one:>13.2f} {c_one:>8.2f} "
              f"{ratios[-1]:>6.2f} {r_many == r_one}")
    print(f"geometric mean ratio (own threads / one thread): {np.exp(np.mean(np.log(ratios))):.2f}")


if __name__ == "__main__":
    main()
