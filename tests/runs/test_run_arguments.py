"""The scripts' shared ``runs`` / ``--n`` arguments (:mod:`jamlab.runs.arguments`), and
:func:`jamlab.reproduce.ensembles.last_rows`: against the expansion written out by hand."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

from jamlab.reproduce.ensembles import last_rows
from jamlab.runs import add_run_arguments, sizes_per_run


def parsed(
    argv: list[str], default_n: int | None = None
) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    ap = argparse.ArgumentParser(prog="probe")
    add_run_arguments(ap, default_n=default_n)
    return ap, ap.parse_args(argv)


def test_one_size_for_every_run_and_one_per_run():
    ap, a = parsed(["r1", "r2", "r3", "--n", "500"])
    assert a.runs == [Path("r1"), Path("r2"), Path("r3")]
    assert sizes_per_run(ap, a) == [500, 500, 500]
    ap, a = parsed(["r1", "r2", "--n", "250", "1000"])
    assert sizes_per_run(ap, a) == [250, 1000]
    ap, a = parsed(["r1", "r2"], default_n=500)
    assert sizes_per_run(ap, a) == [500, 500]


def test_wrong_count_is_a_one_line_error_with_exit_code_2(capsys):
    ap, a = parsed(["r1", "r2", "--n", "1", "2", "3"])
    with pytest.raises(SystemExit) as stop:
        sizes_per_run(ap, a)
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == "probe: error: --n takes one size or one per run (2), got 3"


def test_n_is_required_without_a_default(capsys):
    with pytest.raises(SystemExit) as stop:
        parsed(["r1"])
    assert stop.value.code == 2
    assert "--n" in capsys.readouterr().err


def test_last_rows_is_each_rows_last_finite_entry():
    nan = np.nan
    values = np.array([[1.0, 2.0, 3.0], [4.0, nan, nan], [5.0, 6.0, nan]])
    by_hand = []
    for row in values:
        i = len(row) - 1
        while not np.isfinite(row[i]):
            i -= 1
        by_hand.append(i)
    got = last_rows(values)
    assert got.dtype == np.int64
    assert got.tolist() == by_hand == [2, 0, 1]
    assert last_rows(np.empty((0, 4))).size == 0
