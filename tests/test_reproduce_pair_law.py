"""``jamlab reproduce --sizes/--alpha``: the ensembles of another system (SPEC.md §5)."""

from __future__ import annotations

from pathlib import Path

import pytest

from jamlab.cli import main
from jamlab.reproduce import SCALES
from jamlab.reproduce.cache import cache_file
from jamlab.reproduce.scales import studies, with_pair_law
from jamlab.reproduce.table import parameters


def test_pair_law_reaches_every_ensemble_and_the_report():
    paper = SCALES["tiny"]
    other = with_pair_law(paper, "polydisperse:0.1", 2.5)
    for name, study in studies(other).items():
        assert (study.sizes, study.alpha) == ("polydisperse:0.1", 2.5), name
    for study in studies(paper).values():
        assert (study.sizes, study.alpha) == ("mono", 2.0)
    assert "not the paper's system" in parameters(other, Path("r"))["space dimension, potential"]
    assert parameters(paper, Path("r"))["space dimension, potential"].startswith("d = 3, V(r) = (1")
    assert cache_file(Path("c"), 64, 1, 40) != cache_file(Path("c"), 64, 1, 40, "bidisperse", 2.0)
    assert cache_file(Path("c"), 64, 1, 40).name == "coordination_N64_seed1_steps40.npz"


def run(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code)


@pytest.mark.parametrize("args", [["--sizes", "tri"], ["--alpha", "0.5"]])
def test_bad_pair_law_is_one_line(tmp_path, capsys, args):
    assert run(["reproduce", "--scale", "tiny", "--out", str(tmp_path / "r"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jamlab: error:")
    assert not (tmp_path / "r").exists()
