"""The BLAS under CHOLMOD (``jamlab.spheres.blas``): cvxopt's OpenBLAS runs the kernels numpy's
chose (``aligned``), or chooses alone (``native``: what cvxopt imported without jamlab
chooses), or obeys the user's ``OPENBLAS_CORETYPE``; a bad ``JAMLAB_CHOLMOD_BLAS`` is one line.
Each case in a fresh process (a library chooses its kernels once, when it is loaded); the cores
are read there with ``threadpoolctl`` directly."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from cli_helpers import jamlab, one_line_error

pytest.importorskip("threadpoolctl")

PROBE = """
import json, sys
{imports}
from threadpoolctl import threadpool_info
libs = [i for i in threadpool_info() if i.get("user_api") == "blas"]
cvx = [i.get("architecture") for i in libs if "cvxopt" in i["filepath"]]
others = [i for i in libs if "cvxopt" not in i["filepath"] and i.get("architecture")]
newest = max(others, key=lambda i: [int("0" + "".join(c for c in p if c.isdigit()))
                                    for p in i["version"].split(".")]) if others else None
choice = {choice}
print(json.dumps({{"cvxopt": cvx, "newest": newest and newest["architecture"], "choice": choice}}))
"""
JAMLAB = "from jamlab.spheres.aqs import linalg\nfrom jamlab.spheres import blas"


def probe(imports: str, choice: str = "None", **env: str) -> dict:
    environ = {k: v for k, v in os.environ.items()
               if k not in ("OPENBLAS_CORETYPE", "JAMLAB_CHOLMOD_BLAS")}
    code = PROBE.format(imports=imports, choice=choice)
    out = subprocess.run([sys.executable, "-c", code], env={**environ, **env},
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


@pytest.fixture(scope="module")
def alone() -> dict:
    """cvxopt imported without jamlab: the core its OpenBLAS chooses by itself."""
    found = probe("import numpy.linalg, scipy.linalg, cvxopt, cvxopt.cholmod")
    if not found["cvxopt"] or not found["cvxopt"][0]:
        pytest.skip("cvxopt's BLAS is not an OpenBLAS that names its core")
    return found


def test_aligned_runs_the_kernels_of_the_newest_openblas(alone):
    found = probe(JAMLAB, "blas.choice()")
    older = {"SapphireRapids": "Cooperlake"}
    assert found["cvxopt"] == [older.get(found["newest"], found["newest"])]
    assert found["choice"]["mode"] == "aligned"
    assert found["choice"]["coretype"] == found["cvxopt"][0]
    # where cvxopt's OpenBLAS knew the CPU, nothing changed
    if alone["cvxopt"][0] == found["cvxopt"][0]:
        assert "runs" in found["choice"]["reason"]


def test_native_is_what_cvxopt_chooses_alone(alone):
    found = probe(JAMLAB, "blas.choice()", JAMLAB_CHOLMOD_BLAS="native")
    assert found["cvxopt"] == alone["cvxopt"]
    assert found["choice"] == {"mode": "native", "coretype": None,
                               "reason": "JAMLAB_CHOLMOD_BLAS=native"}


def test_the_users_coretype_is_obeyed_and_not_changed(alone):
    found = probe(JAMLAB + "\nimport os\nassert os.environ['OPENBLAS_CORETYPE'] == 'Prescott'",
                  "blas.choice()", OPENBLAS_CORETYPE="Prescott")
    assert found["cvxopt"] == ["Prescott"] and found["choice"]["coretype"] is None
    assert "OPENBLAS_CORETYPE=Prescott" in found["choice"]["reason"]


def test_a_bad_mode_is_one_line_exit_2(tmp_path):
    r = jamlab("inspect", tmp_path / "none.h5", env={**os.environ, "JAMLAB_CHOLMOD_BLAS": "fast"})
    line = one_line_error(r)
    assert "JAMLAB_CHOLMOD_BLAS" in line and "'aligned' or 'native'" in line


def test_the_choice_is_recorded_with_every_record():
    from jamlab import provenance
    from jamlab.spheres import blas

    record = provenance.machine()
    listed = record["blas_cores"].split("; ")
    assert len(listed) == len(blas.cores())
    for lib in blas.cores():
        assert f"{lib['prefix']} {lib['version']} {lib['architecture']}".strip() in listed


def test_a_core_the_old_openblas_may_not_know_is_not_set():
    """The rule, by hand: only names OpenBLAS 0.3.15 knows are set (the mapping included)."""
    from jamlab.spheres import blas

    assert "skylakex" in blas.KNOWN_CORES and "zen" in blas.KNOWN_CORES
    assert blas.OLDER_NAMES["SapphireRapids"].lower() in blas.KNOWN_CORES
    for unknown in ("NeoverseV2", "Zen4", "ARMV8", "Generic"):
        assert unknown.lower() not in blas.KNOWN_CORES
    # in a fresh process, numpy's core made to look unknown: nothing is set
    found = probe("import jamlab.spheres.blas as b\nb.numpy_core = lambda: 'NeoverseV2'\n"
                  "from jamlab.spheres.aqs import linalg\nblas = b", "blas.choice()")
    assert found["choice"]["coretype"] is None and "left alone" in found["choice"]["reason"]
