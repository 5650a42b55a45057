"""`reproduce` end to end at the `tiny` scale: files, figures, and every table number recomputed
here from the stored runs (h5py and numpy, or jamlab.analysis), not copied from the pipeline."""

import glob
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from jamlab.analysis import fit_power_law
from jamlab.reproduce import SCALES, reproduce
from jamlab.runs import Execution
from jamlab.theory import exact_jump_R, one_level_R
from test_report import parse_html  # noqa: E402  (tests/ is on sys.path via rootdir conftest)

pytestmark = pytest.mark.slow  # one tiny reproduction, ~20-40 s on one core

SCALE = SCALES["tiny"]
FIGURES = ("fig1", "fig2", "fig3", "fig3_exact", "fig4", "fig5", "fig6", "fig7",
           "theory_vs_cascade", "criticality")  # finite_size: needs two N (tiny has one)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny") / "report"
    result = reproduce("tiny", out, execution=Execution(workers=0))
    data = json.loads((out / "results.json").read_text())
    rows = {r["quantity"]: r for r in data["rows"]}
    return out, result, data, rows


def _traces(run_dir: Path, phi: str, n: int) -> list[dict]:
    """Every finished sample's trace and attributes, read with h5py."""
    out = []
    for f in sorted(glob.glob(str(run_dir / "samples" / f"phi={phi}" / f"N={n}" / "*.h5"))):
        with h5py.File(f, "r") as h5:
            if not h5.attrs.get("complete", False):
                continue
            out.append({"trace": {k: h5["trace"][k][()] for k in h5["trace"]},
                        "attrs": dict(h5.attrs)})
    return out


def _sizes(run_dir: Path, phi: str, ns) -> tuple[np.ndarray, int]:
    sizes, samples = [], 0
    for n in ns:
        for s in _traces(run_dir, phi, n):
            t = s["trace"]
            de, pl = t["energy_jump"][1:], t["plastic"][1:].astype(bool)
            # issue 18: a step counts only between two jammed minima (the trace's jammed column)
            jm = t["jammed"].astype(bool)
            sizes.append(-de[pl & (de < 0) & jm[:-1] & jm[1:]])
            samples += 1
    return np.concatenate(sizes), samples


def _excluded(run_dir: Path, phi: str, ns) -> tuple[int, int, int]:
    """(steps, steps excluded as unjammed, avalanches excluded), counted here with numpy."""
    steps = x_steps = x_av = 0
    for n in ns:
        for s in _traces(run_dir, phi, n):
            t = s["trace"]
            de, pl = t["energy_jump"][1:], t["plastic"][1:].astype(bool)
            jm = t["jammed"].astype(bool)
            ok = jm[:-1] & jm[1:]
            steps += de.size
            x_steps += int((~ok).sum())
            x_av += int((pl & (de < 0) & ~ok).sum())
    return steps, x_steps, x_av


def _row(rows, start):
    hits = [r for q, r in rows.items() if q.startswith(start)]
    assert len(hits) == 1, (start, list(rows))
    return hits[0]


def test_files_and_figures(tiny):
    out, result, data, _ = tiny
    for name in ("index.html", "report.md", "results.json"):
        assert (out / name).is_file()
    keys = [f["key"] for f in data["figures"]]
    assert keys == list(FIGURES)
    for f in data["figures"]:
        png = out / f["path"]
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f["caption"]


def test_the_header_says_where_the_samples_ran(tiny):
    out, _, data, _ = tiny
    files = sorted(glob.glob(str(out / "runs" / "*" / "samples" / "*" / "*" / "sample-*.h5")))
    machines = set()
    for f in files:  # every sample's record, read here with h5py and json
        with h5py.File(f, "r") as h5:
            records = json.loads(h5.attrs["provenance"])
        assert [r["resumed_from"] for r in records] == [-1]
        machines.add((records[0]["cpu"], records[0]["llvm_cpu"], records[0]["numpy"]))
    assert len(machines) == 1 and files
    line = data["parameters"]["machines"]
    assert "machines: 1 recorded" in line and f"machine 1, {len(files)} samples:" in line
    cpu, llvm_cpu, numpy_version = machines.pop()
    assert f"{cpu} ({llvm_cpu};" in line and f"numpy {numpy_version}" in line
    assert "more than one machine" not in line and "record no machine" not in line
    assert "machines: " in (out / "report.md").read_text()


