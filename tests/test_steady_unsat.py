"""``scripts/steady_unsat.py``: the counted sizes and the balance of a trace recomputed by hand,
the results file's round trip, a tiny run end to end, and the refusals."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from tests.script_helpers import assert_out_kept, exit_code, script_module


@pytest.fixture(scope="module")
def su():
    return script_module("steady_unsat")


def test_balance_by_hand(su):
    tr = SimpleNamespace(gamma=np.array([0.0, 0.1, 0.3]), shear_stress=np.array([2.0, 3.0, 5.0]),
                         energy=np.array([10.0, 9.0, 7.5]))
    work, given, strain = su.balance(tr)
    assert work == pytest.approx(0.1 * 2.0 + 0.2 * 3.0)
    assert given == pytest.approx(2.5) and strain == pytest.approx(0.3)


def test_counted_sizes_by_hand(su):
    # steps 1..4: plastic with a drop (counted), plastic with a rise (not), elastic drop (not),
    # plastic drop ending at an unjammed minimum (not)
    tr = SimpleNamespace(energy_jump=np.array([0.0, -2.0, 1.0, -3.0, -4.0]),
                         plastic=np.array([False, True, True, False, True]),
                         jammed=np.array([True, True, True, True, False]))
    assert su.counted_sizes(tr).tolist() == [2.0]


def test_tiny_run_end_to_end_and_round_trip(su, tmp_path, capsys):
    out = tmp_path / "r.npz"
    su.main(["--phi", "0.8", "--n", "16", "--samples", "2", "--steps", "20", "--pre-strain",
             "0.02", "--pre-dgamma", "2e-3", "--dgamma", "1e-3", "--min-tail", "2",
             "--boot", "5", "--out", str(out)])
    text = capsys.readouterr().out
    assert "| transient | 16 (2) |" in text and "| steady | 16 (2) |" in text
    results = su.load(out)
    assert [r["seed"] for r in results] == [1, 2]
    for r in results:
        for name in su.PROTOCOLS:
            assert r[name]["converged"]
            assert np.all(r[name]["sizes"] > 0)
            assert r[name]["balance"][2] == pytest.approx(20 * 1e-3)  # the strain sheared
            assert len(r[name]["order"]) == 4 and all(0 <= v <= 1 for v in r[name]["order"])
        # the quench's order, recomputed from the prepared packing
        from jamlab.analysis.order import bond_order
        from jamlab.spheres import prepare

        start = prepare(16, 3, 0.8, r["seed"]).packing
        o = bond_order(start.positions, start.box.length, start.box.strain)
        assert r["transient"]["order"][:2] == (o.crystalline_fraction, o.global_q)
    su.main(["--load", str(out), "--min-tail", "2", "--boot", "5"])
    assert capsys.readouterr().out == text  # the file reprints the same table
    # two files (here the same one twice): each table in turn; pooled they would count each
    # sample twice, which is refused; the figure of the run is a PNG
    su.main(["--load", str(out), str(out), "--min-tail", "2", "--boot", "5"])
    assert capsys.readouterr().out.count("| steady | 16 (2) |") == 2
    with pytest.raises(SystemExit) as e:
        su.main(["--load", str(out), str(out), "--pool"])
    assert e.value.code == 2
    su.main(["--load", str(out), "--load", str(out), "--pool", "--min-tail", "2", "--boot", "5"])
    assert capsys.readouterr().out.count("| steady | 16 (2) |") == 2  # one set per --load
    fig = tmp_path / "f.png"
    su.main(["--load", str(out), "--min-tail", "2", "--boot", "5", "--figure", str(fig)])
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # τ at a fixed x_min: the tail counted by hand from the file's sizes
    every = {name: np.concatenate([r[name]["sizes"] for r in results]) for name in su.PROTOCOLS}
    x_min = float(np.median(every["transient"])) if every["transient"].size else 1e-9
    su.main(["--load", str(out), "--min-tail", "2", "--boot", "5", "--x-min", str(x_min)])
    row = capsys.readouterr().out.split(f"| {x_min:.3g} | all | ")[1].split("\n")[0]
    for name, cell in zip(su.PROTOCOLS, row.split(" | "), strict=True):
        tail = int(np.count_nonzero(every[name] >= x_min))
        assert (f"], {tail}, " in cell) if tail >= 2 else cell.startswith("no data")


def test_each_size_alone(su, capsys):
    """With two N the τ tables gain one row per N, fitted on that N's sizes alone: the tails
    of the fixed window counted by hand for the pooled sizes and for each N."""
    rng = np.random.default_rng(3)

    def result(n, seed, scale):
        sizes = scale * (1.0 - rng.random(60)) ** (-1.0 / 0.4)  # Pareto, τ = 1.4, x ≥ scale
        return {"n": n, "seed": seed, "cpu": 0.0,
                **{name: {"sizes": sizes, "balance": (1.0, 1.0, 0.1), "converged": True,
                          "order": (0.0, 0.1, 0.0, 0.1)} for name in su.PROTOCOLS}}

    results = [result(64, s, 1e-6) for s in range(3)] + [result(128, s, 1e-5) for s in range(3)]
    su.table(results, boot=5, min_tail=10, x_mins=(2e-5,))
    text = capsys.readouterr().out
    for label, rs in (("all", results), ("64", results[:3]), ("128", results[3:])):
        tail = sum(int(np.count_nonzero(r["steady"]["sizes"] >= 2e-5)) for r in rs)
        row = text.split(f"| 2e-05 | {label} | ")[1].split("\n")[0]
        assert row.count(f"], {tail}, ") == 2  # both protocols (the same sizes here)
        assert f"| steady | {label} | " in text
    assert "(each fit truncated at its set's largest size)" in text
    # truncated at x_max: the tails of [2e-5, 1e-3] counted by hand
    su.table(results, boot=5, min_tail=10, x_mins=(2e-5,), x_maxs=(1e-3,))
    text = capsys.readouterr().out.split("(each fit truncated at x_max = 0.001 ε)")[1]
    for label, rs in (("all", results), ("64", results[:3]), ("128", results[3:])):
        s = np.concatenate([r["steady"]["sizes"] for r in rs])
        tail = int(np.count_nonzero((s >= 2e-5) & (s <= 1e-3)))
        row = text.split(f"| 2e-05 | {label} | ")[1].split("\n")[0]
        assert row.count(f"], {tail}, ") == 2 if tail >= 10 else row.startswith("no data")


def test_cutoff_scale_by_hand(su, capsys):
    """⟨S²⟩/⟨S⟩ per N in the balance table: two packings' sizes by hand; its σ over packing
    resamples lies within what the three possible resamples allow (log σ at most half their
    log range); with one N the value alone."""
    import math

    def result(n, seed, sizes):
        return {"n": n, "seed": seed, "cpu": 0.0,
                **{name: {"sizes": np.array(sizes), "balance": (1.0, 1.0, 0.1),
                          "converged": True, "order": (0.0, 0.1, 0.0, 0.1)}
                   for name in su.PROTOCOLS}}

    results = [result(64, 0, [1.0, 2.0]), result(64, 1, [3.0]),
               result(128, 0, [2.0, 4.0]), result(128, 1, [6.0])]
    su.table(results, boot=200, min_tail=50)
    text = capsys.readouterr().out
    for n, value in ((64, (1 + 4 + 9) / (1 + 2 + 3)), (128, (4 + 16 + 36) / (2 + 4 + 6))):
        cell = text.split(f"| steady | {n} (2) | 3 | ")[1].split(" | ")[1]
        shown, err = (float(v) for v in cell.split(" ± "))
        assert shown == pytest.approx(value, rel=1e-2)
        assert 0 < err <= value * math.log(18 / 10) / 2
    su.table(results[:2], boot=50, min_tail=50)
    cell = capsys.readouterr().out.split("| steady | 64 (2) | 3 | ")[1].split(" | ")[1]
    assert cell == f"{14 / 6:.3g}"  # one N: no resample σ


def test_cutoff_exponent_of_sizes_scaled_by_hand(su, capsys):
    """Every size of N = 256 is twice its N = 64 twin, so ⟨S²⟩/⟨S⟩ doubles over a factor 4 of
    N: β = 1/2 exactly for both protocols."""
    rng = np.random.default_rng(5)
    base = [rng.pareto(0.3, 8) + 1e-6 for _ in range(6)]

    def result(n, sizes):
        return {"n": n, "seed": int(n), "cpu": 0.0,
                **{name: {"sizes": sizes, "balance": (1.0, 1.0, 0.1), "converged": True,
                          "order": (0.0, 0.1, 0.0, 0.1)} for name in su.PROTOCOLS}}

    results = [result(64, b) for b in base] + [result(256, 2.0 * b) for b in base]
    su.table(results, boot=50, min_tail=5)
    text = capsys.readouterr().out
    for name in su.PROTOCOLS:
        assert f"{name}: ⟨S²⟩/⟨S⟩ ∝ N^β, β = 0.50 ± " in text


def test_rate_density_by_hand(su):
    """S n(S) in quarter-decade bins: counts / (N · strain · Δln S), the bins found from
    floor(4 log10 S) by hand; the other protocol and the other N left out."""
    import math

    def result(n, sizes):
        return {"n": n, "seed": 0, "cpu": 0.0,
                "steady": {"sizes": np.array(sizes), "balance": (1.0, 0.0, 0.5)},
                "transient": {"sizes": np.array([7.0]), "balance": (1.0, 0.0, 0.5)}}

    results = [result(10, [1.5e-3, 2e-3]), result(10, [2.5e-3, 5e-2]), result(20, [1e-4])]
    x, y, e = su.rate_density(results, "steady", 10, bins_per_decade=4)
    bins = sorted({math.floor(4 * math.log10(v)) for v in (1.5e-3, 2e-3, 2.5e-3, 5e-2)})
    counts = [1, 2, 1]
    assert bins == [-12, -11, -6]
    assert x == pytest.approx([10 ** ((k + 0.5) / 4) for k in bins])
    exposure = 10 * (0.5 + 0.5)
    assert y == pytest.approx([c / (exposure * math.log(10) / 4) for c in counts])
    assert e == pytest.approx([math.sqrt(c) / (exposure * math.log(10) / 4) for c in counts])
    assert all(a.size == 0 for a in su.rate_density(results, "steady", 40))


@pytest.mark.parametrize("argv", [["--phi", "0.3"], ["--samples", "0"], ["--n", "4"],
                                  ["--dgamma", "0.5"], ["--load", "/nonexistent.npz"],
                                  ["--x-min", "0"], ["--min-tail", "1"],
                                  ["--figure", "f.txt"], ["--pool"],
                                  ["--x-max", "1e-3"], ["--x-min", "1e-5", "--x-max", "0"]])
def test_bad_arguments_exit_2(su, monkeypatch, argv):
    assert exit_code(su, argv, monkeypatch) == 2


def test_existing_out_is_not_overwritten(su, tmp_path, monkeypatch):
    assert_out_kept(su, tmp_path / "r.npz", monkeypatch)


STEADY = Path(__file__).resolve().parents[1] / "data" / "steady"


def readme_rows() -> dict[str, dict[int, int]]:
    """``{file: {N: samples}}`` from the table of ``data/README.md`` on ``data/steady``: the N
    of its ``--n`` and the count of its ``--samples``."""
    text = (STEADY.parent / "README.md").read_text()
    rows = {}
    for m in re.finditer(r"^\| `steady/(\S+\.npz)` \| `([^`]*)`", text, re.M):
        argv = m.group(2).split()
        ns = [int(v) for v in argv[argv.index("--n") + 1:argv.index("--samples")]]
        rows[m.group(1)] = {n: int(argv[argv.index("--samples") + 1]) for n in ns}
    return rows


def test_committed_results_files_are_what_the_readme_says(su):
    rows = readme_rows()
    assert sorted(rows) == sorted(p.name for p in STEADY.glob("*.npz"))
    for name, counts in rows.items():
        results = su.load(STEADY / name)
        keys = [(r["n"], r["seed"]) for r in results]
        assert len(set(keys)) == len(keys), name
        assert {n: sum(1 for k in keys if k[0] == n) for n in counts} == counts, name
        assert {k[0] for k in keys} == set(counts), name
        for r in results:
            for p in su.PROTOCOLS:
                assert r[p]["converged"] and np.all(r[p]["sizes"] > 0), (name, r["seed"])
