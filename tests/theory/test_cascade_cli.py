"""``jamlab cascade``: runs end to end, writes figures and CSV; bad input: one line, exit 2."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

# the command plots the printed theory of jamlab.theory.jumps beside the samples
pytest.importorskip("jamlab.theory.jumps")


def run(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "jamlab", "cascade", *args], capture_output=True,
                          text=True, timeout=300, cwd=cwd)


def test_cascade_command_writes_outputs(tmp_path):
    out, csv, tree = tmp_path / "c.png", tmp_path / "c.csv", tmp_path / "t.png"
    r = run("--q", "0,0.5", "--y", "0.5,1.5", "--dgamma", "0.3", "--n", "3000", "--seed", "3",
            "--out", str(out), "--csv", str(csv), "--tree", str(tree))
    assert r.returncode == 0, r.stderr
    assert "p_no_jump sampled" in r.stdout and "printed formula" in r.stdout
    assert out.stat().st_size > 0 and tree.stat().st_size > 0
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert data.shape == (3000, 5)
    np.testing.assert_allclose(data[:, 0], data[:, 1] - 0.3 * data[:, 2], atol=1e-12)


def test_cascade_command_bad_input_is_one_line_exit_2(tmp_path):
    for args in (["--q", "0,0.5", "--y", "1.5,0.5"], ["--linear", "2.5", "--q", "0"],
                 ["--linear", "2.5", "--q-max", "0.9", "--k", "8", "--n", "0"]):
        r = run(*args, "--out", str(tmp_path / "x.png"))
        assert r.returncode == 2, (args, r.stderr)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("jamlab: error:"), r.stderr
    for n in ("0", "100000001"):  # the bound of --n, by the validation layer's wording
        r = run("--linear", "2.5", "--n", n, "--out", str(tmp_path / "x.png"))
        assert r.returncode == 2 and r.stderr.strip() == (
            f"jamlab: error: --n must be an integer in [1, 100000000], got {n}"), r.stderr
    assert not (tmp_path / "x.png").exists()


def test_cascade_levels_are_bounded(tmp_path):
    """--k is at most 4096 (MAX_LEVELS): above, one short line and exit 2 at once. Before, 1e18
    levels ended in a MemoryError traceback and 1e6 levels in a 'line' listing every y; at 4096
    the check lets the levels through, and the sampler's float64 overflow is named in one short
    line (without the 4096 values, and without numpy's overflow warnings before it)."""
    for k, needle in (("4097", "--k"), ("1000000", "--k"), (str(10**18), "--k"),
                      ("4096", "cascade constants overflow float64 for these 4096 levels"),
                      ("1", "cascade constants overflow float64 for these 1 levels")):
        # (k = 1 with q_max = 1 and a huge dgamma: the same overflow from T, one line too)
        args = ("--q-max", "1", "--dgamma", "1e200") if k == "1" else ("--q-max", "0.9")
        r = run("--linear", "2.5", *args, "--k", k, "--n", "10", "--out", str(tmp_path / "x.png"))
        assert r.returncode == 2, (k, r.stderr[:500])
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("jamlab: error:"), r.stderr[:500]
        assert needle in lines[0] and len(lines[0]) < 200, lines[0][:500]
        if needle == "--k":
            assert "[1, 4096]" in lines[0]
    assert not (tmp_path / "x.png").exists()


def test_sampler_levels_are_bounded():
    from jamlab.theory import ParisiFunction, sample_cascade_jumps
    from jamlab.theory.cascade import MAX_LEVELS

    assert MAX_LEVELS == 4096  # the bound docs/theory-vs-cascade.md gives
    with pytest.raises(ValueError, match="1 <= k <= 4096"):
        sample_cascade_jumps(ParisiFunction.linear(2.5, 0.0, 0.9), dgamma=0.1, n=1, seed=1,
                             k=10**18)


def test_cascade_strain_beyond_the_sampler_is_one_line_at_once(tmp_path, monkeypatch):
    """--dgamma 30 with one level (q = 0, y = 1): a sample would draw ~e^450 states. Before, the
    sampler drew 5e7 nodes (~15 s) and ended in a RuntimeError traceback, exit 1; now
    check_representable refuses it up front (the kernel is not called) in one line, exit 2."""
    r = run("--q", "0", "--y", "1", "--dgamma", "30", "--n", "10", "--out",
            str(tmp_path / "x.png"))
    assert r.returncode == 2, r.stderr[-2000:]
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("jamlab: error: dgamma=30.0 is too large"), \
        r.stderr[-2000:]
    assert "5e+07 nodes" in lines[0] and "smaller |dgamma|" in lines[0]
    assert not (tmp_path / "x.png").exists()

    from jamlab.theory import cascade

    def never(*args):
        raise AssertionError("the sampler ran")

    monkeypatch.setattr(cascade._k, "sample_batch", never)
    with pytest.raises(ValueError, match="too large for these levels"):
        cascade.sample_cascade_jumps([0.0], [1.0], 30.0, 1, seed=1)
    with pytest.raises(ValueError, match="too large for these levels"):
        cascade.sample_cascade_jumps([0.0], [1.0], -7.2, 1, seed=1)  # the bound's edge (doc)
    cascade.check_representable([0.0], [1.0], 7.1)  # not refused
    # two levels: refused where the product over the levels is below MAX_MISS
    with pytest.raises(ValueError, match="k=2, y up to 1.5"):
        cascade.check_representable([0.0, 0.5], [0.5, 1.5], 10.0)


def test_a_sample_reaching_the_node_limit_is_one_line(monkeypatch):
    """A strain the up-front bound lets through but whose sample reaches MAX_NODES (here lowered
    to 200 so that it happens at once) is a one-line ValueError naming dgamma and the limit,
    not the kernel's RuntimeError."""
    from jamlab.theory import cascade

    monkeypatch.setattr(cascade, "MAX_NODES", 200)
    with pytest.raises(ValueError) as e:
        cascade.sample_cascade_jumps([0.0, 0.5], [0.5, 1.5], 3.0, 200, seed=1)
    msg = str(e.value)
    assert "\n" not in msg and "more than 2e+02 nodes" in msg and "dgamma=3.0" in msg, msg
    assert "smaller |dgamma|" in msg


def test_cascade_tree_at_the_node_limit(tmp_path):
    """--tree draws at most 65534 nodes. It used to stop there without a word (exit 0). Now a
    tree that stops inside its window is drawn with a one-line stderr note giving the window it
    holds (and the title says so); one that stops before its ground states are settled is one
    line, exit 2, and nothing is written (the tree is sampled before any output)."""
    common = ("--q", "0,0.5", "--y", "0.5,1.5", "--dgamma", "3", "--n", "1")
    out, csv, tree = tmp_path / "c.png", tmp_path / "c.csv", tmp_path / "t.png"
    r = run(*common, "--seed", "2", "--out", str(out), "--csv", str(csv), "--tree", str(tree))
    assert r.returncode == 0, r.stderr[-2000:]
    assert tree.stat().st_size > 0 and f"tree: {tree}" in r.stdout
    notes = [ln for ln in r.stderr.splitlines() if ln.startswith("jamlab: note:")]
    assert len(notes) == 1, r.stderr[-2000:]
    assert "stopped at 65534 nodes" in notes[0] and "not 1.5" in notes[0], notes[0]
    out.unlink(), csv.unlink(), tree.unlink()
    r = run(*common, "--seed", "34", "--out", str(out), "--csv", str(csv), "--tree", str(tree))
    assert r.returncode == 2, r.stderr[-2000:]
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("jamlab: error: the cascade tree needs more "
                                                   "than 65534 nodes"), r.stderr[-2000:]
    assert not out.exists() and not csv.exists() and not tree.exists()


def test_total_work_beyond_the_limit_is_one_line_at_once(tmp_path, monkeypatch):
    """One level (q = 0, y = 1) at --dgamma 5 with the default --n 100000: each sample draws
    ~2.7e5 nodes, 2.7e10 in all, about an hour. Before, the command just ran; now it is refused
    up front in one line naming the largest --n that fits, exit 2, nothing written."""
    r = run("--q", "0", "--y", "1", "--dgamma", "5", "--out", str(tmp_path / "x.png"))
    assert r.returncode == 2, r.stderr[-2000:]
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("jamlab: error: n=100000 samples"), lines
    # the largest n: 1e10 / (T_1 - 1), T_1 = 1/2 + e^{25/2} Φ(5) from mpmath (independent)
    import mpmath

    t1 = mpmath.mpf(1) / 2 + mpmath.e ** (mpmath.mpf(25) / 2) * mpmath.ncdf(5)
    assert f"use n <= {int(mpmath.floor(mpmath.mpf(10) ** 10 / (t1 - 1)))} " in lines[0], lines
    assert list(tmp_path.iterdir()) == []

    from jamlab.theory import cascade

    def never(*args):
        raise AssertionError("the sampler ran")

    monkeypatch.setattr(cascade._k, "sample_batch", never)
    with pytest.raises(ValueError, match="would draw at least"):
        cascade.sample_cascade_jumps([0.0], [1.0], 5.0, 100_000, seed=1)


def test_the_expected_nodes_bound_is_below_the_sampled_mean():
    """expected_nodes_bound is a lower bound on the mean nodes per sample: for one level it is
    T_1 - 1 (mpmath), the sampled mean itself; with two and three levels it lies below the
    sampled mean (far below: it leaves out the stress increments, docs/theory-vs-cascade.md)."""
    import mpmath

    from jamlab.theory.cascade import expected_nodes_bound, sample_cascade_jumps

    b = 3.0
    t1 = float(mpmath.mpf(1) / 2 + mpmath.e ** (mpmath.mpf(b) ** 2 / 2) * mpmath.ncdf(b))
    assert expected_nodes_bound([0.0], [1.0], 3.0) == pytest.approx(t1 - 1, rel=1e-12)
    for q, y, dg, n in [([0.0], [1.0], 3.0, 20_000), ([0.0, 0.5], [0.5, 1.5], 2.0, 2_000),
                        ([0.0, 0.3, 0.7], [0.3, 1.0, 2.5], 1.0, 2_000)]:  # fmt: skip
        nodes = sample_cascade_jumps(q, y, dg, n, seed=3).n_nodes
        mean, se = nodes.mean(), nodes.std() / np.sqrt(n)
        assert expected_nodes_bound(q, y, dg) < mean + 4 * se, (q, dg, mean)
    assert expected_nodes_bound([0.0], [1.0], 0.0) == 0.0


def test_the_running_projection_stops_the_run_at_its_rule():
    """The kernel's running projection (PROJECTION_AFTER): it stops after the first sample at
    which the nodes drawn so far reach check_after and their mean times n exceeds max_total, the
    rule recomputed here from the uninterrupted run's node counts; the rows drawn before the stop
    are that run's first rows, bit for bit (the samples do not depend on the limit)."""
    from jamlab.theory import cascade

    q, y, dg, n = [0.0, 0.5], [0.5, 1.5], 2.0, 400
    cst = cascade.cascade_constants(q, y, dg)
    args = (np.asarray(y, float), cst["sd"], cst["T"], cst["c"], dg, n, 12345, cascade.MAX_NODES)
    full = cascade._k.sample_batch(*args)
    cum = np.cumsum(full[:, cascade._k.OUT_NNODES])
    max_total, after = 0.5 * cum[-1], 0.1 * cum[-1]
    stop = np.flatnonzero((cum >= after) & (cum / np.arange(1, n + 1) * n > max_total))[0]
    part = cascade._k.sample_batch(*args, max_total, after)
    assert part.shape[0] == stop + 1 < n
    np.testing.assert_array_equal(part, full[: stop + 1])
    # a limit the run stays under: every row, the same
    np.testing.assert_array_equal(cascade._k.sample_batch(*args, 2.0 * cum[-1], 0.0), full)


def test_a_multi_level_run_beyond_the_limit_stops_early_in_one_line(monkeypatch):
    """Two levels at δγ = 2: the up-front bound (Σ a_i (R_i - 1)) lets it through, the running
    projection stops it (limits scaled down here so that it takes milliseconds); the message
    names the projection and an n that fits."""
    from jamlab.theory import cascade

    q, y, dg, n = [0.0, 0.5], [0.5, 1.5], 2.0, 20_000
    monkeypatch.setattr(cascade, "MAX_TOTAL_NODES", 3e5)
    monkeypatch.setattr(cascade, "PROJECTION_AFTER", 3e3)
    assert n * cascade.expected_nodes_bound(q, y, dg) < 3e5  # not refused up front
    with pytest.raises(ValueError, match=r"project to .* use n <= \d+ ") as err:
        cascade.sample_cascade_jumps(q, y, dg, n, seed=3)
    assert "\n" not in str(err.value)
    fits = int(str(err.value).split("use n <= ")[1].split()[0])
    assert 0 < fits < n
