"""No finished data is replaced by accident: every command refuses an existing output file
without ``--force`` (the file byte-identical afterwards) and replaces it with it; a file of a run
directory is refused even with ``--force``; figure suffixes are checked before any work. And the
smaller contracts found with them: ``shear`` exits 1 when a step did not converge, leftover
snapshots of an earlier run are not mixed into a new one or into an export, a resumed run keeps
its avalanche threshold, SLURM options are checked even when unused, ``figure`` refuses runs of
another scale."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from cli_helpers import digest, error_line
from cli_helpers import run_in_process as run


@pytest.fixture(scope="module")
def packing08(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "p08.h5"
    assert run(["prepare", "--phi", "0.8", "--n", "32", "--seed", "1", "--out", path,
                "--quiet"]) == 0  # fmt: skip
    return path


def commands(p08, out, other):
    """Each command writing a file, with ``out`` as the file written (``other``: a second output
    where the command has one)."""
    return {
        "random-packing": ["random-packing", "--n", "8", "--phi", "0.3", "--out", out],
        "prepare": ["prepare", "--phi", "0.8", "--n", "16", "--out", out, "--quiet"],
        "minimize": ["minimize", p08, "--out", out],
        "shear": ["shear", p08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.02"],
        "shear --plot": ["shear", p08, "--out", other, "--dgamma", "0.01", "--gamma-max", "0.02",
                         "--plot", out],
        "export": ["export", p08, "--out", out, "--format", "extxyz"],
        "cascade --csv": ["cascade", "--q", "0.2,0.5", "--y", "1,2", "--n", "100", "--out",
                          other, "--csv", out],
        "theory --csv": ["theory", "--out", other, "--points", "5", "--csv", out],
        "figure": ["figure", "fig3", "--out", out],
    }  # fmt: skip


@pytest.mark.parametrize("name", ["random-packing", "prepare", "minimize", "shear", "shear --plot",
                                  "export", "cascade --csv", "theory --csv", "figure"])
def test_an_existing_output_needs_force(packing08, tmp_path, capsys, name):
    out = tmp_path / ("out.png" if name in ("shear --plot", "figure") else "out.h5")
    other = tmp_path / ("other.png" if name in ("cascade --csv", "theory --csv") else "o.h5")
    out.write_bytes(b"finished data")
    before = digest(out)
    args = commands(packing08, out, other)[name]
    assert run(args) == 2
    assert f"{out} exists; give --force to replace it" in error_line(capsys)
    assert digest(out) == before and not other.exists()  # nothing written, nothing computed
    assert run([*args, "--force"]) == 0
    assert digest(out) != before


def test_a_run_directory_file_is_refused_even_with_force(tmp_path, capsys):
    runs = tmp_path / "runs"
    assert run(["run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
                "--gamma-max", "2e-3", "--task", "toy", "--out", runs / "jamming", "--workers",
                "0", "--quiet"]) == 0  # fmt: skip
    manifest = runs / "jamming" / "manifest.json"
    sample = next((runs / "jamming" / "samples").rglob("sample-*.h5"))
    before = {p: digest(p) for p in (manifest, sample)}
    for target in (manifest, sample, runs / "jamming" / "samples" / "new.png"):
        assert run(["figure", "fig3", "--out", target, "--force"]) == 2
        assert "is a file of the run directory" in error_line(capsys)
    assert {p: digest(p) for p in before} == before
    # beside the run's own files a figure may go
    assert run(["figure", "fig3", "--out", runs / "jamming" / "fig3.png"]) == 0


def toy_run(directory) -> None:
    assert run(["run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
                "--gamma-max", "2e-3", "--task", "toy", "--out", directory, "--workers", "0",
                "--quiet"]) == 0  # fmt: skip


def test_a_run_directory_file_through_a_symlinked_directory_is_refused(tmp_path, capsys):
    toy_run(tmp_path / "rd")
    sample = next((tmp_path / "rd" / "samples").rglob("sample-*.h5"))
    cell = tmp_path / "cell"
    cell.symlink_to(sample.parent, target_is_directory=True)
    before = digest(sample)
    for target in (cell / sample.name, cell / ".." / sample.parent.name / "new.h5"):
        assert run(["random-packing", "--n", "8", "--phi", "0.3", "--out", target,
                    "--force"]) == 2  # fmt: skip
        assert "is a file of the run directory" in error_line(capsys)
    assert digest(sample) == before
    assert sorted(p.name for p in sample.parent.iterdir()) == [sample.name]


def test_no_run_directory_or_report_inside_a_run_directory(tmp_path, capsys):
    rd = tmp_path / "rd"
    toy_run(rd)
    before = {p: digest(p) for p in rd.rglob("*") if p.is_file()}
    (tmp_path / "cell").symlink_to(rd / "samples", target_is_directory=True)
    for inner in (rd / "samples" / "newrun", rd / "newrun", tmp_path / "cell" / "newrun"):
        toy_run_args = ["run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
                        "--gamma-max", "2e-3", "--task", "toy", "--workers", "0", "--quiet"]
        assert run([*toy_run_args, "--out", inner]) == 2
        assert f"lies in the run directory {rd}" in error_line(capsys)
    for args in (["--out", rd / "samples" / "x"], ["--out", rd],
                 ["--out", tmp_path / "rep", "--runs", rd / "x"]):
        assert run(["reproduce", "--scale", "tiny", *args, "--workers", "0", "-q"]) == 2
        assert f"the run directory {rd}" in error_line(capsys)
    assert {p: digest(p) for p in rd.rglob("*") if p.is_file()} == before
    assert not (tmp_path / "rep").exists()
    # the run directory itself is resumed as before
    toy_run(rd)
    assert {p: digest(p) for p in before if p.name != "run.lock"} == {
        p: h for p, h in before.items() if p.name != "run.lock"}


def test_figure_suffix_is_checked_before_the_work(packing08, tmp_path, capsys):
    out = tmp_path / "t.h5"
    assert run(["shear", packing08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.02",
                "--plot", tmp_path / "x.txt"]) == 2  # fmt: skip
    assert "a figure needs one of the suffixes" in error_line(capsys)
    assert not out.exists()
    assert run(["cascade", "--q", "0.2,0.5", "--y", "1,2", "--n", "100", "--out",
                tmp_path / "o.png", "--tree", tmp_path / "t.h5"]) == 2  # fmt: skip
    assert "--tree" in error_line(capsys) and not (tmp_path / "o.png").exists()


def test_shear_replaces_a_run_with_its_snapshots_only_with_force(packing08, tmp_path, capsys):
    out = tmp_path / "a.h5"
    args = ["shear", packing08, "--out", out, "--dgamma", "0.01"]
    assert run([*args, "--gamma-max", "0.04", "--save-every", "1"]) == 0
    snapshots = sorted((tmp_path / "a.configs").glob("step_*.h5"))
    assert len(snapshots) == 4
    (tmp_path / "a.h5").unlink()
    (tmp_path / "a.last.h5").unlink()
    # the old run's snapshots would be read as the new run's frames
    assert run([*args, "--gamma-max", "0.02"]) == 2
    assert "holds 4 snapshot(s) of an earlier run" in error_line(capsys)
    assert run([*args, "--gamma-max", "0.02", "--force"]) == 0
    assert not (tmp_path / "a.configs").exists()
    capsys.readouterr()
    assert run(["export", out, "--out", tmp_path / "a.xyz"]) == 0
    assert "1 frame(s), AQS steps 2..2" in capsys.readouterr().out


@pytest.mark.parametrize("kind", ["packing", "other step", "not hdf5"])
def test_shear_force_never_removes_a_foreign_file_named_like_a_snapshot(packing08, tmp_path,
                                                                         capsys, kind):
    """Audit row 16: a file the user put into a run's snapshot folder under a snapshot's name
    (``random-packing --out a.configs/step_00000009.h5``) was moved aside and deleted with the
    earlier run's snapshots by ``shear --force``. It is refused now, with or without --force,
    and every file stays as it was."""
    out = tmp_path / "a.h5"
    args = ["shear", packing08, "--out", out, "--dgamma", "0.01", "--save-every", "1"]
    assert run([*args, "--gamma-max", "0.02"]) == 0
    foreign = tmp_path / "a.configs" / "step_00000009.h5"
    if kind == "packing":  # a packing without aqs_step
        assert run(["random-packing", "--out", foreign, "--n", "16", "--phi", "0.5"]) == 0
    elif kind == "other step":  # a real snapshot of step 1, under another step's name
        foreign.write_bytes((tmp_path / "a.configs" / "step_00000001.h5").read_bytes())
    else:
        foreign.write_text("my notes\n")
    capsys.readouterr()
    before = {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()}
    assert run([*args, "--gamma-max", "0.03"]) == 2  # a.h5 exists: refused before, too
    assert "exists; give --force" in error_line(capsys)
    assert run([*args, "--gamma-max", "0.03", "--force"]) == 2
    line = error_line(capsys)
    assert str(foreign) in line and "move it out of" in line, line
    assert {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()} == before
    foreign.unlink()  # without it, the replacement goes on as before
    assert run([*args, "--gamma-max", "0.03", "--force"]) == 0
    assert sorted(p.name for p in (tmp_path / "a.configs").iterdir()) == [
        "step_00000001.h5", "step_00000002.h5", "step_00000003.h5"]


def test_export_never_writes_over_the_saved_configurations_it_reads(packing08, tmp_path, capsys):
    out = tmp_path / "w.h5"
    assert run(["shear", packing08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.05",
                "--save-every", "2"]) == 0  # fmt: skip
    saved = [tmp_path / "w.last.h5", *sorted((tmp_path / "w.configs").glob("step_*.h5"))]
    before = {p: digest(p) for p in saved}
    (tmp_path / "link.h5").symlink_to(saved[1])
    for target in (*saved, tmp_path / "link.h5"):
        assert run(["export", out, "--out", target, "--format", "extxyz", "--force"]) == 2
        assert "is the same file as the" in error_line(capsys)
    assert {p: digest(p) for p in saved} == before


def test_export_never_writes_the_traces_last_configuration_even_when_it_is_missing(
        packing08, tmp_path, capsys, monkeypatch):
    """``--out w.last.h5`` of the trace w.h5 was refused only when w.last.h5 existed; when it
    was missing, export wrote it, and shear --resume and the next export read it as the run's
    last configuration. Refused now in any spelling, with or without --force, nothing written."""
    out = tmp_path / "w.h5"
    assert run(["shear", packing08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.03",
                "--save-every", "1"]) == 0  # fmt: skip
    last = tmp_path / "w.last.h5"
    last.unlink()  # the trace holds its configuration, the snapshots are the export's frames
    before = {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()}
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path)
    for target in (last, "w.last.h5", tmp_path / "sub" / ".." / "w.last.h5"):
        for force in ([], ["--force"]):
            assert run(["export", out, "--out", target, "--format", "extxyz", *force]) == 2
            line = error_line(capsys)
            assert f"is the last configuration {last} (absent now, read as input" in line, line
    assert not last.exists()
    assert {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()} == before
    assert run(["export", out, "--out", tmp_path / "w.xyz"]) == 0  # elsewhere: as before
    assert "3 frame(s), AQS steps 1..3" in capsys.readouterr().out


def test_import_never_writes_over_the_meta_json_it_reads(packing08, tmp_path, capsys):
    with h5py.File(packing08, "r") as h5:
        positions, length = h5["positions"][()], float(h5.attrs["box_length"])
    np.savetxt(tmp_path / "pos.txt", positions)
    meta = tmp_path / "meta.json"
    meta.write_text(json.dumps({"box_length": length}))
    before = digest(meta)
    for command in ("import", "import-xyz"):  # one rule, one implementation
        assert run([command, tmp_path / "pos.txt", "--out", meta, "--force"]) == 2
        assert "is the same file as the meta.json" in error_line(capsys)
    assert digest(meta) == before
    # beside it, a new output is written as before
    assert run(["import", tmp_path / "pos.txt", "--out", tmp_path / "p.h5"]) == 0


def test_export_writes_nothing_into_the_snapshot_folder_it_reads(packing08, tmp_path, capsys,
                                                                 monkeypatch):
    """A new file in w.configs/ would be read (or removed by shear --force) with the snapshots:
    refused, through any spelling of the folder; the trace is read once."""
    from jamlab.spheres import exchange

    out = tmp_path / "w.h5"
    assert run(["shear", packing08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.05",
                "--save-every", "2"]) == 0  # fmt: skip
    configs = tmp_path / "w.configs"
    before = {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()}
    (tmp_path / "link").symlink_to(configs, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    for target in (configs / "new.xyz", "w.configs/new.extxyz", tmp_path / "link" / "new.xyz",
                   tmp_path / "sub" / ".." / "w.configs" / "new.xyz"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        for force in ([], ["--force"]):
            assert run(["export", out, "--out", target, "--format", "extxyz", *force]) == 2
            assert f"lies in the snapshot folder {configs}, which is read" in error_line(capsys)
    assert sorted(p.name for p in configs.iterdir()) == ["step_00000002.h5", "step_00000004.h5",
                                                         "step_00000005.h5"]  # fmt: skip
    assert {p: digest(p) for p in before} == before
    reads = []
    real = exchange.read_trace
    monkeypatch.setattr(exchange, "read_trace", lambda p: reads.append(p) or real(p))
    assert run(["export", out, "--out", tmp_path / "m.xyz"]) == 0
    assert "3 frame(s), AQS steps 2..5" in capsys.readouterr().out
    assert len(reads) == 1


def test_shear_refuses_an_input_inside_the_snapshot_folder_it_writes(packing08, tmp_path, capsys):
    """Shearing a saved snapshot again to the run it came from: the new run would clear and
    write w.configs/, its own input among them. Refused, with or without --force, in one line
    that names the folder once; nothing changes."""
    out = tmp_path / "w.h5"
    assert run(["shear", packing08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.05",
                "--save-every", "2"]) == 0  # fmt: skip
    configs = tmp_path / "w.configs"
    snap = configs / "step_00000002.h5"
    before = {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()}
    for extra in ([], ["--save-every", "1"], ["--force"], ["--force", "--save-every", "1"]):
        assert run(["shear", snap, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.08",
                    *extra]) == 2  # fmt: skip
        line = error_line(capsys)
        if "--force" in extra:
            assert line == (f"jamlab: error: the configuration {snap} lies in the snapshot "
                            f"directory {configs}, which this command writes into; copy it "
                            "elsewhere first"), line
        else:  # without --force the existing trace is refused first
            assert "exists; give --force" in line, line
    assert {p: digest(p) for p in tmp_path.rglob("*") if p.is_file()} == before


def test_export_refuses_a_movie_with_missing_or_foreign_frames(packing08, tmp_path, capsys):
    out = tmp_path / "tr.h5"
    assert run(["shear", packing08, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.05",
                "--save-every", "1"]) == 0  # fmt: skip
    assert run(["export", out, "--out", tmp_path / "all.xyz"]) == 0
    capsys.readouterr()
    step3 = tmp_path / "tr.configs" / "step_00000003.h5"
    kept = step3.read_bytes()
    step3.unlink()
    assert run(["export", out, "--out", tmp_path / "n.xyz"]) == 2
    assert "1 saved configuration(s) missing from tr.configs/ (steps 3" in error_line(capsys)
    # a snapshot of another run in its place (another strain at that step)
    step3.write_bytes(kept)
    with h5py.File(step3, "r+") as h5:
        h5.attrs["strain"] = 0.5
    assert run(["export", out, "--out", tmp_path / "n.xyz"]) == 2
    assert "a leftover of another run" in error_line(capsys)


def test_shear_exits_1_when_a_step_did_not_converge(tmp_path, capsys):
    low = tmp_path / "low.h5"
    assert run(["random-packing", "--n", "32", "--phi", "0.1", "--out", low]) == 0
    out = tmp_path / "s.h5"
    code = run(["shear", low, "--out", out, "--dgamma", "0.01", "--gamma-max", "0.05",
                "--pressure", "1e-2"])  # fmt: skip
    err = capsys.readouterr().err
    with h5py.File(out, "r") as h5:  # the trace is written: its rows say which did not converge
        bad = int(h5.attrs["n_not_converged"])
    assert bad >= 1
    assert code == 1 and f"{bad} step(s) did not converge" in err


def test_resume_keeps_the_avalanche_threshold(packing08, tmp_path, capsys):
    out = tmp_path / "av.h5"
    args = ["shear", packing08, "--out", out, "--dgamma", "0.01", "--keep-avalanches"]
    assert run([*args, "--gamma-max", "0.05"]) == 0
    before = digest(out)
    assert run([*args, "--gamma-max", "0.15", "--resume", "--avalanche-threshold", "0.5"]) == 2
    assert "differs from the run being resumed (0.001)" in error_line(capsys)
    assert digest(out) == before
    assert run([*args, "--gamma-max", "0.15", "--resume"]) == 0


def test_avalanche_threshold_needs_keep_avalanches(packing08, tmp_path, capsys):
    """A threshold without the records it labels is refused (CLI and library), not ignored."""
    from jamlab.spheres import read_packing
    from jamlab.spheres.aqs import shear

    assert run(["shear", packing08, "--out", tmp_path / "o.h5", "--dgamma", "0.01",
                "--gamma-max", "0.02", "--avalanche-threshold", "0.5"]) == 2  # fmt: skip
    assert "--avalanche-threshold applies to --keep-avalanches" in error_line(capsys)
    assert not (tmp_path / "o.h5").exists()
    with pytest.raises(ValueError, match="avalanche_threshold applies to keep_avalanches"):
        shear(read_packing(packing08), 0.01, n_steps=1, avalanche_threshold=0.5)


@pytest.mark.parametrize("bad", [["--ptol", "-1"], ["--ptol", "nan"], ["--ptol", "0"],
                                 ["--ptol", "1e-5"]])
def test_ptol_is_checked_without_pressure(packing08, tmp_path, capsys, bad):
    """A bad --ptol is named; a good one without --pressure is refused too (it had been ignored
    silently, while --confirm, --confirm-below and --volume-guess were refused)."""
    assert run(["shear", packing08, "--out", tmp_path / "o.h5", "--dgamma", "0.01",
                "--gamma-max", "0.02", *bad]) == 2  # fmt: skip
    assert "--ptol" in error_line(capsys)
    assert run(["prepare", "--n", "16", "--out", tmp_path / "p.h5", "--quiet", *bad]) == 2
    assert "--ptol" in error_line(capsys)
    assert not (tmp_path / "o.h5").exists() and not (tmp_path / "p.h5").exists()


def test_slurm_options_are_checked_before_a_cluster_starts(tmp_path, capsys):
    assert run(["run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
                "--gamma-max", "2e-3", "--task", "toy", "--out", tmp_path / "r", "--cluster",
                "slurm", "--slurm-jobs", "-1"]) == 2  # fmt: skip
    assert "slurm jobs must be an integer >= 1, got -1" in error_line(capsys)
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("extra, message", [
    (["--slurm-jobs", "3"], "--slurm-jobs applies with --cluster slurm only"),
    (["--slurm-memory", "1GiB", "--slurm-queue", "q"],
     "--slurm-memory applies with --cluster slurm only"),
    (["--scheduler", "tcp://127.0.0.1:1"], "--workers applies to local processes or --cluster"),
    (["--p-target", "1e-5"], "p_target applies to phi 'jamming'"),
])
def test_run_options_that_would_be_ignored_are_refused(tmp_path, capsys, extra, message):
    """An option the run would not use is an error, not silently dropped (nor recorded)."""
    assert run(["run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
                "--gamma-max", "2e-3", "--task", "toy", "--out", tmp_path / "r", "--workers",
                "0", *extra]) == 2  # fmt: skip
    assert message in error_line(capsys)
    assert not (tmp_path / "r").exists()


def test_figure_refuses_runs_of_another_scale(tmp_path, capsys):
    from jamlab.reproduce import SCALES
    from jamlab.reproduce.scales import studies
    from jamlab.runs import Execution, Study, run_study

    tiny = studies(SCALES["tiny"])
    for name in ("jamming", "unsat"):  # toy runs with the tiny scale's φ and N
        study = Study(**{**tiny[name].to_dict(), "task": "toy"})
        run_study(study, tmp_path / "runs" / name, Execution(workers=0))
    code = run(["figure", "fig4", "--out", tmp_path / "f.png", "--runs", tmp_path / "runs",
                "--scale", "quick"])  # fmt: skip
    line = error_line(capsys)
    assert code == 2 and "was not made with the scale 'quick'" in line
    assert not (tmp_path / "f.png").exists()


def test_coordination_needs_a_jammed_minimum(packing08, tmp_path, capsys):
    rp = tmp_path / "rp.h5"
    assert run(["random-packing", "--n", "64", "--phi", "0.7", "--out", rp]) == 0
    capsys.readouterr()
    out = tmp_path / "z.png"
    assert run(["coordination", rp, "--out", out, "--steps", "3", "--quiet"]) == 2
    assert "is not a jammed minimum (max|F_i| = " in error_line(capsys)
    assert not out.exists()
    # an over-jammed minimum is accepted, with a warning that dphi is measured from its phi
    assert run(["coordination", packing08, "--out", out, "--steps", "3", "--dphi-max", "0.1",
                "--quiet"]) == 0  # fmt: skip
    assert "far above jamming" in capsys.readouterr().err


def test_run_refuses_a_preparation_below_jamming(tmp_path, capsys):
    assert run(["run", "--phi", "0.3", "--n", "16", "--samples", "1", "--dgamma", "1e-3",
                "--gamma-max", "2e-3", "--out", tmp_path / "r", "--workers", "0", "-q"]) == 2
    assert "phi 0.3 is below jamming" in error_line(capsys)
    assert not (tmp_path / "r").exists()


def test_an_unreachable_scheduler_leaves_no_run_directory(tmp_path, capsys):
    """A run refused for its scheduler left ``r/manifest.json`` behind, and the next run there
    with other parameters was refused as "a different study" (a third audit)."""
    import socket

    with socket.socket() as s:  # a loopback port nothing listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert run(["run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
                "--gamma-max", "2e-3", "--task", "toy", "--out", tmp_path / "r", "--scheduler",
                f"tcp://127.0.0.1:{port}"]) == 2  # fmt: skip
    assert f"cannot reach dask scheduler tcp://127.0.0.1:{port}" in error_line(capsys)
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("args", [
    ["random-packing", "--n", "16", "--phi", "0.5"],
    ["prepare", "--n", "16", "--phi", "0.8", "--quiet"],
])
@pytest.mark.parametrize("suffix", [".xyz", ".gsd", ".png", ".csv"])
def test_an_hdf5_output_named_as_another_format_is_refused(tmp_path, capsys, args, suffix):
    """``random-packing --out r.gsd`` wrote HDF5 into a .gsd file and said nothing (a third
    audit); export/import and every reader take the suffix at its word."""
    out = tmp_path / f"o{suffix}"
    assert run([*args, "--out", out]) == 2
    assert f"this writes an HDF5 file, and {suffix} names another format" in error_line(capsys)
    assert not out.exists()
    assert run([*args, "--out", tmp_path / "o.h5"]) == 0


@pytest.mark.parametrize("args, message", [
    (["prepare", "--phi", "0.8", "--n", "16", "--p-target", "1e-3"],
     "--p-target applies to --phi jamming, not to --phi 0.8"),
    (["prepare", "--phi", "0.8", "--n", "16", "--phi-init", "0.5"],
     "--phi-init applies to --phi jamming"),
    (["cascade", "--q", "0.2,0.5", "--y", "1,2", "--n", "100", "--amplitude", "5"],
     "--amplitude applies to --linear and --power-law, not to --q/--y"),
    (["cascade", "--q", "0.2,0.5", "--y", "1,2", "--n", "100", "--k", "3"],
     "--k applies to --linear and --power-law"),
    (["cascade", "--linear", "2", "--n", "100", "--amplitude", "5"],
     "--amplitude applies to --power-law, not to --linear"),
])
def test_options_that_do_not_apply_are_refused(tmp_path, capsys, args, message):
    out = tmp_path / ("o.png" if args[0] == "cascade" else "o.h5")
    assert run([*args, "--out", out]) == 2
    assert message in error_line(capsys)
    assert not out.exists()


# -- atomic writes: a failed write leaves the earlier figure / CSV whole -------------------------


def test_a_failed_figure_write_leaves_the_earlier_file_whole(tmp_path, capsys, monkeypatch):
    import errno
    import os

    from matplotlib.figure import Figure

    png, csv = tmp_path / "t.png", tmp_path / "t.csv"
    assert run(["theory", "--out", png, "--csv", csv, "--points", "5"]) == 0
    before = {p.name: digest(p) for p in (png, csv)}
    real = Figure.savefig

    def truncated(self, fname, **kwargs):  # writes part of the file, then the disk is full
        real(self, fname, **kwargs)
        with open(fname, "r+b") as fh:
            fh.truncate(100)
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))

    monkeypatch.setattr(Figure, "savefig", truncated)
    assert run(["theory", "--out", png, "--csv", csv, "--points", "5", "--force"]) == 2
    assert f"cannot write {png}: File too large" in error_line(capsys)
    assert {p.name: digest(p) for p in (png, csv)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv", "t.png"]  # no .tmp left


def test_a_file_size_limit_leaves_the_earlier_csv_and_figure_whole(tmp_path):
    """The real thing: ``ulimit -f`` (RLIMIT_FSIZE) makes the write fail with EFBIG midway."""
    import resource
    import subprocess
    import sys

    png, csv = tmp_path / "c.png", tmp_path / "c.csv"
    args = [sys.executable, "-m", "jamlab", "cascade", "--q", "0.2,0.5", "--y", "1,2", "--n",
            "3000", "--out", str(png), "--csv", str(csv), "--force"]
    assert subprocess.run(args, capture_output=True).returncode == 0
    before = {p.name: digest(p) for p in (png, csv)}
    assert csv.stat().st_size > 20_000 and png.stat().st_size > 20_000

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    r = subprocess.run(args, capture_output=True, text=True, preexec_fn=limit)
    assert r.returncode == 2 and "File too large" in r.stderr and "c.png" in r.stderr, r.stderr
    assert {p.name: digest(p) for p in (png, csv)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.csv", "c.png"]


def test_a_packing_flagged_failed_is_named_where_it_is_used(packing08, tmp_path, capsys):
    """A configuration ``prepare`` wrote with ``ok = False`` (its stopping rule failed) is
    shown as such by ``inspect`` and ``shear`` (a warning naming the reason), not used silently;
    the unflagged one gets no warning."""
    from jamlab.spheres.io import read_packing, write_packing

    bad = tmp_path / "bad.h5"
    write_packing(bad, read_packing(packing08), ok=False, reason="hyperstatic (test)")
    for args in (["inspect", bad], ["shear", bad, "--out", tmp_path / "t.h5", "--dgamma", "0.01",
                                    "--gamma-max", "0.02"]):
        assert run(args) == 0
        err = capsys.readouterr().err
        assert f"{bad} is flagged ok=False by prepare (hyperstatic (test))" in err, err
    assert run(["inspect", packing08]) == 0
    assert "ok=False" not in capsys.readouterr().err


def test_every_exchange_and_figure_suffix_is_another_format():
    """The list the HDF5 outputs are checked against holds every suffix an exchange format is
    named by and every figure suffix matplotlib writes (files.py keeps its own list: it imports
    neither)."""
    from matplotlib.backend_bases import FigureCanvasBase

    from jamlab.files import OTHER_FORMAT_SUFFIXES
    from jamlab.spheres.exchange import SUFFIXES, format_named_by

    assert SUFFIXES and all(format_named_by(f"x{s.upper()}") == f for s, f in SUFFIXES.items())
    assert set(SUFFIXES) <= OTHER_FORMAT_SUFFIXES
    figures = {f".{k}" for k in FigureCanvasBase.get_supported_filetypes()}
    assert {".png", ".pdf", ".svg"} <= figures <= OTHER_FORMAT_SUFFIXES
    assert not {".h5", ".hdf5"} & OTHER_FORMAT_SUFFIXES
