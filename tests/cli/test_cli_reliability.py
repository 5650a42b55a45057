"""Issue 15 (reliability), one test per defect found on main at 09aa8ce with tiny systems: no
input destroyed, one line and exit 2 for bad input, nothing wrong reported as fine.

Each test fails on 09aa8ce (checked by running this file with ``PYTHONPATH=/work/main/src``)."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import jamlab.spheres as sp
from cli_helpers import jamlab, one_line_error, shear_loop_seconds, wait_for_file
from jamlab.spheres.fire import minimize
from jamlab.spheres.io import write_packing
from jamlab.spheres.trace import read_trace, write_trace

SHEAR = ("--dgamma", "1e-3", "--gamma-max", "5e-3")


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    """G: a minimised N = 32, φ = 0.8 configuration (as `jamlab prepare --n 32 --phi 0.8`)."""
    packing = minimize(sp.random_packing(32, 3, 0.8, seed=1), ftol=1e-12).packing
    path = tmp_path_factory.mktemp("good") / "good.h5"
    write_packing(path, packing)
    return path


def digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def copy(src: Path, dst: Path) -> Path:
    shutil.copyfile(src, dst)
    return dst


# -- data loss: an output that is an input -------------------------------------------------------


def test_shear_out_equal_to_input_is_refused(good, tmp_path):
    same = copy(good, tmp_path / "same.h5")
    before = digest(same)
    line = one_line_error(jamlab("shear", same, *SHEAR, "--out", same))
    assert "same file" in line and digest(same) == before


def test_shear_into_its_own_checkpoint_is_refused(good, tmp_path):
    # `shear w.last.h5 ... --out w.h5` would overwrite w.last.h5, its own input, at the first save
    src = copy(good, tmp_path / "w.last.h5")
    before = digest(src)
    line = one_line_error(jamlab("shear", src, *SHEAR, "--out", tmp_path / "w.h5"))
    assert "same file" in line and digest(src) == before
    assert not (tmp_path / "w.h5").exists()


def test_shear_input_inside_the_snapshot_directory_is_refused(good, tmp_path):
    (tmp_path / "w.configs").mkdir()
    src = copy(good, tmp_path / "w.configs" / "step_00000005.h5")
    before = digest(src)
    one_line_error(jamlab("shear", src, *SHEAR, "--save-every", "5", "--out", tmp_path / "w.h5"))
    assert digest(src) == before


def test_minimize_in_place_is_refused(good, tmp_path):
    x = copy(good, tmp_path / "x.h5")
    before = digest(x)
    line = one_line_error(jamlab("minimize", x, "--out", x))
    assert "same file" in line and digest(x) == before


def test_output_through_a_link_is_refused(good, tmp_path):
    x = copy(good, tmp_path / "x.h5")
    (tmp_path / "link.h5").symlink_to(x)
    os.link(x, tmp_path / "hard.h5")
    before = digest(x)
    one_line_error(jamlab("minimize", x, "--out", tmp_path / "link.h5"))
    one_line_error(jamlab("minimize", x, "--out", tmp_path / "hard.h5"))
    assert digest(x) == before


def test_coordination_csv_equal_to_input_is_refused(good, tmp_path):
    jam = copy(good, tmp_path / "jam.h5")
    before = digest(jam)
    line = one_line_error(
        jamlab("coordination", jam, "--csv", jam, "--out", tmp_path / "f.png", "--quiet")
    )
    assert "same file" in line and digest(jam) == before


def test_import_xyz_out_equal_to_input_is_refused(tmp_path):
    pos = tmp_path / "pos.txt"
    np.savetxt(pos, np.random.default_rng(0).uniform(0, 3.5, size=(32, 3)))
    before = digest(pos)
    line = one_line_error(jamlab("import-xyz", pos, "--box-length", "3.5", "--out", pos))
    assert "same file" in line and digest(pos) == before


def test_two_outputs_that_are_one_file_are_refused(tmp_path):
    out = tmp_path / "t.png"
    one_line_error(jamlab("theory", "--out", out, "--csv", out))
    assert not out.exists()


@pytest.mark.parametrize("command", ["minimize", "shear", "prepare", "random-packing", "theory"])
def test_out_an_existing_directory_is_refused_before_computing(good, tmp_path, command):
    d = tmp_path / "d"
    d.mkdir()
    args = {
        "minimize": ("minimize", good, "--out", d),
        "shear": ("shear", good, *SHEAR, "--out", d),
        "prepare": ("prepare", "--n", 32, "--phi", 0.8, "--quiet", "--out", d),
        "random-packing": ("random-packing", "--n", 32, "--phi", 0.5, "--out", d),
        "theory": ("theory", "--out", d),
    }[command]
    start = time.perf_counter()
    line = one_line_error(jamlab(*args))
    assert "directory" in line
    assert list(d.iterdir()) == [] and time.perf_counter() - start < 30


# -- tracebacks instead of one line -----------------------------------------------------------


def test_positions_stored_as_a_group_is_one_line(tmp_path):
    bad = tmp_path / "group.h5"
    with h5py.File(bad, "w") as h5:
        h5.create_group("positions")
        h5.attrs.update({"box_length": 4.0, "strain": 0.0, "dim": 3})
    before = digest(bad)
    for args in (("inspect", bad), ("minimize", bad, "--out", tmp_path / "o.h5"),
                 ("shear", bad, *SHEAR, "--out", tmp_path / "t.h5")):  # fmt: skip
        assert "positions" in one_line_error(jamlab(*args))
    assert digest(bad) == before


@pytest.mark.parametrize("link", ["soft", "external"])
def test_a_dangling_link_is_one_line(good, tmp_path, link):
    """A dataset that is a soft link to nothing or an external link to a missing file: h5py lists
    it but raises KeyError on access; the readers call the file damaged."""
    target = h5py.SoftLink("/nothere") if link == "soft" else h5py.ExternalLink("no.h5", "/x")
    bad = copy(good, tmp_path / "d.h5")
    with h5py.File(bad, "a") as h5:
        for key in ("summary", "summary_key"):
            h5.attrs.pop(key, None)
        del h5["positions"]
        h5["positions"] = target
    before = digest(bad)
    for args in (("inspect", bad), ("shear", bad, *SHEAR, "--out", tmp_path / "t.h5")):
        line = one_line_error(jamlab(*args))
        assert "damaged file" in line and "positions" in line
    assert digest(bad) == before and not (tmp_path / "t.h5").exists()


def test_a_trace_column_as_a_dangling_link_is_one_line(good, checkpointed, tmp_path):
    for name in ("w.h5", "w.last.h5"):
        copy(checkpointed / name, tmp_path / name)
    with h5py.File(tmp_path / "w.h5", "a") as h5:
        del h5["gamma"]
        h5["gamma"] = h5py.SoftLink("/nothere")
    before = digest(tmp_path / "w.h5")
    line = one_line_error(jamlab("shear", good, "--dgamma", "1e-3", "--gamma-max", "0.04",
                                 "--out", tmp_path / "w.h5", "--resume"))  # fmt: skip
    assert "damaged file" in line and "gamma" in line
    assert digest(tmp_path / "w.h5") == before


@pytest.mark.parametrize("link", ["soft", "external"])
def test_a_dangling_link_in_the_traces_configuration_is_one_line(good, checkpointed, tmp_path,
                                                                   link):
    """The configuration a trace carries for --resume, its diameters a dangling link: h5py's
    ``group.get`` returns None for it, and the run went on with diameters of 1 (exit 0)."""
    for name in ("w.h5", "w.last.h5"):
        copy(checkpointed / name, tmp_path / name)
    shutil.copytree(checkpointed / "w.configs", tmp_path / "w.configs")
    with h5py.File(tmp_path / "w.h5", "a") as h5:
        del h5["configuration/diameters"]
        h5["configuration/diameters"] = (h5py.SoftLink("/nothere") if link == "soft"
                                         else h5py.ExternalLink("no.h5", "/x"))
    files = sorted(p for p in tmp_path.rglob("*") if p.is_file())
    before = [digest(p) for p in files]
    line = one_line_error(jamlab("shear", good, "--dgamma", "1e-3", "--gamma-max", "0.04",
                                 "--out", tmp_path / "w.h5", "--resume"))  # fmt: skip
    assert "damaged file" in line and "w.h5" in line and "/configuration/diameters" in line
    assert sorted(p for p in tmp_path.rglob("*") if p.is_file()) == files
    assert [digest(p) for p in files] == before


@pytest.mark.parametrize(
    "args",
    [
        ("random-packing", "--n", 32, "--phi", 0.5),
        ("prepare", "--n", 32, "--phi", 0.8, "--quiet"),
        ("run", "--n", 32, "--phi", 0.8, "--samples", 1, "--dgamma", 1e-3, "--gamma-max", 3e-3),
    ],
)
def test_absurd_dim_is_one_line(tmp_path, args):
    out = tmp_path / "o"
    line = one_line_error(jamlab(*args, "--dim", 1_000_000, "--out", out))
    assert "dim must be an integer in [2, 64]" in line and not out.exists()


@pytest.mark.parametrize(
    "args",
    [
        ("random-packing", "--n", 32, "--phi", 0.5, "--seed", 2**64),
        ("prepare", "--n", 32, "--phi", 0.8, "--quiet", "--seed", 2**64),
        ("cascade", "--linear", 1, "--n", 10, "--seed", 2**64),
    ],
)
def test_seed_of_2_to_the_64_is_one_line(tmp_path, args):
    out = tmp_path / "o.h5"
    line = one_line_error(jamlab(*args, "--out", out))
    assert "seed" in line and not out.exists()


def test_run_seed_of_2_to_the_64_writes_nothing(tmp_path):
    run = tmp_path / "r"
    base = ("run", "--phi", 0.8, "--n", 32, "--samples", 1, "--dgamma", 1e-3, "--gamma-max", 3e-3)
    for _ in range(2):  # on 09aa8ce the first call made the directory, every rerun then crashed
        line = one_line_error(jamlab(*base, "--seed", 2**64, "--out", run, "--quiet"))
        assert "seed" in line and not run.exists()


@pytest.mark.parametrize(
    "args, needle",
    [
        (("--dgamma", "1e-320", "--gamma-max", "1e-3"), "steps"),
        (("--dgamma", "1e-3", "--gamma-max", "1e300"), "gamma-max"),
        (("--dgamma", "1e-3", "--gamma-max", "1e5"), "steps"),
        (("--dgamma", "1e-3", "--gamma-max", "5e-3", "--save-every", "0"), "save-every"),
        (("--dgamma", "1e-3", "--gamma-max", "5e-3", "--ftol", "nan"), "ftol"),
    ],
)
def test_absurd_strain_steps_are_one_line(good, tmp_path, args, needle):
    out = tmp_path / "t.h5"
    assert needle in one_line_error(jamlab("shear", good, *args, "--out", out))
    assert not out.exists()


@pytest.mark.parametrize("dgamma", ["1e300", "-1e300", "1e-320"])
def test_theory_absurd_dgamma_is_one_line(tmp_path, dgamma):
    out = tmp_path / "t.png"
    assert "dgamma" in one_line_error(jamlab("theory", "--out", out, "--dgamma", dgamma))
    assert not out.exists()


@pytest.mark.parametrize(
    "meta", ["{not json", '{"seed_of_random_start": 1}', '{"box_length": "big"}', "[1, 2]",
             '{"box_length": 3.5, "seed_of_random_start": -4}', b"\xff\xfe"],  # fmt: skip
)
def test_import_xyz_malformed_meta_json_is_one_line(tmp_path, meta):
    pos = tmp_path / "positions.txt"
    np.savetxt(pos, np.random.default_rng(0).uniform(0, 3.5, size=(32, 3)))
    path = tmp_path / "meta.json"
    path.write_bytes(meta if isinstance(meta, bytes) else meta.encode())
    line = one_line_error(jamlab("import-xyz", pos, "--out", tmp_path / "o.h5"))
    assert "meta.json" in line and not (tmp_path / "o.h5").exists()


def test_import_xyz_absurd_strain_is_refused(tmp_path):
    pos = tmp_path / "pos.txt"
    np.savetxt(pos, np.random.default_rng(0).uniform(0, 3.5, size=(32, 3)))
    one_line_error(
        jamlab("import-xyz", pos, "--box-length", 3.5, "--strain", 1e17, "--out", tmp_path / "o")
    )
    assert not (tmp_path / "o").exists()


def test_shear_of_a_configuration_at_absurd_strain_is_refused(good, tmp_path):
    # a file written elsewhere at γ = 1e17: γ + δγ == γ, the run would record nothing happening
    packing = sp.read_packing(good)
    far = tmp_path / "far.h5"
    write_packing(far, sp.Packing(packing.positions, sp.Box(packing.box.length, 3, 1e17)))
    out = tmp_path / "t.h5"
    one_line_error(jamlab("shear", far, *SHEAR, "--out", out))
    assert not out.exists()


def test_toml_workers_two_is_one_line(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(
        'phi = [0.8]\nn = [32]\nsamples = 1\ndgamma = 1e-3\ngamma_max = 3e-3\nout = "r"\n'
        '[execution]\nworkers = "two"\n'
    )
    line = one_line_error(jamlab("run", study, "--quiet"))
    assert "workers" in line and not (tmp_path / "r").exists()


@pytest.mark.parametrize(
    "extra, needle",
    [(("--phi", "5.0"), "phi"), (("--phi", "0.8", "--dim", "10"), "box length"),
     (("--phi", "jamming", "--dim", "10"), "box length")],  # fmt: skip
)
def test_run_rejects_impossible_phi_and_dim_up_front(tmp_path, extra, needle):
    run = tmp_path / "r"
    args = ("run", "--n", 32, "--samples", 1, "--dgamma", 1e-3, "--gamma-max", 3e-3, *extra)
    assert needle in one_line_error(jamlab(*args, "--out", run, "--quiet"))
    assert not run.exists()


# -- shear --resume -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def checkpointed(good, tmp_path_factory):
    """A run to γ = 0.03 in steps of 1e-3, saved every 5 steps."""
    d = tmp_path_factory.mktemp("ckpt")
    r = jamlab("shear", good, "--dgamma", "1e-3", "--gamma-max", "0.03", "--save-every", "5",
               "--out", d / "w.h5")  # fmt: skip
    assert r.returncode == 0, r.stderr
    return d


def test_resume_after_a_kill_between_the_checkpoint_pair(good, checkpointed, tmp_path):
    """SIGKILL after ``w.last.h5`` (step 30) was written but before the trace (still at step 25):
    ``--resume`` continues from the snapshot of step 25 instead of refusing forever."""
    for name in ("w.last.h5", "w.configs"):
        src = checkpointed / name
        (shutil.copytree if src.is_dir() else shutil.copyfile)(src, tmp_path / name)
    whole = read_trace(checkpointed / "w.h5")
    write_trace(tmp_path / "w.h5", whole.head(26))  # the trace as it was at step 25
    r = jamlab("shear", good, "--dgamma", "1e-3", "--gamma-max", "0.04", "--resume",
               "--save-every", "5", "--out", tmp_path / "w.h5")  # fmt: skip
    assert r.returncode == 0, r.stderr
    resumed = read_trace(tmp_path / "w.h5")
    assert resumed.n_steps == 40
    np.testing.assert_array_equal(resumed.energy[:26], whole.energy[:26])
    np.testing.assert_allclose(resumed.gamma, 1e-3 * np.arange(41), rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "change, needle",
    [(("--ftol", "1e-10"), "ftol"), (("--minimizer", "fire"), "minimizer"),
     (("--dgamma", "2e-3"), "dgamma"), (("OTHER",), "configuration")],  # fmt: skip
)
def test_resume_with_other_parameters_or_configuration_is_refused(
    good, checkpointed, tmp_path, change, needle
):
    for name in ("w.h5", "w.last.h5"):
        shutil.copyfile(checkpointed / name, tmp_path / name)
    config = good
    extra = list(change)
    if change == ("OTHER",):
        config = tmp_path / "other.h5"
        write_packing(config, minimize(sp.random_packing(32, 3, 0.8, seed=2), 1e-12).packing)
        extra = []
    args = ["--dgamma", "1e-3", "--gamma-max", "0.04", "--resume", "--out", tmp_path / "w.h5"]
    if "--dgamma" in extra:
        args[:2] = extra
        extra = []
    before = {name: digest(tmp_path / name) for name in ("w.h5", "w.last.h5")}
    assert needle in one_line_error(jamlab("shear", config, *args, *extra))
    assert {name: digest(tmp_path / name) for name in before} == before


# -- files: modes, full disk ------------------------------------------------------------------


def test_output_files_respect_the_umask(good, tmp_path):
    env = dict(os.environ)
    for mask, mode in ((0o022, 0o644), (0o002, 0o664)):
        out = tmp_path / f"o{mask:o}.h5"
        code = f"import os, sys; os.umask({mask}); from jamlab.cli import main; main(sys.argv[1:])"
        r = subprocess.run([sys.executable, "-c", code, "minimize", str(good), "--out", str(out)],
                           capture_output=True, text=True, env=env)  # fmt: skip
        assert r.returncode == 0, r.stderr
        assert stat.S_IMODE(out.stat().st_mode) == mode


def test_a_full_disk_is_one_line_simulated(good, tmp_path, monkeypatch, capsys):
    """ENOSPC from the write itself (any machine; the tmpfs test below needs root)."""
    import jamlab.files as atomic
    from jamlab.cli import main

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp_path / "o.h5"))

    monkeypatch.setattr(atomic, "atomic_write_bytes", full)
    with pytest.raises(SystemExit) as exc:
        main(["minimize", str(good), "--out", str(tmp_path / "o.h5")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0]


@pytest.fixture
def full_disk(tmp_path):
    """A 300 kB tmpfs filled to the last byte (needs root; skipped otherwise)."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(mnt)],
                       capture_output=True)  # fmt: skip
    if r.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        subprocess.run(["dd", "if=/dev/zero", f"of={mnt / 'fill'}", "bs=4k"], capture_output=True)
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def test_a_full_disk_is_one_line(good, full_disk, tmp_path):
    before = digest(good)
    cases = [
        ("minimize", good, "--out", full_disk / "m.h5"),
        ("shear", good, *SHEAR, "--out", full_disk / "t.h5"),
        ("random-packing", "--n", 32, "--phi", 0.5, "--out", full_disk / "r.h5"),
        ("theory", "--out", full_disk / "t.png"),
        ("run", "--phi", 0.8, "--n", 32, "--samples", 1, "--dgamma", 1e-3, "--gamma-max", 3e-3,
         "--task", "toy", "--workers", 0, "--quiet", "--out", full_disk / "r"),
    ]  # fmt: skip
    for args in cases:
        line = one_line_error(jamlab(*args))
        assert "No space left on device" in line, line
    assert digest(good) == before
    leftovers = [p.name for p in full_disk.rglob("*") if p.name != "fill" and p.is_file()]
    assert not [name for name in leftovers if name.endswith(".tmp")]