def test_html_is_well_formed_and_links_existing_images(tiny):
    out, _, data, rows = tiny
    p = parse_html((out / "index.html").read_text())
    assert p.errors == [] and p.stack == []
    assert sorted(p.images) == sorted(f["path"] for f in data["figures"])
    assert all((out / src).is_file() for src in p.images)
    table = [c for c in p.cells if c and c[0] != "quantity"]
    assert [c[0] for c in table] == list(rows)
    md = (out / "report.md").read_text()
    for r in rows.values():
        assert r["value_text"].replace("|", "\\|") in md


def test_tau_rows_recomputed_from_the_runs(tiny):
    out, _, _, rows = tiny
    for phi, title, ns, run in (("jamming", "τ at jamming", SCALE.jamming_n, "jamming"),
                                ("0.75", "τ at φ = 0.75", SCALE.unsat_n, "unsat"),
                                ("0.8", "τ at φ = 0.80", SCALE.unsat_n, "unsat")):
        sizes, samples = _sizes(out / "runs" / run, phi, ns)
        row = _row(rows, title)
        assert f"{samples} samples" in row["samples"]
        assert f"{sizes.size} avalanches" in row["samples"]
        steps, x_steps, x_av = _excluded(out / "runs" / run, phi, ns)
        assert (f"excluded as unjammed: {x_steps} of {steps} steps, {x_av} of "
                f"{sizes.size + x_av} avalanches") in row["samples"]
        if phi == "jamming":
            assert "constant volume" in row["quantity"] and "p of all minima sampled" in \
                row["samples"]
        if sizes.size < SCALE.min_tail:
            assert row["value"] is None and row["value_text"] == "n/a"
            assert all("no data" in v for v in row["verdicts"])
            continue
        fit = fit_power_law(sizes, x_max=float(sizes.max()), min_tail=SCALE.min_tail,
                            n_boot=SCALE.n_boot, seed=SCALE.seed)
        assert row["value"] == pytest.approx(fit.tau, rel=1e-12)
        assert row["error"] == pytest.approx((fit.ci_high - fit.ci_low) / (2 * 1.959964),
                                             rel=1e-5)
        theory = 1.412693 if phi == "jamming" else 1.0
        k = abs(fit.tau - theory) / row["error"]
        word = "differs" if k > 2 else ("inconclusive" if 2 * row["error"] >= theory else "agrees")
        assert any(v.startswith("theory: " + word) for v in row["verdicts"])


def test_no_cutoff_row_at_a_scale_without_pressures(tiny):
    # the constant-volume τ's cut-off row belongs to the scales with fixed-pressure ensembles
    # (medium, paper); tiny and quick do not pay its bootstrap (tested in
    # test_reproduce_pressure.py)
    _, _, data, rows = tiny
    assert not SCALE.pressures
    assert not [q for q in rows if q.startswith("τ with an exponential cut-off")]
    assert "tau_jamming_cutoff" not in data["data"]
    # the same runs read as a scale with pressures: the constant-volume estimate gets the fit
    from dataclasses import replace

    from jamlab.reproduce.ensembles import RunSet
    from jamlab.reproduce.measurements import tau_estimates

    runs = RunSet(out_dir := tiny[0] / "runs")
    assert out_dir.is_dir()
    with_p = replace(SCALE, pressures=(1e-3,), pressure_n=SCALE.jamming_n, pressure_samples=1,
                     pressure_gamma_max=10 * SCALE.dgamma)
    est = tau_estimates(runs["jamming"], runs["unsat"], with_p)
    assert est["jamming"].cutoff_made and not est["0.75"].cutoff_made
    assert not tau_estimates(runs["jamming"], runs["unsat"], SCALE)["jamming"].cutoff_made


def test_phi_j_row_recomputed(tiny):
    out, _, _, rows = tiny
    phis = [s["attrs"]["phi_actual"] for n in SCALE.jamming_n
            for s in _traces(out / "runs" / "jamming", "jamming", n)]
    row = _row(rows, "φ_J")
    assert row["value"] == pytest.approx(np.mean(phis), rel=1e-12)
    assert row["error"] == pytest.approx(np.std(phis, ddof=1) / math.sqrt(len(phis)), rel=1e-9)
    assert 0.55 < row["value"] < 0.70  # a jammed monodisperse 3D packing, any N


