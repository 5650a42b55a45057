"""Issue 15: `jamlab shear --resume` is the uninterrupted run bit for bit — after a split at the
end of a shorter run and after SIGKILL at random moments — in every dataset and attribute of
the trace file; and `--resume` keeps (or refuses to change) the run's --save-every."""

from __future__ import annotations

import json
import platform
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from cli_helpers import jamlab, one_line_error, shear_loop_seconds
from jamlab.spheres.io import write_packing
from jamlab.spheres.packing import prepare


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    """Issue 15's G: `jamlab prepare --n 32 --phi 0.8 --seed 1`."""
    path = tmp_path_factory.mktemp("good") / "good.h5"
    write_packing(path, prepare(32, 3, 0.8, 1).packing)
    return path


def h5_contents(path: Path) -> dict:
    """Every dataset's bytes and every attribute (``source`` left out: it names the input file,
    the same in every run here anyway; ``provenance`` too: one record per invocation, so a
    resumed run has more, checked by :func:`invocations`) of an HDF5 file, by name."""
    out = {}
    with h5py.File(path, "r") as h5:
        out["/attrs"] = {k: str(v) for k, v in h5.attrs.items()
                         if k not in ("source", "provenance")}

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                out[name] = (obj.dtype.str, obj.shape, obj[()].tobytes())
            else:
                out[name + "/attrs"] = {k: str(v) for k, v in obj.attrs.items()}

        h5.visititems(visit)
    return out


def invocations(path: Path) -> list[int]:
    """The steps each invocation of a trace's run resumed from (-1: started afresh), from its
    ``provenance`` records, each of which must name this machine and Python."""
    with h5py.File(path, "r") as h5:
        records = json.loads(h5.attrs["provenance"])
    for record in records:
        assert record["python"] == platform.python_version() and record["cpu"]
    return [record["resumed_from"] for record in records]


def same_file(a: Path, b: Path) -> list[str]:
    ca, cb = h5_contents(a), h5_contents(b)
    return sorted(k for k in ca.keys() | cb.keys() if ca.get(k) != cb.get(k))


def test_issue_split_then_resume_equals_one_run(good, tmp_path):
    """The issue's commands, shortened to γ = 0.06 (600 steps, through the plastic steps 135,
    177 and 240): to 0.04 with --save-every 50, then --gamma-max 0.06 --resume, against one run."""
    one = tmp_path / "one.h5"
    split = tmp_path / "d.h5"
    args = ("--dgamma", "1e-4", "--save-every", "50")
    assert jamlab("shear", good, *args, "--gamma-max", "0.06", "--out", one).returncode == 0
    assert jamlab("shear", good, *args, "--gamma-max", "0.04", "--out", split).returncode == 0
    # --save-every may be left out on resume: the run's own is kept
    r = jamlab("shear", good, "--dgamma", "1e-4", "--gamma-max", "0.06", "--resume",
               "--out", split)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert same_file(one, split) == []
    assert invocations(one) == [-1] and invocations(split) == [-1, 400]
    with h5py.File(one, "r") as h5:
        assert np.count_nonzero(h5["plastic"][()]) >= 3


def test_resume_with_another_save_every_is_refused(good, tmp_path):
    out = tmp_path / "w.h5"
    assert jamlab("shear", good, "--dgamma", "1e-4", "--gamma-max", "0.002", "--save-every",
                  "5", "--out", out).returncode == 0  # fmt: skip
    before = out.read_bytes()
    line = one_line_error(jamlab("shear", good, "--dgamma", "1e-4", "--gamma-max", "0.004",
                                 "--save-every", "7", "--resume", "--out", out))  # fmt: skip
    assert "save-every" in line
    assert out.read_bytes() == before


def written(path: Path) -> int:
    """Steps in the trace file at ``path`` (0 if none yet; it is replaced atomically)."""
    try:
        with h5py.File(path, "r") as h5:
            return h5["gamma"].shape[0] - 1
    except (OSError, KeyError):
        return 0


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume_is_the_uninterrupted_run(good, tmp_path):
    """SIGKILL of `shear --save-every 20` (400 steps, through the plastic steps 135, 177, 240)
    at random moments of its stepping loop (a random time after a random checkpoint, so that
    the time spent starting Python does not waste trials), then `--resume`, in 20 trials: every
    time the trace file equals the uninterrupted run's in every dataset and attribute."""
    args = ("--dgamma", "1e-4", "--gamma-max", "0.04", "--save-every", "20")
    ref = tmp_path / "ref.h5"
    loop = shear_loop_seconds(good, args, ref, poll=0.01)  # after the first checkpoint
    rng = np.random.default_rng(1515)
    done_at = []
    for trial in range(20):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        out = d / "w.h5"
        cmd = [sys.executable, "-m", "jamlab", "shear", str(good), *args, "--out", str(out)]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        # kill at a random moment after a random checkpoint (wall times on a shared machine
        # are too noisy to aim at the run's middle by the clock alone)
        target = int(rng.choice(np.arange(20, 400, 20)))
        while proc.poll() is None and written(out) < target:
            time.sleep(0.005)
        time.sleep(rng.uniform(0.0, 0.05) * loop)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        with h5py.File(out, "r") as h5:
            done = h5["gamma"].shape[0] - 1
        done_at.append(done)
        if done == 400:  # killed after the end: nothing to resume, and nothing lost
            assert "nothing to do" in one_line_error(
                jamlab("shear", good, *args, "--resume", "--out", out)
            )
        else:
            r = jamlab("shear", good, *args, "--resume", "--out", out)
            assert r.returncode == 0, (trial, r.stderr)
        assert same_file(ref, out) == [], (trial, done, same_file(ref, out))
        if done < 400:  # the resumed run's records: the killed invocation's, then the resume's
            assert invocations(out) == [-1, done], (trial, done, invocations(out))
    # the kills landed at many different checkpoints, most inside the run
    assert len(set(done_at)) >= 5 and sum(d < 400 for d in done_at) >= 15, done_at
