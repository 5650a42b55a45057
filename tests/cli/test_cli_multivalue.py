"""Options with several values (``jamlab.cli.multivalue``): an option given without a value is
refused (exit 2, one line), not silently replaced by its default; and a command that warns about
its input refuses a bad argument before any warning (one line in all). Both were found by
``test_cli_fuzz.py``'s random examples (``--dgamma --``; ``coordination`` on a packing far above
jamming with ``--dphi-max 0.5``)."""

from __future__ import annotations

import pytest

from cli_helpers import jamlab, one_line_error
from jamlab.cli.multivalue import expand_multi_values


def test_expansion():
    opts = ("--phi", "--n")
    assert expand_multi_values(["--phi", "0.7", "0.8", "--n", "-5", "16", "-q"], opts) == [
        "--phi", "0.7", "--phi", "0.8", "--n", "-5", "--n", "16", "-q"]  # fmt: skip
    assert expand_multi_values(["--n", "16", "s.toml"], opts) == ["--n", "16", "s.toml"]
    assert expand_multi_values(["--phi=0.8", "x"], opts) == ["--phi=0.8", "x"]
    assert expand_multi_values(["--n", "16", "--", "x"], opts) == ["--n", "16", "--", "x"]
    # an option without a value is refused, named
    for bare in (["--phi"], ["--phi", "--", "x"], ["--phi", "--n", "8"], ["--n", "s.toml"],
                 ["--n", "-q"]):
        with pytest.raises(ValueError, match=f"option {bare[0]} requires a value"):
            expand_multi_values(bare, opts)


@pytest.mark.parametrize("tail", [["--dgamma", "--"], ["--dgamma"], ["--dgamma", "--mu", "0.5"]])
def test_theory_without_a_dgamma_value_is_refused(tmp_path, tail):
    r = jamlab("theory", "--out", "new.png", "--points", "20", *tail, cwd=tmp_path)
    assert "option --dgamma requires a value" in one_line_error(r)
    assert not (tmp_path / "new.png").exists()


@pytest.mark.parametrize("tail", [["--n"], ["--n", "--", "x"], ["--phi", "--n", "8"]])
def test_run_without_a_value_is_refused(tmp_path, tail):
    r = jamlab("run", "--phi", "0.8", "--n", "8", "--samples", "1", "--dgamma", "1e-3",
               "--gamma-max", "3e-3", "--out", "r", *tail, cwd=tmp_path)
    assert f"option {tail[0]} requires a value" in one_line_error(r)
    assert not (tmp_path / "r").exists()


def test_coordination_refuses_before_warning(tmp_path):
    r = jamlab("prepare", "--phi", "0.8", "--n", "32", "--seed", "1", "--out", "good.h5",
               cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = jamlab("coordination", "good.h5", "--out", "new.png", "--steps", "3", "--quiet",
               "--dphi-max", "0.5", cwd=tmp_path)
    assert "must stay below 1" in one_line_error(r)  # no "far above jamming" warning first
    assert not (tmp_path / "new.png").exists()