# -- runs ---------------------------------------------------------------------------------------


def test_a_refused_run_never_writes_the_manifest(tmp_path):
    """Two drivers on one new directory: the one refused by the lock writes nothing (on 09aa8ce
    it wrote manifest.json before taking the lock)."""
    from jamlab.runs import RunDir

    run = tmp_path / "r"
    run.mkdir()
    base = ("run", "--phi", 0.8, "--n", 32, "--dgamma", 1e-3, "--gamma-max", 3e-3, "--task",
            "toy", "--workers", 0, "--quiet", "--out", run)  # fmt: skip
    with RunDir(run).lock():  # the first driver, between taking the lock and writing its manifest
        line = one_line_error(jamlab(*base, "--samples", 3))
    assert "another jamlab process" in line
    assert not (run / "manifest.json").exists()
    assert jamlab(*base, "--samples", 2).returncode == 0
    assert json.loads((run / "manifest.json").read_text())["study"]["samples"] == 2


def test_killing_the_driver_kills_its_workers(tmp_path):
    psutil = pytest.importorskip("psutil")  # installed with dask.distributed

    env = dict(os.environ, JAMLAB_TOY_DELAY="60")
    cmd = [sys.executable, "-m", "jamlab", "run", "--phi", "0.8", "--n", "32", "--samples", "2",
           "--dgamma", "1e-3", "--gamma-max", "3e-3", "--task", "toy", "--workers", "2",
           "--quiet", "--out", str(tmp_path / "r")]  # fmt: skip
    driver = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        parent = psutil.Process(driver.pid)

        def command_line(p) -> str:
            # a child can exit (a zombie until reaped) between children() and cmdline()
            try:
                return " ".join(p.cmdline())
            except psutil.Error:
                return ""

        deadline = time.monotonic() + 60
        workers: list[psutil.Process] = []
        while time.monotonic() < deadline and len(workers) < 2:
            time.sleep(0.2)
            workers = [c for c in parent.children() if "multiprocessing" in command_line(c)
                       and "resource_tracker" not in command_line(c)]  # fmt: skip
        assert len(workers) == 2, [command_line(c) for c in parent.children()]
        time.sleep(1.0)  # let the workers start their samples
        os.kill(driver.pid, signal.SIGKILL)
        driver.wait(10)
        gone, alive = psutil.wait_procs(workers, timeout=10)

        def running(p) -> bool:
            # a worker that exited stays a zombie until whoever adopted it (the container's
            # init, which may never reap) collects it: it has stopped all the same
            try:
                return p.status() != psutil.STATUS_ZOMBIE
            except psutil.NoSuchProcess:
                return False

        alive = [p for p in alive if running(p)]
        for p in alive:
            p.kill()
        assert not alive
    finally:
        if driver.poll() is None:
            driver.kill()


