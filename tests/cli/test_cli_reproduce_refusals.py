"""``jamlab reproduce`` and ``jamlab figure`` with bad input (the findings of a second audit,
``docs/formats.md``): a refused ``reproduce`` leaves nothing it created behind, an ensemble in
which every sample failed is one line with exit code 1 (not a traceback from the analysis), a run
manifest of an unknown format version is refused, and ``figure`` redraws a report made with
another ``--seed``."""

from __future__ import annotations

import hashlib
import json

import pytest

from cli_helpers import error_line
from cli_helpers import run_in_process as run


def tree(root) -> dict:
    """Every path below ``root`` with the sha256 of each file (``None`` for a directory)."""
    return {str(p.relative_to(root)): (hashlib.sha256(p.read_bytes()).hexdigest()
                                       if p.is_file() else None)
            for p in sorted(root.rglob("*"))}


def toy_runs(root, scale, task="toy"):
    """Run directories of ``scale``'s jamming and unsat studies, with the quick ``toy`` task
    (``task=None``: the scale's own)."""
    from jamlab.reproduce.scales import studies
    from jamlab.runs import Execution, Study, run_study

    for name, study in studies(scale).items():
        if name in ("jamming", "unsat"):
            if task is not None:
                study = Study(**{**study.to_dict(), "task": task})
            run_study(study, root / name, Execution(workers=0))


def reproduce(out, *extra):
    return ["reproduce", "--scale", "tiny", "--workers", "0", "-q", "--out", out, *extra]


@pytest.fixture
def seeded_runs(tmp_path):
    from jamlab.reproduce import SCALES, with_seed

    toy_runs(tmp_path / "runs1", with_seed(SCALES["tiny"], 1))
    return tmp_path / "runs1"


@pytest.mark.parametrize("case", ["seed too large", "runs is a file", "runs of another seed",
                                  "runs of another scale", "foreign runs directory"])
def test_a_refused_reproduce_leaves_nothing_it_created(tmp_path, capsys, seeded_runs, case):
    """Each of these was refused (exit 2) after the report directory, its marker and its
    figures/ folder had been made, and left them behind (audit rows 1-5)."""
    (tmp_path / "file.txt").write_text("mine\n")
    (tmp_path / "foreign" / "jamming").mkdir(parents=True)
    (tmp_path / "foreign" / "jamming" / "notes.txt").write_text("mine\n")
    extra, message = {
        "seed too large": (["--seed", 2**64], "seed must be an integer in [0, "),
        "runs is a file": (["--runs", tmp_path / "file.txt"], "cannot create output directory"),
        "runs of another seed": (["--runs", seeded_runs], "holds a different study (seed: 1 != 0"),
        "runs of another scale": (["--runs", seeded_runs, "--scale", "quick", "--seed", 1],
                                  "holds a different study (n: "),
        "foreign runs directory": (["--runs", tmp_path / "foreign"],
                                   "is not empty and has no manifest.json"),
    }[case]
    before = tree(tmp_path)
    out = tmp_path / "new" / "report"
    assert run(reproduce(out, *extra)) == 2
    assert message in error_line(capsys)
    assert tree(tmp_path) == before  # no report directory, no parent of it, nothing changed


def test_a_refused_reproduce_into_an_existing_directory_removes_only_its_own(tmp_path, capsys,
                                                                             seeded_runs):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    before = tree(tmp_path)
    assert run(reproduce(out, "--runs", seeded_runs)) == 2
    assert "holds a different study" in error_line(capsys)
    assert tree(tmp_path) == before  # the marker and figures/ it made are gone, notes.txt kept


def test_removed_on_failure_keeps_anything_finished(tmp_path):
    """The rule behind the cases above (``files.removed_on_failure``), against a hand-made
    tree: a directory made inside the block is removed on failure only while it holds nothing
    but the named bookkeeping files; what existed before is never touched."""
    from jamlab.files import removed_on_failure

    old, bare, worked = tmp_path / "old", tmp_path / "bare", tmp_path / "worked"
    old.mkdir()
    with pytest.raises(KeyboardInterrupt), removed_on_failure([old, bare, worked],
                                                              frozenset({"manifest.json"})):
        (old / "manifest.json").write_text("{}")
        (bare / "a" / "b").mkdir(parents=True)
        (bare / "a" / "manifest.json").write_text("{}")
        (worked / "samples").mkdir(parents=True)
        (worked / "manifest.json").write_text("{}")
        (worked / "samples" / "0.h5").write_bytes(b"finished")
        raise KeyboardInterrupt
    assert (old / "manifest.json").is_file()  # existed on entry: left as the block made it
    assert not bare.exists()
    assert (worked / "samples" / "0.h5").read_bytes() == b"finished"
    # and nothing is removed when the block succeeds
    with removed_on_failure([tmp_path / "fine"], frozenset()):
        (tmp_path / "fine").mkdir()
    assert (tmp_path / "fine").is_dir()


def test_every_sample_failed_is_one_line_with_exit_1_and_the_failures_kept(tmp_path, capsys):
    """α = 1000: no tiny packing jams, every sample fails; the analysis then raised an
    AttributeError (a 46-line traceback, exit 1) on the empty ensemble (audit rows 7-8)."""
    out = tmp_path / "r"
    assert run(reproduce(out, "--alpha", 1000)) == 1
    line = error_line(capsys)
    assert "no sample of the jamming ensemble finished: 3 of 3 failed" in line, line
    assert "no report written" in line
    assert not (out / "report.md").exists()
    failed = list((out / "runs" / "jamming" / "samples").rglob("*.failed.json"))
    assert len(failed) == 3  # the records of what failed stay for `jamlab status --failures`


