"""``scripts/steady_anatomy.py``: the counted avalanches equal those of ``steady_unsat.py``'s run
without the anatomy (the same protocol by another path), the anatomy's records are those of the
counted steps, the slopes against exact power laws, the file round trip, ``--check`` and the
refusals."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from tests.script_helpers import assert_out_kept, exit_code, script_module


@pytest.fixture(scope="module")
def sa():
    return script_module("steady_anatomy")


@pytest.fixture(scope="module")
def su():
    return script_module("steady_unsat")


JOB = (48, 0.8, 3, 1e-3, 60, 2e-3, 0.1, "bidisperse")


@pytest.fixture(scope="module")
def sample(sa):
    return sa.one_sample(JOB)


def test_counted_sizes_equal_steady_unsat(sa, su, sample):
    """Keeping the anatomy changes nothing of the run: the counted sizes are bit for bit those
    ``steady_unsat.one_sample`` counts on the same job (its run without ``keep_avalanches``)."""
    ref = su.one_sample(JOB)["steady"]["sizes"]
    assert ref.size >= 1  # the case has avalanches to compare
    assert np.array_equal(sample["S"], ref)
    n = JOB[0]
    for c in sa.COLUMNS:
        assert np.asarray(sample[c]).shape[0] == sample["S"].size
    for c in ("radii", "thin_axis", sa.NULL):  # (avalanches, d)
        assert np.asarray(sample[c]).shape == (sample["S"].size, 3)
    assert sample["length"] > 0 and np.all(np.diff(sample["radii"], axis=1) <= 0)
    # the reference turns the same offsets: Σ r_a² (the trace of G) is kept to rounding, and
    # the recomputed extent equalled the recorded one (or one_sample would have raised)
    np.testing.assert_allclose(np.sum(sample[sa.NULL] ** 2, axis=1),
                               np.sum(sample["radii"] ** 2, axis=1), rtol=1e-12)
    assert np.all(np.diff(sample[sa.NULL], axis=1) <= 0)
    assert np.all((sample["n_eff"] >= 1 - 1e-12) & (sample["n_eff"] <= n + 1e-12))
    assert np.array_equal(sample["localized"], sample["n_eff"] <= 10)
    assert np.all(sample["n_moved"] <= n) and sample["converged"]


def test_records_pick_the_counted_rows(sa):
    """Rows 1–4: plastic drop (counted), plastic rise, elastic drop, plastic drop ending unjammed:
    only row 1 counted, and its record found among the plastic rows' records."""
    av = {"step": np.array([1, 2, 4])}
    for k, c in enumerate(sa.COLUMNS):
        av[c] = np.array([10.0 + k, 20.0 + k, 40.0 + k])
    tr = SimpleNamespace(energy_jump=np.array([0.0, -2.0, 1.0, -3.0, -4.0]),
                         plastic=np.array([False, True, True, False, True]),
                         jammed=np.array([True, True, True, True, False]), avalanches=av)
    assert sa.counted_rows(tr).tolist() == [1]
    rec = sa.records(tr)
    assert rec["S"].tolist() == [2.0]
    assert [rec[c][0] for c in sa.COLUMNS] == [10.0 + k for k in range(len(sa.COLUMNS))]
    tr.avalanches = {k: v[1:] for k, v in av.items()}  # the counted step's record missing
    with pytest.raises(RuntimeError, match="without an anatomy record"):
        sa.records(tr)