@pytest.mark.parametrize("phi,run,ns,title", [
    ("jamming", "jamming", SCALE.jamming_n, "at jamming"),
    ("0.75", "unsat", SCALE.unsat_n, "at φ = 0.75"),
])
def test_moduli_slope_recomputed_with_numpy(tiny, phi, run, ns, title):
    out, _, _, rows = tiny
    n = max(ns)
    samples = _traces(out / "runs" / run, phi, n)
    stress = np.array([s["trace"]["shear_stress"] / s["attrs"]["box_length"] ** 3
                       for s in samples])
    jammed = np.array([s["trace"]["jammed"] for s in samples]) > 0.5
    lags = [m for m in SCALE.moduli_lags if m <= SCALE.moduli_fit_max_lag]

    def per_sample(m, power):
        # differences across an unjammed minimum are left out; so is a sample with none left
        out = []
        for st, jm in zip(stress, jammed, strict=True):
            d = [(st[k + m] - st[k]) / (m * SCALE.dgamma) for k in range(st.size - m)
                 if jm[k : k + m + 1].all()]
            if d:
                out.append(np.mean(np.power(d, power)))
        return np.array(out)

    x, y, e = [], [], []
    for m in lags:
        per = per_sample(m, 2)
        x.append(m * SCALE.dgamma)
        y.append(per.mean())
        e.append(per.std(ddof=1) / math.sqrt(per.size))
    x, y, e = map(np.array, (x, y, e))
    slope = np.polyfit(np.log(x), np.log(y), 1, w=y / e)[0]
    row = _row(rows, f"slope of log⟨μ_1²⟩ vs log δγ, {title}")
    assert row["value"] == pytest.approx(slope, rel=1e-8, abs=1e-10)
    mu1 = per_sample(1, 1).mean()
    mu_row = _row(rows, f"⟨μ_1⟩ at the smallest and largest δγ, {title}")
    assert mu_row["value"] == pytest.approx(mu1, rel=1e-10)

    def within(m):
        # each sample's variance of its kept differences about their mean, divided by
        # K − Σ_k w_k²/(m K) (w_k: kept differences holding fine step k; docs/analysis.md §4)
        out = []
        for st, jm in zip(stress, jammed, strict=True):
            kept = [k for k in range(st.size - m) if jm[k : k + m + 1].all()]
            if len(kept) < 2:
                continue
            d = np.array([(st[k + m] - st[k]) / (m * SCALE.dgamma) for k in kept])
            w = [sum(1 for k in kept if k <= j < k + m) for j in range(st.size - 1)]
            dof = len(kept) - sum(v * v for v in w) / (m * len(kept))
            out.append(((d - d.mean()) ** 2).sum() / dof)
        return np.array(out)

    v = [within(m) for m in lags]
    y = np.array([a.mean() for a in v])
    e = np.array([a.std(ddof=1) / math.sqrt(a.size) for a in v])
    slope = np.polyfit(np.log(x), np.log(y), 1, w=y / e)[0]
    row = _row(rows, f"slope of the within-sample variance of μ_1 vs log δγ, {title}")
    assert row["value"] == pytest.approx(slope, rel=1e-8, abs=1e-10)


def test_coordination_rows_recomputed(tiny):
    out, _, _, rows = tiny
    files = sorted((out / "data").glob("coordination_*.npz"))
    assert len(files) == SCALE.coord_samples
    expected = {}
    for f in files:
        with np.load(f) as z:
            for name, y in (("z", z["z_nr"] - z["z_iso"]), ("p", z["pressure"])):
                sel = (z["dphi"] >= 1e-4) & (z["dphi"] <= 1e-1) & (y > 0)
                expected.setdefault(name, []).append(
                    np.polyfit(np.log(z["dphi"][sel]), np.log(y[sel]), 1)[0])
    assert _row(rows, "exponent of z_nr")["value"] == pytest.approx(np.mean(expected["z"]))
    assert _row(rows, "exponent of p")["value"] == pytest.approx(np.mean(expected["p"]))


def test_theory_rows(tiny):
    _, _, data, rows = tiny
    k1 = _row(rows, "k = 1 no-jump")
    # SPEC §1: exact 0.744, the paper's chi 0.629
    assert data["data"]["theory"]["k1_exact"] == pytest.approx(0.744, abs=5e-4)
    assert data["data"]["theory"]["k1_chi"] == pytest.approx(0.629, abs=5e-4)
    assert data["data"]["theory"]["k1_exact"] == pytest.approx(one_level_R(0.0, 1.0, 0.5))
    assert abs(k1["value"] - 0.744) < 5 * k1["error"]  # sampled, 5 sigma
    check = _row(rows, "P(no jump) at δγ = 0.3, y = 2.5q")
    from jamlab.theory import ParisiFunction

    q, y = ParisiFunction.linear(2.5, 0.0, 0.9).discretise(SCALE.cascade_k)
    exact = float(exact_jump_R(q, y, 0.3, 0.0)[0])
    assert f"{exact:.4f}" in check["reference_text"]
    assert abs(check["value"] - exact) < 5 * check["error"]
    tau = _row(rows, "τ_J = (3+θ)/(2+θ)")  # (the criticality rows "τ_J predicted by …" follow)
    assert tau["value"] == pytest.approx((3 + 0.42311) / (2 + 0.42311), rel=1e-12)


