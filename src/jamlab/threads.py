"""Cores and threads: the cores this process may use, and BLAS threads around many small
optimisations.

**Usable cores** (:func:`usable_cores`): the CPUs this process may run on
(``os.sched_getaffinity``), not all the machine's (``os.cpu_count``). Inside a SLURM allocation or
a container limited by ``taskset``/cgroups cpusets the two differ (4 of a node's 64 cores, say),
and a default of one worker per core must count the first.

**BLAS threads** (:func:`one_blas_thread`).

scipy's L-BFGS-B (C since scipy 1.15) calls BLAS on vectors of 2–4 parameters. A multithreaded
OpenBLAS wakes its thread pool for each call; on a machine whose cores are busy (a study beside
the analysis, pytest-xdist) the pool's threads wait for cores, and the fits slowed ~11×: a
`size_difference` with 100 bootstrap resamples took 28.5 s wall (19.6 s CPU) with OpenBLAS's
default threads against 2.5 s (1.7 s CPU) at one thread, beside a 2-worker run on 2 cores
(cProfile: 18 of 26 s inside ``setulb``). Idle, the two agree. One thread changes no number:
each BLAS call is on a handful of entries (tests/test_threads.py checks bit-identical fits).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache

__all__ = ["one_blas_thread", "usable_cores"]


def usable_cores() -> int:
    """The number of CPUs this process may run on (at least 1; ``os.cpu_count()`` where the
    platform has no ``sched_getaffinity``)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


@cache
def _controller():
    # made once per process (inspecting the loaded libraries takes ~1.5 ms; a limit from it
    # ~13 µs); the BLAS scipy and numpy load is there by the first fit
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with every BLAS loaded (at the first call) limited to one thread."""
    with _controller().limit(limits=1, user_api="blas"):
        yield