def test_slopes_of_exact_power_laws(sa):
    rng = np.random.default_rng(1)
    s = 10.0 ** rng.uniform(-6, -1, 200)
    assert sa.log_slope(s, 3.0 * s**0.5) == pytest.approx(0.5, abs=1e-12)
    assert sa.log_slope(np.array([1.0, 4.0]), np.array([3.0, 6.0])) == pytest.approx(0.5)
    assert np.isnan(sa.log_slope(s[:1], s[:1]))
    assert np.isnan(sa.log_slope(np.array([2.0, 2.0]), np.array([1.0, 3.0])))
    # packings with y = S^0.7 exactly: the slope, and σ zero to rounding whatever the resample;
    # points below s_min or with y = 0 are left out
    samples = []
    for k in range(6):
        ss = s[k * 30:(k + 1) * 30]
        y = ss**0.7
        y[0] = 0.0
        samples.append({"S": ss, "n_eff": y})
    slope, sigma, points = sa.packing_slope(samples, lambda r: r["n_eff"], 1e-5, 20, rng)
    assert slope == pytest.approx(0.7, abs=1e-12) and sigma < 1e-10
    assert points == sum(int(np.count_nonzero((r["S"] >= 1e-5) & (r["n_eff"] > 0)))
                         for r in samples)


def test_round_trip_table_and_check(sa, su, sample, tmp_path, capsys):
    out = tmp_path / "a.npz"
    sa.save(out, [sample])
    back = sa.load(out)[0]
    assert (back["n"], back["seed"], back["converged"]) == (JOB[0], JOB[2], True)
    assert back["length"] == sample["length"]
    for c in ("S", *sa.COLUMNS, sa.NULL):
        assert np.array_equal(back[c], sample[c])
    fig = tmp_path / "f.png"
    sa.main(["--load", str(out), "--boot", "5", "--figure", str(fig)])
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    sa.table([back, {**back, "seed": 4}], 1e-9, 10)
    text = capsys.readouterr().out
    assert f"| {JOB[0]} (2) | {2 * sample['S'].size} |" in text
    # --check against steady_unsat result files: the same sizes, then one changed
    ref = tmp_path / "ref.npz"
    entry = {"sizes": sample["S"], "balance": (0.0, 0.0, 0.0), "converged": True,
             "order": (0.0,) * 4}
    su.save(ref, [{"n": JOB[0], "seed": JOB[2], "cpu": 0.0,
                   "transient": entry, "steady": entry}])
    assert sa.check([back], [ref]) == 0
    assert "1 samples identical bit for bit, 0 differ" in capsys.readouterr().out
    changed = {**back, "S": back["S"] * (1 + 1e-15) + 1e-300}
    assert sa.check([changed, {**back, "seed": 99}], [ref]) == 1
    assert "0 samples identical bit for bit, 1 differ, 1 not in" in capsys.readouterr().out


def test_refusals(sa, tmp_path, monkeypatch):
    assert_out_kept(sa, tmp_path / "kept.npz", monkeypatch)
    assert exit_code(sa, ["--load", str(tmp_path / "none.npz")], monkeypatch) == 2
    assert exit_code(sa, ["--s-min", "0"], monkeypatch) == 2
    assert exit_code(sa, ["--n", "4"], monkeypatch) == 2
    assert exit_code(sa, ["--figure", str(tmp_path / "f.txt")], monkeypatch) == 2


def test_top_tenth_by_hand(sa):
    """The largest tenth by S of two packings' pooled avalanches (S = 1 … 20): S ≥ the 90 %
    quantile 18.1, i.e. S = 19 and 20, whose N_eff and contacts changed are returned."""
    s = np.arange(1.0, 21.0)
    samples = [{"S": s[:10], "n_eff": 2 * s[:10], "n_opened": s[:10], "n_closed": 0 * s[:10]},
               {"S": s[10:], "n_eff": 2 * s[10:], "n_opened": s[10:], "n_closed": 1 + 0 * s[10:]}]
    assert sa.top_tenth(samples).tolist() == [38.0, 40.0]
    assert sa.top_tenth(samples, sa.changes).tolist() == [20.0, 21.0]


