"""``jamlab shear``: trace file contents, resume, plot, and one-line errors."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

import jamlab.spheres as sp
from cli_helpers import jamlab, one_line_error
from jamlab.spheres.fire import minimize
from jamlab.spheres.io import read_packing, write_packing
from jamlab.spheres.trace import OPTIONAL_COLUMNS, TRACE_COLUMNS, read_trace


@pytest.fixture(scope="module")
def start(tmp_path_factory):
    packing = minimize(sp.random_packing(64, 3, 0.8, seed=11), ftol=1e-12).packing
    path = tmp_path_factory.mktemp("cfg") / "start.h5"
    write_packing(path, packing)
    return path, packing


def test_shear_writes_the_documented_trace(start, tmp_path):
    path, packing = start
    out = tmp_path / "trace.h5"
    fig = tmp_path / "fig.png"
    r = jamlab(
        "shear",
        str(path),
        "--dgamma",
        "1e-5",
        "--gamma-max",
        "1e-4",
        "--out",
        str(out),
        "--plot",
        str(fig),
    )
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as h5:
        # format version 2: the optional jammed and phi columns, and the last configuration
        assert set(h5.keys()) == set(TRACE_COLUMNS) | set(OPTIONAL_COLUMNS) | {"configuration"}
        assert all(h5[k].shape == (11,) for k in TRACE_COLUMNS + OPTIONAL_COLUMNS)
        assert h5.attrs["format_version"] == 2
        assert h5["configuration/positions"].shape == (packing.n, packing.dim)
        for key in (
            "dgamma",
            "gamma_max",
            "ftol",
            "minimizer",
            "N",
            "dim",
            "phi",
            "seed",
            "jamlab_version",
            "source",
        ):
            assert key in h5.attrs, key
        assert h5.attrs["N"] == 64 and h5.attrs["minimizer"] == "linear"
        assert h5.attrs["source"] == str(path)
    tr = read_trace(out)
    np.testing.assert_allclose(tr.gamma, 1e-5 * np.arange(11), rtol=1e-12, atol=0)
    # row 0 is the input minimum, measured independently
    assert tr.energy[0] == pytest.approx(sp.energy(packing), rel=1e-12)
    assert tr.shear_stress[0] == pytest.approx(sp.shear_stress(packing), rel=1e-10)
    assert np.all(tr.max_force < 1e-12)
    assert fig.is_file() and fig.stat().st_size > 1000


def test_shear_resume_matches_one_run(start, tmp_path):
    path, _ = start
    whole = tmp_path / "whole.h5"
    part = tmp_path / "part.h5"
    args = ("--dgamma", "1e-5", "--minimizer", "fire")
    assert (
        jamlab("shear", str(path), *args, "--gamma-max", "8e-5", "--out", str(whole)).returncode
        == 0
    )
    r = jamlab(
        "shear", str(path), *args, "--gamma-max", "4e-5", "--out", str(part), "--save-every", "2"
    )
    assert r.returncode == 0, r.stderr
    r = jamlab("shear", str(path), *args, "--gamma-max", "8e-5", "--out", str(part), "--resume")
    assert r.returncode == 0, r.stderr
    a, b = read_trace(whole), read_trace(part)
    assert b.n_steps == a.n_steps == 8
    np.testing.assert_allclose(b.energy, a.energy, rtol=1e-12)


@pytest.mark.parametrize(
    "args, needle",
    [
        (("--dgamma", "0", "--gamma-max", "0.01"), "dgamma"),
        (("--dgamma", "-1e-5", "--gamma-max", "0.01"), "dgamma"),
        (("--dgamma", "0.02", "--gamma-max", "0.01"), "gamma-max"),
        (("--dgamma", "1e-5", "--gamma-max", "1e-5"), "gamma-max"),
        (("--dgamma", "1e-5", "--gamma-max", "1e-4", "--minimizer", "cg"), "minimizer"),
        (("--dgamma", "1e-5", "--gamma-max", "1e-4", "--pressure", "-1"), "--pressure"),
        (("--dgamma", "1e-5", "--gamma-max", "1e-4", "--pressure", "nan"), "--pressure"),
        (("--dgamma", "1e-5", "--gamma-max", "1e-4", "--pressure", "1e-3", "--ptol", "0"), "ptol"),
        (
            ("--dgamma", "1e-5", "--gamma-max", "1e-4", "--pressure", "1e-3", "--save-every", "0"),
            "--save-every",
        ),
        (("--dgamma", "1e-5", "--gamma-max", "1e-4", "--volume-guess", "never"), "--pressure"),
        (
            ("--dgamma", "1e-5", "--gamma-max", "1e-4", "--pressure", "1e-3", "--volume-guess",
             "often"),
            "--volume-guess must be",
        ),
    ],
)
def test_bad_arguments_are_one_line_errors(start, tmp_path, args, needle):
    path, _ = start
    line = one_line_error(jamlab("shear", str(path), *args, "--out", str(tmp_path / "t.h5")))
    assert needle in line


def test_missing_file_is_one_line_error(tmp_path):
    line = one_line_error(
        jamlab(
            "shear",
            str(tmp_path / "nope.h5"),
            "--dgamma",
            "1e-5",
            "--gamma-max",
            "1e-3",
            "--out",
            str(tmp_path / "t.h5"),
        )
    )
    assert "nope.h5" in line


def test_shear_at_fixed_pressure(start, tmp_path):
    path, packing = start
    out = tmp_path / "p.h5"
    r = jamlab(
        "shear",
        str(path),
        "--dgamma",
        "1e-4",
        "--gamma-max",
        "1e-3",
        "--out",
        str(out),
        "--pressure",
        "1e-2",
    )
    assert r.returncode == 0, r.stderr
    assert "fixed p=0.01" in r.stdout
    tr = read_trace(out)
    assert tr.n_steps == 10 and tr.attrs["protocol"] == "fixed-pressure"
    assert np.all(np.abs(tr.pressure - 1e-2) <= 1e-8)
    assert tr.phi[0] < packing.phi  # phi = 0.8 carries p >> 1e-2: the box expands
    assert tr.jammed.all()
    assert tr.attrs["volume_guess"] == "elastic"  # the default rule, recorded


def test_floppy_option_is_recorded_and_checked(start, tmp_path):
    path, _ = start
    out = tmp_path / "t.h5"
    args = ("shear", str(path), "--dgamma", "1e-5", "--gamma-max", "3e-5", "--out", str(out))
    r = jamlab(*args, "--floppy", "project")
    assert r.returncode == 0, r.stderr
    assert read_trace(out).attrs["floppy"] == "project"
    # resumed with another choice: refused, the file kept
    before = out.read_bytes()
    r = jamlab("shear", str(path), "--dgamma", "1e-5", "--gamma-max", "5e-5", "--out", str(out),
               "--resume")
    assert "floppy" in one_line_error(r) and out.read_bytes() == before
    for extra, words in ((("--floppy", "newton"), "--floppy must be"),
                         (("--floppy", "project", "--pressure", "1e-3"), "constant volume"),
                         (("--floppy", "project", "--minimizer", "fire"), "constant volume")):
        r = jamlab("shear", str(path), "--dgamma", "1e-5", "--gamma-max", "3e-5", "--out",
                   str(tmp_path / "other.h5"), *extra)
        assert words in one_line_error(r)


@pytest.mark.parametrize("bad", ["dgamma", "garbage input"])
def test_refused_force_rerun_keeps_the_earlier_run(start, tmp_path, bad):
    """`shear --force` refused for a bad argument or an unreadable input changes nothing on disk:
    the earlier run's trace, its .last.h5 and every snapshot in w.configs/ stay as they were."""
    path, _ = start
    out = tmp_path / "w.h5"
    first = jamlab("shear", path, "--dgamma", "1e-3", "--gamma-max", "5e-3", "--save-every", "2",
                   "--out", out)  # fmt: skip
    assert first.returncode == 0, first.stderr
    files = [out, tmp_path / "w.last.h5", *sorted((tmp_path / "w.configs").iterdir())]
    assert len(files) == 5
    before = {f: f.read_bytes() for f in files}
    if bad == "dgamma":
        args, needle = (path, "--dgamma", "1", "--gamma-max", "3e-3"), "--dgamma"
    else:
        garbage = tmp_path / "garbage.h5"
        garbage.write_bytes(b"not hdf5 at all")
        args, needle = (garbage, "--dgamma", "1e-3", "--gamma-max", "3e-3"), "not an HDF5 file"
    assert needle in one_line_error(jamlab("shear", *args, "--out", out, "--force"))
    assert sorted(tmp_path.glob("w*")) == sorted([out, tmp_path / "w.last.h5",
                                                  tmp_path / "w.configs"])
    assert sorted((tmp_path / "w.configs").iterdir()) == files[2:]
    assert {f: f.read_bytes() for f in files} == before
    assert jamlab("export", out, "--out", tmp_path / "m.xyz").returncode == 0