def test_criticality_and_finite_size_rows(tiny):
    out, _, data, rows = tiny
    packings = len(_traces(out / "runs" / "jamming", "jamming", SCALE.jamming_n[0]))
    crit = data["data"]["criticality"]
    assert crit["packings"] == {str(SCALE.jamming_n[0]): packings}
    assert crit["counts"]["packings"] == packings
    # N = 32, 3 packings: too few values in any window; every exponent says so, no verdict
    for start in ("θ_e,", "θ_l,", "γ,"):
        row = _row(rows, start)
        assert row["value_text"].startswith("n/a (") and row["verdicts"] == ["SPEC §6: no data"]
    for start in ("τ_J predicted by 1 + γ", "τ_J predicted by (3"):
        assert all(v.endswith("no data") for v in _row(rows, start)["verdicts"])
    for title in ("at jamming", "at φ = 0.75", "at φ = 0.80"):
        row = _row(rows, f"β of the avalanche cut-off S_c = ⟨S²⟩/⟨S⟩ ~ N^β, τ {title}")
        assert row["value_text"].startswith("n/a (need avalanches at two sizes")


def test_per_sample_sizes_recounted_from_the_files(tiny):
    """The finite-size input: each sample's avalanches (plastic, ΔE < 0, between jammed minima),
    recounted here with numpy from the sample files."""
    from jamlab.reproduce.ensembles import avalanche_set
    from jamlab.runs import open_run

    out = tiny[0]
    for run, phi, n in (("jamming", "jamming", SCALE.jamming_n[0]),
                        ("unsat", "0.8", SCALE.unsat_n[0])):
        got = avalanche_set(open_run(out / "runs" / run), phi, n).per_sample
        want = []
        for smp in _traces(out / "runs" / run, phi, n):
            t = smp["trace"]
            de, pl = t["energy_jump"][1:], t["plastic"][1:].astype(bool)
            jm = t["jammed"].astype(bool)
            want.append(-de[pl & (de < 0) & jm[:-1] & jm[1:]])
        assert len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)


def test_fig4_trace_recounted_from_its_sample_file(tiny):
    """Fig. 4's sample: its pressures, jammed flags and which flagged steps are counted
    (plastic, ΔE < 0, both minima jammed), recounted here with numpy from the first finished
    sample file of the largest N."""
    from jamlab.reproduce.measurements import one_trace
    from jamlab.runs import open_run

    out = tiny[0]
    n = max(SCALE.jamming_n)
    t = one_trace(open_run(out / "runs" / "jamming"), SCALE)
    want = _traces(out / "runs" / "jamming", "jamming", n)[0]["trace"]
    de, pl = want["energy_jump"], want["plastic"].astype(bool)
    jm = want["jammed"].astype(bool)
    counted = np.zeros(de.size, dtype=bool)
    counted[1:] = pl[1:] & (de[1:] < 0) & jm[:-1] & jm[1:]
    np.testing.assert_array_equal(t.pressure, want["pressure"])
    np.testing.assert_array_equal(t.jammed, jm)
    np.testing.assert_array_equal(t.counted, counted)
    np.testing.assert_array_equal(t.plastic, pl)
    assert not np.any(t.counted & ~t.plastic)