def test_resume_from_the_configuration_stored_in_the_trace(good, checkpointed, tmp_path):
    """A trace that carries its last configuration resumes with neither ``w.last.h5`` nor a
    snapshot (the state a SIGKILL can leave once the checkpoint is one file)."""
    whole = read_trace(checkpointed / "w.h5")
    at25 = sp.read_packing(checkpointed / "w.configs" / "step_00000025.h5")
    write_trace(tmp_path / "w.h5", whole.head(26), configuration=at25)
    r = jamlab("shear", good, "--dgamma", "1e-3", "--gamma-max", "0.03", "--resume",
               "--out", tmp_path / "w.h5")  # fmt: skip
    assert r.returncode == 0, r.stderr
    resumed = read_trace(tmp_path / "w.h5")
    assert resumed.n_steps == 30
    np.testing.assert_array_equal(resumed.energy[:26], whole.energy[:26])


def test_the_checkpoint_trace_carries_its_configuration(checkpointed):
    from jamlab.spheres.trace import read_trace_configuration

    stored = read_trace_configuration(checkpointed / "w.h5")
    assert stored is not None and stored["step"] == 30
    last = sp.read_packing(checkpointed / "w.last.h5")
    assert np.array_equal(stored["positions"], last.positions)


def test_resumed_counters_cover_the_whole_trace(good, checkpointed, tmp_path):
    shutil.copyfile(checkpointed / "w.h5", tmp_path / "w.h5")
    shutil.copyfile(checkpointed / "w.last.h5", tmp_path / "w.last.h5")
    first = read_trace(tmp_path / "w.h5").attrs
    r = jamlab("shear", good, "--dgamma", "1e-3", "--gamma-max", "0.031", "--resume",
               "--out", tmp_path / "w.h5")  # fmt: skip
    assert r.returncode == 0, r.stderr
    after = read_trace(tmp_path / "w.h5").attrs
    # one more step can only add factorisations to the 30 steps' count
    assert after["n_factorisations"] >= first["n_factorisations"]
    assert after["n_lean"] >= first["n_lean"] > 0


