"""``jamlab warmup``: after it, a user's first ``prepare`` + ``shear`` and a report's fits
compile nothing.

The claim is checked in fresh processes with a private, emptied numba cache
(``NUMBA_CACHE_DIR``): numba's own ``numba:compile`` events are counted (a cache load is not a
compilation), once without the warm-up (the control: it must compile) and once after it.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import pytest

from jamlab.warmup import count_compilations

FIRST_RUN = """
import sys
from jamlab.cli import main
from jamlab.warmup import count_compilations

def run():
    for argv in (["prepare", "--n", "64", "--phi", "0.8", "--seed", "1", "--quiet",
                  "--out", "c.h5"],
                 ["shear", "c.h5", "--dgamma", "1e-4", "--gamma-max", "2e-3", "--out", "t.h5"]):
        sys.argv = ["jamlab", *argv]
        try:
            main()
        except SystemExit as exit:
            assert exit.code in (0, None), exit.code
    # and a report's fits (other data and cut-off shape than the warm-up's own)
    import numpy as np
    from jamlab.analysis import fit_cutoff_power_law, fit_joint_scaling, fit_power_law

    rng = np.random.default_rng(5)
    sizes = {n: [1.0 + rng.pareto(0.4, 30) for _ in range(4)] for n in (64, 128, 256)}
    fit_joint_scaling(sizes, 1.0, n_boot=3, stretch=0.5)
    x = np.concatenate(sizes[64])
    fit_cutoff_power_law(x, 1.0)
    fit_power_law(x, x_max=float(x.max()), min_tail=20, n_boot=5)
print(count_compilations(run))
"""


def test_count_compilations_counts_compiles_not_cache_loads() -> None:
    @numba.njit
    def plus_one(x):
        return x + 1

    assert count_compilations(lambda: plus_one(1.0)) == 1
    assert count_compilations(lambda: plus_one(2.0)) == 0  # already compiled for float64
    assert count_compilations(lambda: plus_one(2)) == 1  # a new signature


def _first_run(tmp_path, env) -> int:
    work = tmp_path / f"run-{len(list(tmp_path.iterdir()))}"
    work.mkdir()
    proc = subprocess.run([sys.executable, "-c", FIRST_RUN], cwd=work, env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return int(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_after_warmup_the_first_prepare_and_shear_compile_nothing(tmp_path) -> None:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    (tmp_path / "runs").mkdir()
    runs = tmp_path / "runs"
    # control: with an empty cache the same commands compile (so a 0 below means something)
    assert _first_run(runs, env) > 10
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "cache-2")
    proc = subprocess.run([sys.executable, "-m", "jamlab", "warmup", "--jobs", "2"],
                          env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "numba cache filled" in proc.stdout
    # and says which machine and which BLAS kernels CHOLMOD runs (the record of every file)
    from jamlab import provenance

    here = provenance.machine()
    assert f"this machine: {provenance.summary_text(here)}" in proc.stdout
    assert "CHOLMOD's BLAS kernels: " in proc.stdout
    assert _first_run(runs, env) == 0


def test_warmup_rejects_bad_jobs() -> None:
    proc = subprocess.run([sys.executable, "-m", "jamlab", "warmup", "--jobs", "0"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    message = "jamlab: error: --jobs must be an integer >= 1, got 0"
    assert proc.stderr.strip().splitlines() == [message]