def test_the_same_command_again_computes_no_sample(tiny, tmp_path):
    """The first call computed every sample; ``jamlab reproduce`` run again on that report (a
    copy of it: the other tests read this one) reuses every sample and the stored exact law, says
    so, and writes the same table and figures. (It was two more tiny reproductions in
    tests/cli/test_cli_reproduce.py.)"""
    import shutil

    from cli_helpers import jamlab

    out, result, data, _ = tiny
    runs = result.data["runs"]
    assert all(r["done"] == r["total"] > 0 for r in runs.values()), runs
    again = tmp_path / "report"
    shutil.copytree(out, again, symlinks=True)
    r = jamlab("reproduce", "--scale", "tiny", "--out", again, "--workers", 0)
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and "index.html" in r.stdout
    for name, total in (("jamming", 3), ("unsat", 6), ("stress-strain", 3)):
        assert runs[name]["total"] == total
        assert f"{name}: 0 computed, {total} reused, 0 failed" in r.stderr, r.stderr
    # nor is the exact law rebuilt: read from the report's data (the same code stored it)
    assert f"exact law: read from {again / 'data'}" in r.stderr, r.stderr
    rows = json.loads((again / "results.json").read_text())["rows"]
    assert [row["value"] for row in rows] == [row["value"] for row in data["rows"]]
    assert all((again / f["path"]).is_file() for f in data["figures"])
    fig = next(f["path"] for f in data["figures"] if "fig3_exact" in f["path"])
    assert (again / fig).read_bytes() == (out / fig).read_bytes()  # drawn from the stored law


def test_runs_elsewhere_are_reused(tiny, tmp_path):
    """``--runs`` pointing at another report's runs: nothing is computed (in-process, no
    reproduction of its own beyond the analysis)."""
    out, result, _, _ = tiny
    again = reproduce("tiny", tmp_path / "r2", runs=out / "runs", execution=Execution(workers=0))
    assert all(r["done"] == 0 and r["skipped"] == r["total"] for r in again.data["runs"].values())
    assert [r.value_text for r in again.rows][:4] == [r.value_text for r in result.rows][:4]


def test_unknown_scale_and_unwritable_out(tmp_path):
    with pytest.raises(ValueError, match="unknown scale 'huge'"):
        reproduce("huge", tmp_path / "x")
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="cannot create output directory"):
        reproduce("tiny", tmp_path / "file" / "sub")


def test_order_rows_recomputed_from_the_sample_files(tiny):
    """The bond-order section: each prepared packing's crystalline fraction from the positions
    in its file (first shell, 1.3 σ_ij), the ordered counts, and τ of the amorphous samples'
    avalanches counted here with numpy."""
    from jamlab.analysis.order import bond_order

    out, _, data, rows = tiny
    for run, phi, ns, title in (("jamming", "jamming", SCALE.jamming_n, "τ at jamming"),
                                ("unsat", "0.75", SCALE.unsat_n, "τ at φ = 0.75"),
                                ("unsat", "0.8", SCALE.unsat_n, "τ at φ = 0.80"),
                                ("stress-strain", "0.75", (SCALE.stress_n,), None)):
        fractions, sizes = [], []
        for n in ns:
            files = sorted(glob.glob(str(out / "runs" / run / "samples" / f"phi={phi}" /
                                         f"N={n}" / "*.h5")))
            for f, smp in zip(files, _traces(out / "runs" / run, phi, n), strict=True):
                with h5py.File(f, "r") as h5:
                    pos, length = h5["packing/positions"][()], float(h5.attrs["box_length"])
                frac = bond_order(pos, length, 0.0, cutoff=1.3).crystalline_fraction
                fractions.append(frac)
                t = smp["trace"]
                de, pl = t["energy_jump"][1:], t["plastic"][1:].astype(bool)
                jm = t["jammed"].astype(bool)
                if frac <= 0.05:
                    sizes.append(-de[pl & (de < 0) & jm[:-1] & jm[1:]])
        stored = data["data"]["order"][f"{run}:{phi}"]
        got = [x for n in ns for x in stored["crystalline_fraction"][str(n)]]
        np.testing.assert_allclose(got, fractions, rtol=0, atol=1e-12)
        ordered = int(np.sum(np.array(fractions) > 0.05))
        count = _row(rows, f"ordered prepared packings, {run} run, φ = {phi} ")
        assert count["value_text"] == f"{ordered} of {len(fractions)}"
        if title is None:
            assert stored["tau_amorphous"] is None
            continue
        row = _row(rows, f"amorphous prepared packings only: {title}")
        s = np.concatenate(sizes) if sizes else np.empty(0)
        assert row["samples"] == (f"{len(sizes)} of {len(fractions)} samples, "
                                  f"{s.size} avalanches")
        if s.size < SCALE.min_tail:
            assert row["value"] is None and row["value_text"] == "n/a"
            continue
        fit = fit_power_law(s, x_max=float(s.max()), min_tail=SCALE.min_tail,
                            n_boot=SCALE.n_boot, seed=SCALE.seed)
        assert row["value"] == pytest.approx(fit.tau, rel=1e-12)