def test_top_slope_of_scaled_groups(sa):
    """Each N's packings alike, N_eff = N/4 for every avalanche and contacts changed = 2 √N: the
    slopes on ln N are 1 and 0.5 exactly, and every resample gives the same (σ 0)."""
    rng = np.random.default_rng(2)
    s = 10.0 ** rng.uniform(-6, -1, 30)

    def group(n):
        one = {"n": n, "S": s, "n_eff": np.full(30, n / 4), "n_opened": np.full(30, np.sqrt(n)),
               "n_closed": np.full(30, np.sqrt(n))}
        return [dict(one) for _ in range(4)]

    groups = [group(64), group(256), group(1024)]
    b, sb = sa.top_slope(groups, lambda r: r["n_eff"], 20, rng)
    assert b == pytest.approx(1.0, abs=1e-12) and sb < 1e-12
    b, sb = sa.top_slope(groups, sa.changes, 20, rng)
    assert b == pytest.approx(0.5, abs=1e-12) and sb < 1e-12


DATA = Path(__file__).resolve().parents[1] / "data"


def anatomy_rows() -> dict[str, tuple[dict[int, int], list[str]]]:
    """``{file: ({N: samples}, --check files)}`` from the table of ``data/README.md`` on
    ``data/anatomy``."""
    rows = {}
    text = (DATA / "README.md").read_text()
    for m in re.finditer(r"^\| `anatomy/(\S+\.npz)` \| `([^`]*)`", text, re.M):
        argv = m.group(2).split()
        ns = [int(v) for v in argv[argv.index("--n") + 1:argv.index("--samples")]]
        checks = argv[argv.index("--check") + 1:]
        rows[m.group(1)] = ({n: int(argv[argv.index("--samples") + 1]) for n in ns}, checks)
    return rows


def test_committed_anatomy_files_are_what_the_readme_says(sa, capsys):
    rows = anatomy_rows()
    assert rows and sorted(rows) == sorted(p.name for p in (DATA / "anatomy").glob("*.npz"))
    root = DATA.parent
    for name, (counts, checks) in rows.items():
        results = sa.load(DATA / "anatomy" / name)
        keys = [(r["n"], r["seed"]) for r in results]
        assert len(set(keys)) == len(keys), name
        assert {n: sum(1 for k in keys if k[0] == n) for n in counts} == counts, name
        assert all(r["converged"] for r in results), name
        assert sa.check(results, [root / c for c in checks]) == 0, name
        assert f"{len(results)} samples identical bit for bit" in capsys.readouterr().out
        if name.endswith("_axes.npz"):
            # a rerun for the long axis: every column of the earlier file, bit for bit
            earlier = {(r["n"], r["seed"]): r for r in sa.load(DATA / "anatomy" /
                                                                 name.replace("_axes", ""))}
            assert sorted(earlier) == sorted(keys), name
            for r in results:
                o = earlier[(r["n"], r["seed"])]
                for c in ("S", *sa.COLUMNS, sa.NULL):
                    assert np.array_equal(np.asarray(r[c]), np.asarray(o[c]), equal_nan=True)
        for r in results:
            if "long_axis" in r:  # unit vectors orthogonal to the thin axis
                long, thin = np.asarray(r["long_axis"]), np.asarray(r["thin_axis"])
                assert long.shape == thin.shape, name
                np.testing.assert_allclose(np.einsum("ij,ij->i", long, long), 1.0, atol=1e-12)
                assert np.all(np.abs(np.einsum("ij,ij->i", long, thin)) < 1e-12), name


def test_decades_by_hand(sa, capsys):
    """Three avalanches of one N: two in [1e-3, 1e-2) (medians of 10 and 30, 4 and 8, 0.1 and
    0.3), one in [1e-1, 1); the other decades empty."""
    r = {"n": 64, "S": np.array([2e-3, 5e-3, 0.5]), "n_eff": np.array([10.0, 30.0, 60.0]),
         "n_opened": np.array([3, 5, 9]), "n_closed": np.array([1, 3, 1]),
         "max_displacement": np.array([0.1, 0.3, 0.9])}
    sa.decades([r], -3, 0)
    row = capsys.readouterr().out.split("| 64 | ")[1].split("\n")[0]
    assert row == "2: 20 / 6 / 0.2 | 0 | 1: 60 / 10 / 0.9 |"