@pytest.mark.parametrize("version", [99, 0, "1", True, None])
def test_a_run_manifest_of_another_format_version_is_refused(tmp_path, capsys, version):
    """A manifest with ``"format_version": 99`` was read as version 1, and a report written
    from it with exit 0 (audit row 9). Every jamlab manifest has carried the version."""
    from jamlab.reproduce import SCALES

    toy_runs(tmp_path / "runs", SCALES["tiny"])
    path = tmp_path / "runs" / "jamming" / "manifest.json"
    manifest = json.loads(path.read_text())
    if version is None:
        del manifest["format_version"]
    else:
        manifest["format_version"] = version
    path.write_text(json.dumps(manifest))
    assert run(["figure", "fig4", "--out", tmp_path / "f.png", "--runs", tmp_path / "runs",
                "--scale", "tiny"]) == 2  # fmt: skip
    assert f"has format_version {version!r}: this jamlab reads" in error_line(capsys)
    assert not (tmp_path / "f.png").exists()


def test_figure_redraws_a_report_made_with_another_seed(tmp_path, capsys):
    """``figure`` compared the runs with the scale's default seed and had no --seed, so no
    figure of a report made with ``--seed 1`` could be redrawn (audit row 10). The tiny scale's
    own jamming and unsat runs (about 10 s)."""
    from jamlab.reproduce import SCALES, with_seed

    toy_runs(tmp_path / "runs", with_seed(SCALES["tiny"], 1), task=None)
    args = ["figure", "fig4", "--runs", tmp_path / "runs", "--scale", "tiny"]
    assert run([*args, "--out", tmp_path / "a.png"]) == 2
    line = error_line(capsys)
    assert "(seed: 1 != 0;" in line and "give the --scale, --seed, --sizes and --alpha" in line
    assert run([*args, "--seed", 1, "--out", tmp_path / "b.png"]) == 0
    assert (tmp_path / "b.png").stat().st_size > 0


@pytest.mark.parametrize("kind", ["configuration", "trace"])
@pytest.mark.parametrize("version", [99, 0, "2", 1.5])
def test_hdf5_files_of_another_format_version_are_refused(tmp_path, capsys, kind, version):
    """The same rule for configurations (version 1) and traces (versions 1 and 2): a file that
    says it is of a version this jamlab does not know is refused by every reader (here
    ``inspect`` and ``export``), one line with exit code 2; a file without the attribute
    (another program's) is read as before."""
    import h5py

    path = tmp_path / "c.h5"
    assert run(["random-packing", "--n", "8", "--phi", "0.3", "--dim", "2", "--out", path]) == 0
    if kind == "trace":
        trace = tmp_path / "t.h5"
        assert run(["shear", path, "--out", trace, "--dgamma", "0.01", "--gamma-max", "0.02"]) == 0
        path = trace
    capsys.readouterr()
    with h5py.File(path, "r+") as h5:
        h5.attrs["format_version"] = version
    command = ["inspect", path] if kind == "configuration" else ["export", path, "--out",
                                                                 tmp_path / "t.xyz"]
    assert run(command) == 2
    assert f"has format_version {version!r}: this jamlab reads {kind} files of version 1 to" \
        in error_line(capsys)
    with h5py.File(path, "r+") as h5:
        del h5.attrs["format_version"]
    assert run(command) == 0


def test_figure_refuses_a_runs_path_that_is_not_a_directory(tmp_path, capsys):
    """``figure fig1 --runs missing`` ignored the --runs it was given (fig1 needs none); a
    figure that reads runs refuses a --runs that is not a directory."""
    (tmp_path / "file.txt").write_text("mine\n")
    for runs in (tmp_path / "missing", tmp_path / "file.txt"):
        assert run(["figure", "fig5", "--runs", runs, "--out", tmp_path / "f.png"]) == 2
        assert f"--runs {runs} is not a directory" in error_line(capsys)
    assert not (tmp_path / "f.png").exists()


@pytest.mark.parametrize("name", ["fig1", "fig2", "fig3", "fig3_exact", "theory_vs_cascade"])
def test_figure_refuses_runs_for_a_computed_figure(tmp_path, capsys, name):
    """``figure fig3 --runs runA`` ignored --runs and said "wrote" (a third audit): the figures
    computed from the scale alone read no run directory, so --runs is an error for them."""
    (tmp_path / "runs").mkdir()
    assert run(["figure", name, "--runs", tmp_path / "runs", "--out", tmp_path / "f.png"]) == 2
    assert f"{name} is computed, it reads no runs: drop --runs" in error_line(capsys)
    assert not (tmp_path / "f.png").exists()


def test_the_log_counts_the_local_processes_started():
    """``--workers 1000000000`` logged "on 1000000000 local processes"; a pool starts at most
    one process per sample to run (``runs.execute``: ``min(workers, len(items))``)."""
    from jamlab.runs import Execution
    from jamlab.threads import usable_cores

    cores = usable_cores()
    shared = f" sharing {cores} usable core{'s' if cores != 1 else ''}"
    assert Execution(workers=10**9).describe(12) == "12 local processes" + shared * (12 > cores)
    assert Execution(workers=2).describe(12) == "2 local processes" + shared * (2 > cores)
    assert Execution(workers=2).describe(1) == "1 local process"
    assert Execution(workers=0).describe(12) == "in-process"
