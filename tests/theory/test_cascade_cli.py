"""``jamlab cascade``: runs end to end, writes figures and CSV; bad input: one line, exit 2."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

# the command plots the printed theory of jamlab.theory.jumps beside the samples
pytest.importorskip("jamlab.theory.jumps")


def run(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "jamlab", "cascade", *args], capture_output=True,
                          text=True, timeout=300, cwd=cwd)


def test_cascade_command_writes_outputs(tmp_path):
    out, csv, tree = tmp_path / "c.png", tmp_path / "c.csv", tmp_path / "t.png"
    r = run("--q", "0,0.5", "--y", "0.5,1.5", "--dgamma", "0.3", "--n", "3000", "--seed", "3",
            "--out", str(out), "--csv", str(csv), "--tree", str(tree))
    assert r.returncode == 0, r.stderr
    assert "p_no_jump sampled" in r.stdout and "printed formula" in r.stdout
    assert out.stat().st_size > 0 and tree.stat().st_size > 0
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert data.shape == (3000, 5)
    np.testing.assert_allclose(data[:, 0], data[:, 1] - 0.3 * data[:, 2], atol=1e-12)


def test_cascade_command_bad_input_is_one_line_exit_2(tmp_path):
    for args in (["--q", "0,0.5", "--y", "1.5,0.5"], ["--linear", "2.5", "--q", "0"],
                 ["--linear", "2.5", "--q-max", "0.9", "--k", "8", "--n", "0"]):
        r = run(*args, "--out", str(tmp_path / "x.png"))
        assert r.returncode == 2, (args, r.stderr)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("jamlab: error:"), r.stderr
