"""``jamlab criticality``: summary, counts, figures, exit codes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cli_helpers import jamlab, one_line_error
from cli_helpers import run_in_process as run
from jamlab.spheres.io import write_packing
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import remove_rattlers


@pytest.fixture(scope="module")
def packings(tmp_path_factory):
    root = tmp_path_factory.mktemp("crit")
    paths, states = [], []
    for seed, n in ((1, 128), (2, 128), (3, 128), (4, 160), (5, 160)):
        res = jam(n, 3, seed, p_target=1e-6)
        assert res.ok
        path = root / f"p{seed}.h5"
        write_packing(path, res.packing, **res.attrs())
        paths.append(path)
        states.append(remove_rattlers(res.packing))
    return paths, states


WINDOWS = ["--window-theta-e", "0.02,0.5", "--window-theta-l", "0.02,0.5"]
WINDOWS += ["--window-gamma", "1e-4,0.1", "--n-boot", "50"]


def test_summary_counts_and_figures(packings, tmp_path, capsys):
    paths, states = packings
    out = tmp_path / "crit"
    assert run(["criticality", *map(str, paths), "--out", str(out), "--json", *WINDOWS]) == 0
    summary = json.loads(capsys.readouterr().out)
    for name in ("theta_e", "theta_l", "gamma"):
        fit = summary[name]
        assert set(fit) >= {"value", "ci95", "window"}
        assert fit["ci95"][0] <= fit["value"] <= fit["ci95"][1]
    assert summary["theta_e"]["window"] == [0.02, 0.5]
    # counts against the engine's own rattler removal (an independent implementation)
    c = summary["counts"]
    assert c["packings"] == 5
    assert c["contacts"] == sum(s.n_contacts_nr for s in states)
    assert c["rattlers"] == sum(s.n_rattlers for s in states)
    assert c["extended_contacts"] + c["localized_contacts"] == c["contacts"]
    assert summary["isostatic_excess"] == [0]
    assert summary["n"] == [128, 160] and set(summary["by_n"]) == {"128", "160"}
    assert summary["tau_j_from_gamma"] == pytest.approx(1 + summary["gamma"]["value"])
    # forces resolved: ftol 1e-12 against a mean force ~1e-6
    assert 0 < summary["force_resolution"] < 1e-4
    on_disk = json.loads((out / "criticality.json").read_text())
    assert on_disk["theta_e"] == summary["theta_e"]
    for fig in ("distributions.png", "local_exponents.png", "finite_size.png"):
        assert (out / fig).stat().st_size > 1000
    # a second run does not replace the summary unless asked
    again = jamlab("criticality", *paths, "--out", out, *WINDOWS)
    assert "exists" in one_line_error(again)
    assert run(["criticality", *map(str, paths), "--out", str(out), "--overwrite", *WINDOWS]) == 0
    assert np.isfinite(json.loads((out / "criticality.json").read_text())["gamma"]["value"])


def test_user_errors(packings, tmp_path):
    paths, _ = packings
    out = tmp_path / "o"
    assert "no such packing" in one_line_error(
        jamlab("criticality", tmp_path / "missing.h5", "--out", out)
    )
    assert "--window-gamma" in one_line_error(
        jamlab("criticality", paths[0], "--out", out, "--window-gamma", "0.1")
    )
    assert "above --h-max 0.5: gaps above --h-max are not kept" in one_line_error(
        jamlab("criticality", paths[0], "--out", out, "--window-gamma", "1e-4,5")
    )
    assert not out.exists()
    assert "--method" in one_line_error(
        jamlab("criticality", paths[0], "--out", out, "--method", "ols")
    )
    not_h5 = tmp_path / "x.h5"
    not_h5.write_text("hello")
    assert "HDF5" in one_line_error(jamlab("criticality", not_h5, "--out", out, *WINDOWS))
    # packings of two dimensions are not pooled into one fit
    flat = tmp_path / "flat.h5"
    res2 = jam(64, 2, 1, p_target=1e-4)
    write_packing(flat, res2.packing, **res2.attrs())
    err = one_line_error(jamlab("criticality", paths[0], flat, "--out", out, *WINDOWS))
    assert "is 2D" in err and "3D" in err and not out.exists()
    # the automatic window needs statistics: one small packing has none for the localized forces
    err = one_line_error(jamlab("criticality", paths[0], "--out", tmp_path / "p", "--n-boot", "5"))
    assert "window" in err


def _strict_json(text: str) -> dict:
    """Parse as standard JSON: NaN, Infinity are not JSON and fail the test."""

    def refuse(token: str) -> None:
        raise AssertionError(f"not valid JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def test_one_packing_has_no_interval_and_says_why(packings, tmp_path, capsys):
    """One packing: the bootstrap over packings has no spread, so no 95 % interval (it was
    printed as "95% [nan, nan]", with NaN in --json and an empty warnings list)."""
    paths, _ = packings
    out = tmp_path / "one"
    assert run(["criticality", str(paths[0]), "--out", str(out), "--json", *WINDOWS]) == 0
    captured = capsys.readouterr()
    summary = _strict_json(captured.out)
    for name in ("theta_e", "theta_l", "gamma"):
        assert summary[name]["ci95"] == [None, None]
        assert summary[name]["n_packings"] == 1
        assert np.isfinite(summary[name]["value"])
        warning = f"{name}: the 95% interval could not be estimated: 1 packing"
        assert sum(w.startswith(warning) for w in summary["warnings"]) == 1
        assert f"jamlab: warning: {warning}" in captured.err
    saved = _strict_json((out / "criticality.json").read_text())
    assert saved["warnings"] == summary["warnings"] and saved["gamma"]["ci95"] == [None, None]
    out2 = tmp_path / "text"
    assert run(["criticality", str(paths[0]), "--out", str(out2), *WINDOWS]) == 0
    text = capsys.readouterr().out
    assert "nan" not in text.lower()
    assert text.count("95% interval not estimated") == 3


def test_a_group_of_one_packing_is_warned(packings, tmp_path, capsys):
    """N = 128 three times, N = 160 once: the pooled and N = 128 fits have intervals, the
    N = 160 fits none, each with its warning."""
    paths, _ = packings
    args = ["criticality", *map(str, paths[:4]), "--out", str(tmp_path / "c"), "--json"]
    assert run([*args, *WINDOWS]) == 0
    summary = _strict_json(capsys.readouterr().out)
    for name in ("theta_e", "theta_l", "gamma"):
        assert None not in summary[name]["ci95"]
        assert None not in summary["by_n"]["128"][name]["ci95"]
        assert summary["by_n"]["160"][name]["ci95"] == [None, None]
    assert sorted(summary["warnings"]) == sorted(
        f"{name} at N=160: the 95% interval could not be estimated: 1 packing (the bootstrap "
        "resamples packings: it needs at least 2)"
        for name in ("theta_e", "theta_l", "gamma")
    )


def test_the_same_packing_twice_is_refused(packings, tmp_path):
    """Given twice (same path, a symbolic or a hard link) a packing would count as two and give
    a degenerate interval: refused with one line, nothing written."""
    paths, _ = packings
    (tmp_path / "soft.h5").symlink_to(paths[1])
    (tmp_path / "hard.h5").hardlink_to(paths[1])
    for twin in (paths[1], tmp_path / "soft.h5", tmp_path / "hard.h5"):
        out = tmp_path / "twice"
        line = one_line_error(jamlab("criticality", paths[0], paths[1], twin, "--out", out))
        assert f"packing {twin} is" in line and "each file may be given once" in line
        assert not out.exists()


def test_a_failed_run_leaves_no_empty_out_and_outputs_need_force(tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not a packing")
    out = tmp_path / "c"
    assert run(["criticality", str(bad), "--out", str(out)]) == 2
    assert not out.exists()  # it was created for the run, and the run failed
    # an earlier run's figure (or summary) in --out is not replaced without --force
    out.mkdir()
    (out / "distributions.png").write_bytes(b"an earlier figure")
    capsys.readouterr()
    assert run(["criticality", str(bad), "--out", str(out)]) == 2
    assert "distributions.png exists; give --force" in capsys.readouterr().err
    assert (out / "distributions.png").read_bytes() == b"an earlier figure"


def test_a_bad_bootstrap_seed_is_named(tmp_path, capsys):
    bad = tmp_path / "p.h5"
    bad.write_bytes(b"x")
    assert run(["criticality", str(bad), "--out", str(tmp_path / "c"), "--seed", "-1"]) == 2
    assert "--seed must be an integer in [0, " in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_out_in_a_run_directory_is_refused(tmp_path, capsys):
    """``--out`` a jamlab run directory, or a folder inside one, would put the summary and the
    figures among that run's members: refused with one line, nothing made there."""
    bad = tmp_path / "p.h5"
    bad.write_bytes(b"x")
    run_dir = tmp_path / "run"
    (run_dir / "samples").mkdir(parents=True)
    (run_dir / "manifest.json").write_text(json.dumps({"format": "jamlab-run"}))
    before = sorted(p.name for p in run_dir.iterdir())
    for out in (run_dir, run_dir / "crit", run_dir / "samples"):
        capsys.readouterr()
        assert run(["criticality", str(bad), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"--out {out} " in err and f"the run directory {run_dir}" in err
        assert len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in run_dir.iterdir()) == before
    assert not any((run_dir / "samples").iterdir())
    # a folder beside a directory whose manifest is another program's is allowed
    other = tmp_path / "other"
    other.mkdir()
    (other / "manifest.json").write_text(json.dumps({"format": "other"}))
    capsys.readouterr()
    assert run(["criticality", str(bad), "--out", str(other / "crit")]) == 2
    assert "run directory" not in capsys.readouterr().err  # it fails on the packing instead