def test_shape_rows_and_old_files(sa, tmp_path, capsys):
    """``shape_rows`` by hand (ratios, r1/L, |thin axis|, the largest tenth), and a file written
    before the extent existed loads with NaN radii, which the shape table leaves out."""
    s = np.arange(1.0, 21.0)
    radii = np.column_stack([2 * s, s, 0.5 * s])
    null = np.column_stack([s, s, s])
    axis = np.tile([0.0, -1.0, 0.0], (20, 1))
    r = {"n": 64, "S": s, "radii": radii, "thin_axis": axis, sa.NULL: null, "length": 4.0}
    v = sa.shape_rows([r])
    np.testing.assert_allclose(v["r1L"], 0.5 * s)
    np.testing.assert_allclose(v["r2"], 0.5)
    np.testing.assert_allclose(v["r3"], 0.25)
    np.testing.assert_allclose(v["null3"], 1.0)
    np.testing.assert_allclose(v["axis"], np.abs(axis))
    assert sa.shape_rows([r], top=True)["r1"].tolist() == [38.0, 40.0]
    sa.shapes([r])
    assert "| 64 | all (20) | 5.250 | 0.50 / 1.00 | 0.25 / 1.00 (" in capsys.readouterr().out
    old = tmp_path / "old.npz"
    np.savez(old, s0_meta=np.array([64, 1, 2.0, 1.0]), s0_S=s,
             **{f"s0_{c}": np.ones(20) for c in sa.COLUMNS if c not in ("radii", "thin_axis")})
    back = sa.load(old)[0]
    assert np.isnan(back["length"]) and np.all(np.isnan(back["radii"]))
    assert back["radii"].shape == (20, 3)
    sa.shapes([back])
    assert "| 64 | all (0) | — |" in capsys.readouterr().out


def test_shape_decades_by_hand(sa, capsys):
    """Three avalanches of one N: two in [1e-3, 1e-2) (r1 2 and 4, r3 1 and 1: medians 3, 1,
    r3/r1 median of 0.5 and 0.25 = 0.375, reference 1.0), one in [1e-1, 1); a row with NaN
    radii is left out."""
    radii = np.array([[2.0, 1.5, 1.0], [4.0, 2.0, 1.0], [8.0, 8.0, 8.0], [np.nan] * 3])
    r = {"n": 64, "S": np.array([2e-3, 5e-3, 0.5, 6e-3]), "radii": radii,
         sa.NULL: np.ones((4, 3)), "thin_axis": np.zeros((4, 3)), "length": 1.0}
    sa.shape_decades([r], -3, 0)
    row = capsys.readouterr().out.split("| 64 | ")[1].split("\n")[0]
    assert row == "2: 3.00 / 1.00 / 0.38 (1.00) | 0 | 1: 8.00 / 8.00 / 1.00 (1.00) |"


def test_shape_slopes_of_scaled_groups(sa, capsys):
    """Radii ∝ N^(1/3), N^(1/3), N^0 in every avalanche of every packing: the slopes on ln N are
    1/3, 1/3 and 0 with σ 0; thin axes all e_y: pooled median |n_y| 1."""
    s = np.arange(1.0, 11.0)

    def group(n):
        c = n ** (1 / 3)
        one = {"n": n, "S": s, "radii": np.tile([2 * c, c, 1.0], (10, 1)), "length": c,
               "thin_axis": np.tile([0.0, 1.0, 0.0], (10, 1)), sa.NULL: np.ones((10, 3))}
        return [dict(one) for _ in range(3)]

    sa.shapes(group(64) + group(512), boot=10)
    out = capsys.readouterr().out
    assert "r1 0.333 ± 0.000, r2 0.333 ± 0.000, r3 0.000 ± 0.000" in out
    assert "thin axis pooled over N (60 avalanches): |n_x| 0.000" in out and "|n_y| 1.000" in out


