"""``jamlab theory``: the README's main job, several --dgamma values, CSV, one-line errors."""

import csv

import numpy as np

from cli_helpers import jamlab
from jamlab.theory import ParisiFunction, jump_distribution


def test_theory_draws_figure_and_csv(tmp_path):
    r = jamlab(
        "theory", "--mu", "0.706346", "--dgamma", "1e-2", "1e-3", "1e-4",
        "--out", "fig3a.png", "--csv", "fig3a.csv", "--points", "40", cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    png = (tmp_path / "fig3a.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    with open(tmp_path / "fig3a.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    dgs = sorted({float(row["dgamma"]) for row in rows})
    assert dgs == [1e-4, 1e-3, 1e-2]
    assert len(rows) == 3 * 40
    # the CSV holds the library's numbers (spot check against a direct evaluation)
    pick = [row for row in rows if float(row["dgamma"]) == 1e-3][20]
    dist = jump_distribution(ParisiFunction.power_law(0.706346), 1e-3)
    e = float(pick["abs_dE"])
    assert np.isclose(float(pick["pdf"]), dist.pdf(-e), rtol=1e-12)
    assert np.isclose(float(pick["cdf"]), dist.cdf(-e), rtol=1e-12)


def test_theory_bad_arguments_are_one_line(tmp_path):
    for args in (
        ["--mu", "1.3", "--out", "x.png"],
        ["--mu", "0.6", "--dgamma", "0", "--out", "x.png"],
        ["--mu", "0.6", "--q-max", "2", "--out", "x.png"],
        ["--mu", "abc", "--out", "x.png"],
        ["--mu", "0.6", "--out", "no/such/dir/x.png"],
    ):
        r = jamlab("theory", *args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stderr)
        lines = [line for line in r.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("jamlab: error:"), r.stderr
        assert "Traceback" not in r.stderr


def test_dgamma_expansion():
    from jamlab.cli.theory import expand_dgamma

    assert expand_dgamma(["--dgamma", "1e-2", "-3e-3", "--mu", "0.5"]) == [
        "--dgamma", "1e-2", "--dgamma", "-3e-3", "--mu", "0.5",
    ]  # fmt: skip


def test_theory_refuses_a_figure_without_its_jumps(tmp_path):
    """``--amplitude 0`` (``y ≡ 0``: no jumps) and a ``δγ`` whose jumps all lie above the drawn
    range ``|ΔE| ≤ 20|δγ|`` (the printed formula at ``μ_J``, ``A = 1``: the cdf at ``−20δγ`` is
    1 for δγ = 10) are refused in one line, and no figure is written; δγ = 1, whose jumps lie
    inside the range, is drawn."""
    dist = jump_distribution(ParisiFunction.power_law(0.706346), 10.0)
    assert dist.cdf(-200.0) > 0.99  # the case the refusal is for
    for args in (["--amplitude", "0"], ["--dgamma", "10"], ["--dgamma", "1e-3", "100"]):
        r = jamlab("theory", "--mu", "0.706346", *args, "--out", "x.png", cwd=tmp_path)
        assert r.returncode == 2 and r.stderr.count("\n") == 1, (args, r.stderr)
        assert not (tmp_path / "x.png").exists()
    r = jamlab("theory", "--mu", "0.706346", "--dgamma", "1", "--points", "20", "--out", "x.png",
               cwd=tmp_path)
    assert r.returncode == 0 and (tmp_path / "x.png").exists(), r.stderr