# `jamlab shear ARGS` in a subprocess that dies (os._exit: no clean-up, as SIGKILL) or fails at
# one point of a run replacing an earlier one; argv[1] names the point
_DIE_AT = r"""
import os, sys
import jamlab.spheres.aqs.checkpoint as checkpoint
import jamlab.spheres.aqs.driver as driver
import jamlab.spheres.io as io
from jamlab.cli import main

where, real_replace, real_write = sys.argv[1], os.replace, io.write_packing
moved = []

def die(*args, **kwargs):
    os._exit(9)

def replace(src, dst):  # dies after moving one old snapshot aside
    if "step_" in str(src) and ".replacing" in str(dst):
        if moved:
            os._exit(9)
        moved.append(src)
    real_replace(src, dst)

def write_packing(path, *args, **kwargs):  # dies writing <stem>.last.h5, after the trace
    if str(path).endswith(".last.h5"):
        os._exit(9)
    return real_write(path, *args, **kwargs)

def disk_full(*args, **kwargs):
    raise OSError(28, "No space left on device")

if where == "before the first save":
    driver.save_checkpoint = die
elif where == "moving the old snapshots":
    os.replace = replace
elif where == "after the new snapshot":
    checkpoint.write_trace = die
elif where == "after the new trace":
    io.write_packing = write_packing
elif where == "disk full at the trace":
    checkpoint.write_trace = disk_full
main(["shear", *sys.argv[2:]])
"""

