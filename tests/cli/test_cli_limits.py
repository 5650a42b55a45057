"""Inputs beyond what a run can hold, found by an audit of every command with bad input
(2026-12-07): each gave a traceback, a crash, a hang, or wrong data reported as fine. Each must
now be one line ``jamlab: error: …`` with exit code 2, before anything is written."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from cli_helpers import digest, error_line
from cli_helpers import run_in_process as run


@pytest.fixture(scope="module")
def over(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "over.h5"
    assert run(["prepare", "--n", "16", "--dim", "2", "--sizes", "bidisperse", "--phi", "0.9",
                "--seed", "2", "--out", path, "--quiet"]) == 0  # fmt: skip
    return path


def test_a_size_the_machine_cannot_hold_is_one_line(tmp_path, capsys):
    """numpy's MemoryError had come out as a 38-line traceback with exit code 1."""
    out = tmp_path / "new.h5"
    assert run(["random-packing", "--out", out, "--n", "100000000000000", "--phi", "0.5"]) == 2
    assert "out of memory" in error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize("args, name", [
    (["minimize", "{over}", "--out", "{tmp}/m.h5", "--max-iter", "99999999999999999999999"],
     "--max-iter"),  # numba could not take the number: a traceback
    (["shear", "{over}", "--dgamma", "1e-3", "--gamma-max", "3e-3", "--out", "{tmp}/s.h5",
      "--save-every", "99999999999999999999999"],
     "--save-every"),  # failed writing the trace after the whole run: the result was lost
    (["run", "-q", "--workers", "0", "--dim", "2", "--sizes", "bidisperse", "--samples",
      "99999999999999999999", "--dgamma", "1e-3", "--gamma-max", "3e-3", "--phi", "0.9", "--n",
      "16", "--out", "{tmp}/r"],
     "samples"),  # wrote a manifest, then hung
])
def test_counts_beyond_their_limit_are_refused(over, tmp_path, capsys, args, name):
    args = [a.format(over=over, tmp=tmp_path) for a in args]
    before = digest(over)
    assert run(args) == 2
    assert name in error_line(capsys)
    assert digest(over) == before
    assert list(tmp_path.iterdir()) == []


def test_a_run_may_not_end_beyond_the_strain_limit(over, tmp_path, capsys):
    """A configuration at γ = 999999.9 sheared by 1 had written files at γ = 1000000.9 that
    ``export`` then refused."""
    import dataclasses

    from jamlab.spheres.io import read_packing, write_packing

    start = tmp_path / "start.h5"
    pk = read_packing(over)
    write_packing(start, dataclasses.replace(pk, box=pk.box.with_strain(999999.9)))
    assert run(["shear", start, "--dgamma", "0.5", "--gamma-max", "1", "--out",
                tmp_path / "s.h5"]) == 2  # fmt: skip
    assert "1000000.9" in error_line(capsys)
    assert not (tmp_path / "s.h5").exists()


def test_resume_cannot_start_avalanche_records_midway(over, tmp_path, capsys):
    """Resumed with --keep-avalanches, a run that kept none had written a table covering only
    the resumed steps, with nothing in the file to say so."""
    out = tmp_path / "n.h5"
    assert run(["shear", over, "--dgamma", "1e-2", "--gamma-max", "0.1", "--out", out,
                "--save-every", "5"]) == 0  # fmt: skip
    capsys.readouterr()
    files = {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()}
    assert run(["shear", over, "--dgamma", "1e-2", "--gamma-max", "0.2", "--out", out,
                "--resume", "--keep-avalanches"]) == 2  # fmt: skip
    assert "kept no avalanche records" in error_line(capsys)
    assert {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()} == files


def test_theory_overflow_is_one_line(tmp_path, capsys):
    """Two RuntimeWarnings had come before the refusal (as errors here: pytest would capture
    them apart from stderr)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        code = run(["theory", "--dgamma", "1e-2", "--points", "20", "--out", tmp_path / "t.png",
                    "--amplitude", "1e308"])  # fmt: skip
    assert code == 2
    error_line(capsys)


@pytest.mark.parametrize("dim", [16, 65])
def test_high_dimensional_text_positions(tmp_path, capsys, dim):
    """65 coordinates per line had been imported (the limit is 64) and then failed every reader;
    16 were imported and crashed ``inspect`` (MemoryError; 32 and 64 a segmentation fault in
    ``minimize``): the cell list had 3^d cells for two spheres."""
    text = tmp_path / "c.txt"
    np.savetxt(text, np.array([[1.0] * dim, [1.5] + [1.0] * (dim - 1)]))
    out = tmp_path / "c.h5"
    code = run(["import-xyz", text, "--out", out, "--box-length", "5"])
    if dim > 64:
        assert code == 2
        assert "dimension" in error_line(capsys)
        assert not out.exists()
        return
    assert code == 0
    assert run(["minimize", out, "--out", tmp_path / "m.h5"]) == 0
    assert "converged" in capsys.readouterr().out
