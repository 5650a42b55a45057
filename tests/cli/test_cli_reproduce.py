"""`jamlab reproduce`: bad input is one line with exit code 2; report files it did not write are
refused without --force; `figure` draws the suffix's format. (The tiny scale's run and its
resumption through the command: ``tests/test_reproduce.py``, on the one tiny reproduction there.)"""

import json

import pytest

from cli_helpers import jamlab, one_line_error
from jamlab.reproduce import reproduce
from jamlab.runs import Execution


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
    # the fixed-pressure figures: a scale without such ensembles, or runs without them
    for name in ("fig5_pressure", "tau_pressure"):
        line = one_line_error(jamlab("figure", name, "--runs", tmp_path, "--scale", "tiny",
                                     "--out", tmp_path / "x.png"))
        assert "the scale 'tiny' has none (quick and medium have)" in line
        line = one_line_error(jamlab("figure", name, "--runs", tmp_path, "--scale", "quick",
                                     "--out", tmp_path / "x.png"))
        assert f"{tmp_path / 'pressure-1e-05'} is not a run directory" in line
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("name", ["index.html", "report.md", "results.json", "report.json",
                                  "figures/mine.png"])
def test_report_files_of_something_else_are_refused_before_anything_runs(tmp_path, name):
    out = tmp_path / "site"
    (out / name).parent.mkdir(parents=True)
    (out / name).write_text("<html>mine</html>")
    with pytest.raises(ValueError, match="not written by jamlab reproduce; give --force"):
        reproduce("tiny", out, execution=Execution(workers=0))
    assert (out / name).read_text() == "<html>mine</html>"
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [name]


def test_an_earlier_report_of_reproduce_is_its_own(tmp_path):
    from jamlab.reproduce.pipeline import MARKER, TITLE, check_report_directory

    out = tmp_path / "site"
    out.mkdir()
    (out / "index.html").write_text("<html>mine</html>")
    with pytest.raises(ValueError, match="index.html"):
        check_report_directory(out)
    check_report_directory(out, force=True)  # --force: replaced
    # a report written before the marker existed: results.json with reproduce's title
    (out / "results.json").write_text(json.dumps({"title": TITLE, "rows": []}))
    check_report_directory(out)
    (out / "results.json").write_text(json.dumps({"title": "my own"}))
    with pytest.raises(ValueError, match="index.html, results.json"):
        check_report_directory(out)
    (out / MARKER).write_text("{}")  # the marker reproduce writes before anything else
    check_report_directory(out)
    check_report_directory(tmp_path / "missing")  # a new directory: nothing to refuse


def test_the_marker_is_written_before_the_runs(tmp_path, monkeypatch):
    import jamlab.reproduce.pipeline as pipeline

    seen = []

    def stop(*args, **kwargs):
        # a first call killed from here on (SIGKILL: no clean-up) leaves a directory that the
        # next call recognises as its own and resumes
        seen.append((tmp_path / "r" / pipeline.MARKER).is_file())
        pipeline.check_report_directory(tmp_path / "r")
        raise RuntimeError("stop before running")

    monkeypatch.setattr(pipeline, "_run_all", stop)
    with pytest.raises(RuntimeError, match="stop before running"):
        reproduce("tiny", tmp_path / "r", execution=Execution(workers=0))
    assert seen == [True]
    # an exception before any sample finished: what the call made is removed again
    assert not (tmp_path / "r").exists()


def test_cli_refuses_report_files_it_did_not_write(tmp_path):
    site = tmp_path / "site"
    site.mkdir()
    (site / "index.html").write_text("<html>mine</html>")
    (site / "report.md").write_text("# notes")
    line = one_line_error(jamlab("reproduce", "--scale", "tiny", "--out", site, "--workers", 0))
    assert "index.html, report.md" in line and "--force" in line
    assert (site / "index.html").read_text() == "<html>mine</html>"
    assert (site / "report.md").read_text() == "# notes"
    assert sorted(p.name for p in site.iterdir()) == ["index.html", "report.md"]


@pytest.mark.parametrize("suffix, magic", [(".pdf", (b"%PDF",)), (".svg", (b"<?xml", b"<svg")),
                                           (".png", (b"\x89PNG\r\n\x1a\n",)),
                                           (".jpg", (b"\xff\xd8\xff",))])
def test_figure_is_drawn_in_the_format_of_its_suffix(tmp_path, suffix, magic):
    out = tmp_path / f"fig3{suffix}"
    r = jamlab("figure", "fig3", "--out", out)
    assert r.returncode == 0, r.stderr
    assert out.read_bytes().startswith(magic), out.read_bytes()[:16]
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no temporary file left


def test_make_figure_refuses_an_unknown_suffix_before_drawing(tmp_path):
    from jamlab.reproduce import make_figure

    with pytest.raises(ValueError, match="a figure needs one of the suffixes"):
        make_figure("fig3", "tiny", tmp_path, tmp_path / "f.xyz")
    assert not list(tmp_path.iterdir())