def test_shape_excess_by_hand(sa, capsys):
    """Two packings of one N, every avalanche r = (4, 2, 1) against a reference (1, 1, 0.75):
    Δ2 = 0.5 − 1 = −0.5, Δ3 = 0.25 − 0.75 = −0.5, σ 0 (every resample the same); a second N
    with too few avalanches (2 < 3) is left out."""
    one = {"n": 64, "S": np.arange(1.0, 6.0), "radii": np.tile([4.0, 2.0, 1.0], (5, 1)),
           sa.NULL: np.tile([1.0, 1.0, 0.75], (5, 1)), "thin_axis": np.zeros((5, 3)),
           "length": 10.0}
    few = {**one, "n": 128, "S": one["S"][:2], "radii": one["radii"][:2],
           sa.NULL: one[sa.NULL][:2], "thin_axis": one["thin_axis"][:2]}
    sa.shape_excess([one, dict(one), few], boot=10)
    out = capsys.readouterr().out
    assert "| 64 (2) | -0.500 (0.000) | -0.500 (0.000) |" in out
    assert "| 128 (" not in out


def test_orientation_by_hand(sa, capsys):
    """Two packings of one N whose thin axes are all e_y and long axes all (1, 1, 0)/√2, and a
    second N with thin axes e_x, long axes (1, −1, 0)/√2 (signs flipped on half of them):
    Q_yy = 2/3 (thin) and Q_xy = +1/2 / −1/2 (long), σ 0; pooled, the thin axes give
    Q_xx = Q_yy = 1/6 and the long axes Q_xy = 0; the xy-plane direction +45° and −45°; a sample
    without ``long_axis`` drops the long rows."""
    d = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    one = {"n": 64, "S": np.ones(4), "thin_axis": np.tile([0.0, 1.0, 0.0], (4, 1)),
           "long_axis": np.tile(d, (4, 1))}
    other = {"n": 128, "S": np.ones(4), "thin_axis": np.tile([1.0, 0.0, 0.0], (4, 1)),
             "long_axis": np.tile(d * [1, -1, 1], (4, 1)) * [[1], [-1], [1], [-1]]}
    sa.orientation([one, dict(one), other, dict(other)], boot=10)
    out = capsys.readouterr().out
    row = [x for x in out.splitlines() if x.startswith("| 64 | thin (8) |")][0]
    assert "| +0.667 ± 0.000 (—) |" in row and row.endswith("| +90 |")
    row = [x for x in out.splitlines() if x.startswith("| 64 | long (8) |")][0]
    assert row.split(" | ")[5] == "+0.500 ± 0.000 (—)" and row.endswith("| +45 |")
    row = [x for x in out.splitlines() if x.startswith("| 128 | long (8) |")][0]
    assert row.split(" | ")[5] == "-0.500 ± 0.000 (—)" and row.endswith("| -45 |")
    row = [x for x in out.splitlines() if x.startswith("| pooled 64, 128 | thin (16) |")][0]
    assert row.split(" | ")[2:4] == ["+0.167 ± 0.000 (—)", "+0.167 ± 0.000 (—)"]
    row = [x for x in out.splitlines() if x.startswith("| pooled 64, 128 | long (16) |")][0]
    assert abs(float(row.split(" | ")[5].split(" ± ")[0])) < 1e-12
    sa.orientation([one, {k: v for k, v in other.items() if k != "long_axis"}], boot=10)
    assert "long (" not in capsys.readouterr().out


def test_long_axes_of_a_rotated_blob(sa):
    """``long_axes`` gives row 0 of the gyration tensor's axes for each rebuilt field: a blob
    elongated along (1, 1, 1)/√3 gives that direction."""
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 6.0, (6000, 3))
    d = x - 3.0
    e = np.ones(3) / np.sqrt(3)
    along = d @ e
    across = d - along[:, None] * e
    u = np.zeros_like(x)
    u[:, 0] = np.exp(-0.125 * (along**2 / 1.0 + np.sum(across**2, axis=1) / 0.09))
    axes = sa.long_axes([(u, x, 6.0, 0.0)], 3)
    assert axes.shape == (1, 3) and abs(axes[0] @ e) > 0.999