def test_python_api_shear_uses_the_validation_layer(good):
    from jamlab.spheres.aqs import shear

    packing = sp.read_packing(good)
    far = sp.Packing(packing.positions, sp.Box(packing.box.length, 3, 1e5))
    with pytest.raises(ValueError, match="resolution"):
        shear(far, 1e-12, 1e-10)
    with pytest.raises(ValueError, match="steps"):
        shear(packing, 1e-3, n_steps=10**9)


def test_sigkill_at_random_moments_always_leaves_a_resumable_run(good, tmp_path):
    """SIGKILL of `shear --save-every 3` at random moments of its stepping loop (6 inside it):
    whenever a trace exists, `--resume` succeeds, gives all 61 rows, and the rows written before
    the kill are bit for bit those of the uninterrupted run. (Equality of the whole file after
    the resume: tests/cli/test_cli_resume.py.)

    The moments are aimed after the trace first appears, not by the clock from the launch: on a
    loaded machine Python's start-up can outlast the whole stepping loop, and kills timed from
    the launch then all land before the first checkpoint or after the end (this test once
    resumed nothing in 12 trials on a CI machine). The loop's length is measured once, and a
    machine whose load changes afterwards can make it an overestimate (5 of 12 resumed once,
    beside a two-worker study): a kill that lands after the end halves the estimate, and the
    trials go on (at most 20) until 6 kills have landed inside the loop."""
    args = ("--dgamma", "1e-3", "--gamma-max", "0.06", "--save-every", "3")
    ref = tmp_path / "ref.h5"
    loop = shear_loop_seconds(good, args, ref, poll=0.002)  # after the first checkpoint
    whole = read_trace(ref)
    rng = np.random.default_rng(15)
    resumed_trials = 0
    for trial in range(20):
        if resumed_trials >= 6:
            break
        d = tmp_path / f"t{trial}"
        d.mkdir()
        out = d / "w.h5"
        cmd = [sys.executable, "-m", "jamlab", "shear", str(good), *args, "--out", str(out)]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for_file(proc, out, poll=0.002)
        time.sleep(rng.uniform(0.0, 0.8) * loop)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        assert out.exists(), trial  # the trace appears at the first checkpoint and stays
        before = read_trace(out)
        if before.n_steps == 60:  # killed after the run ended: nothing left to resume
            assert "nothing to do" in one_line_error(
                jamlab("shear", good, *args, "--resume", "--out", out)
            )
            loop *= 0.5  # the measured loop outlasts this machine's present one
            continue
        r = jamlab("shear", good, *args, "--resume", "--out", out)
        assert r.returncode == 0, (trial, r.stderr)
        after = read_trace(out)
        assert after.n_steps == 60
        np.testing.assert_allclose(after.gamma, 1e-3 * np.arange(61), rtol=0, atol=1e-15)
        rows = before.n_steps + 1
        for name in ("energy", "shear_stress", "plastic", "iterations"):
            assert getattr(after, name)[:rows].tobytes() == getattr(whole, name)[:rows].tobytes()
        resumed_trials += 1
    assert resumed_trials >= 6, resumed_trials  # most kills land inside the loop