_FIRST = ("--dgamma", "1e-3", "--gamma-max", "5e-3", "--save-every", "2")
# the new run: other strains, its only save at step 4 (a name the earlier run's snapshots use)
_SECOND = ("--dgamma", "5e-4", "--gamma-max", "2e-3", "--save-every", "4", "--force")


def _files(directory):
    """``{path: bytes}`` of the files below ``directory``, hidden ones left out."""
    return {p.relative_to(directory): p.read_bytes() for p in directory.rglob("*")
            if p.is_file() and not any(part.startswith(".") for part in p.parts)}


def _hidden(directory):
    return sorted(p.name for p in directory.iterdir() if p.name.startswith("."))


@pytest.mark.parametrize("where", ["before the first save", "moving the old snapshots",
                                   "after the new snapshot", "disk full at the trace",
                                   "after the new trace"])
def test_force_rerun_killed_before_its_first_save_keeps_the_earlier_run(start, tmp_path, where):
    """A `shear --force` over an earlier run killed (or failing) at any point before its trace
    replaced w.h5 leaves the earlier run whole — w.h5, w.last.h5 and every snapshot
    byte-identical — once the next `jamlab shear` to w.h5 (here a refused one) has run; killed
    after, the new run's files replace the earlier ones and nothing of those is left."""
    import subprocess
    import sys

    path, _ = start
    rundir = tmp_path / "run"
    rundir.mkdir()
    out = rundir / "w.h5"
    assert jamlab("shear", path, *_FIRST, "--out", out).returncode == 0
    before = _files(rundir)
    assert sorted(map(str, before)) == ["w.configs/step_00000002.h5", "w.configs/step_00000004.h5",
                                        "w.configs/step_00000005.h5", "w.h5", "w.last.h5"]
    killed = subprocess.run([sys.executable, "-c", _DIE_AT, where, path, *_SECOND, "--out", out],
                            capture_output=True, text=True, timeout=600)
    assert killed.returncode == (2 if where == "disk full at the trace" else 9), killed.stderr
    if where == "disk full at the trace":  # a failure is undone by the command itself
        assert "No space left on device" in one_line_error(killed)
        assert _files(rundir) == before and _hidden(rundir) == []
    elif where == "before the first save":  # nothing moved yet: the earlier run is whole
        assert _files(rundir) == before and _hidden(rundir) == [".w.h5.replacing"]
        assert jamlab("export", out, "--out", tmp_path / "m0.xyz").returncode == 0
    elif where != "after the new trace":
        # the old snapshots are (partly) aside: export says so instead of mixing two runs
        error = one_line_error(jamlab("export", out, "--out", tmp_path / "m0.xyz"))
        assert "was killed at its first save" in error
    refused = jamlab("shear", path, "--dgamma", "1", "--gamma-max", "3e-3", "--out", out,
                     "--force")
    assert refused.returncode == 2 and "--dgamma" in refused.stderr.splitlines()[-1]
    assert _hidden(rundir) == []
    if where != "after the new trace":
        assert _files(rundir) == before
        assert jamlab("export", out, "--out", tmp_path / "m.xyz").returncode == 0
        return
    # the new trace had replaced w.h5: only the new run's files, w.last.h5 its last minimum
    after = _files(rundir)
    assert sorted(map(str, after)) == ["w.configs/step_00000004.h5", "w.h5", "w.last.h5"]
    assert after[Path("w.h5")] != before[Path("w.h5")]
    trace = read_trace(out)
    assert trace.n_steps == 4 and trace.attrs["dgamma"] == 5e-4
    last, snap = (read_packing(rundir / f) for f in ("w.last.h5", "w.configs/step_00000004.h5"))
    assert last.strain == snap.strain == float(trace.gamma[-1])
    np.testing.assert_array_equal(last.positions, snap.positions)
    r = jamlab("export", out, "--out", tmp_path / "m.xyz")
    assert r.returncode == 0 and "1 frame(s), AQS steps 4..4" in r.stdout, r.stderr


def test_force_rerun_leaves_only_the_new_runs_files(start, tmp_path):
    path, _ = start
    rundir = tmp_path / "run"
    rundir.mkdir()
    out = rundir / "w.h5"
    assert jamlab("shear", path, *_FIRST, "--out", out).returncode == 0
    r = jamlab("shear", path, *_SECOND, "--out", out)
    assert r.returncode == 0, r.stderr
    assert sorted(str(p.relative_to(rundir)) for p in rundir.rglob("*")) == [
        "w.configs", "w.configs/step_00000004.h5", "w.h5", "w.last.h5"]
    assert read_trace(out).attrs["dgamma"] == 5e-4
    r = jamlab("export", out, "--out", tmp_path / "m.xyz")
    assert r.returncode == 0 and "1 frame(s), AQS steps 4..4" in r.stdout, r.stderr
