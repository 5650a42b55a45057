"""`jamlab reproduce`: bad input is one line with exit code 2; the tiny scale runs and resumes."""

import json

import pytest

from cli_helpers import jamlab, one_line_error


def test_unknown_scale_is_one_line(tmp_path):
    line = one_line_error(jamlab("reproduce", "--scale", "huge", "--out", tmp_path / "r"))
    assert "unknown scale 'huge'" in line and "quick" in line and "paper" in line
    assert not (tmp_path / "r").exists()


def test_unwritable_out_is_one_line(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    line = one_line_error(jamlab("reproduce", "--scale", "tiny", "--out", blocker / "report"))
    assert "cannot create output directory" in line and str(blocker) in line
    assert blocker.read_text() == "x"


def test_bad_scheduler_is_one_line(tmp_path):
    line = one_line_error(jamlab("reproduce", "--scale", "tiny", "--out", tmp_path / "r",
                                 "--scheduler", "nowhere"))
    assert "scheduler" in line


@pytest.mark.slow
def test_tiny_reproduction_then_resume(tmp_path):
    out = tmp_path / "report"
    r = jamlab("reproduce", "--scale", "tiny", "--out", out, "--workers", 0)
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and "index.html" in r.stdout
    assert "jamming: 3 computed, 0 reused, 0 failed" in r.stderr
    data = json.loads((out / "results.json").read_text())
    assert all((out / f["path"]).is_file() for f in data["figures"])
    # the same command again computes no sample
    r2 = jamlab("reproduce", "--scale", "tiny", "--out", out, "--workers", 0)
    assert r2.returncode == 0, r2.stderr
    for name, total in (("jamming", 3), ("unsat", 6), ("stress-strain", 3)):
        assert f"{name}: 0 computed, {total} reused, 0 failed" in r2.stderr
    again = json.loads((out / "results.json").read_text())
    assert [r["value"] for r in again["rows"]] == [r["value"] for r in data["rows"]]


def test_figure_command_makes_one_theory_figure(tmp_path):
    r = jamlab("figure", "fig2", "--out", tmp_path / "tree.png")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "tree.png").read_bytes()[:4] == b"\x89PNG"


def test_figure_command_errors_are_one_line(tmp_path):
    assert "unknown figure 'fig9'" in one_line_error(
        jamlab("figure", "fig9", "--out", tmp_path / "x.png"))
    assert "needs --runs" in one_line_error(jamlab("figure", "fig5", "--out", tmp_path / "x.png"))
    line = one_line_error(jamlab("figure", "fig5", "--runs", tmp_path, "--out", tmp_path / "x.png"))
    assert "is not a run directory" in line
    assert not (tmp_path / "x.png").exists()