@pytest.mark.slow
def test_ctrl_c_inside_a_compiled_kernel_is_an_abort(tmp_path):
    """Ctrl-C while FIRE's numba kernel runs surfaced as a traceback ending in "SystemError:
    CPUDispatcher(<function fire …>) returned a result with an exception set", exit code 1: the
    KeyboardInterrupt is chained under numba's SystemErrors. It is an abort now: one line, 130,
    no file. And while a kernel ran for the first time in the process, the interrupt was
    processed inside numba's runtime unpickling on the kernel's return, which numba does not
    check: a segmentation fault (exit −11, no message). Measured on this command before
    jamlab.interrupts (2026-12-07, AMD EPYC, idle): SIGINT at 2.1-4.0 s segfaulted 9 times in
    9, at 0.3-1.8 s and from 4.5 s it aborted. Here: two interrupts in that window and one
    inside a later FIRE run (8 s, past the imports and the kernels' cache loading)."""
    env = dict(os.environ, JAMLAB_FORCE_KERNEL="branchy")
    subprocess.run([sys.executable, "-m", "jamlab", "prepare", "--n", "64", "--phi", "jamming",
                    "--quiet", "--out", str(tmp_path / "small.h5")], env=env, check=True,
                   capture_output=True)
    import time

    for i, delay in enumerate((2.2, 3.2, 8.0)):
        out = tmp_path / f"big{i}.h5"
        proc = subprocess.Popen(
            [sys.executable, "-m", "jamlab", "prepare", "--n", "3000", "--phi", "jamming",
             "--out", str(out)],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        time.sleep(delay)
        assert proc.poll() is None, "the preparation ended before it could be interrupted"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        assert (proc.returncode, err) == (130, "jamlab: aborted\n"), (delay, proc.returncode, err)
        assert not out.exists()


def test_interrupted_follows_the_chain():
    """Numba chains the KeyboardInterrupt under several SystemErrors (by __context__); an
    unrelated SystemError is not an interrupt."""
    from jamlab.cli import interrupted

    def numba_like():
        try:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt:
                raise SystemError("<function _numba_unpickle> returned a result with an "
                                  "exception set") from None
        except SystemError as e:
            raise SystemError("CPUDispatcher(<function fire>) returned a result …") from e

    with pytest.raises(SystemError) as info:
        numba_like()
    assert interrupted(info.value)
    assert not interrupted(SystemError("a genuine internal error"))
    assert interrupted(KeyboardInterrupt())
