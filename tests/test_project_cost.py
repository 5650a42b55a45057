"""``scripts/project_cost.py``: the power-law fit and the CPU-hour sum, against hand arithmetic."""

from __future__ import annotations

import json
import math

import pytest

from script_helpers import script_module


@pytest.fixture(scope="module")
def pc():
    return script_module("project_cost")


def test_power_law_recovers_an_exact_law(pc):
    a, b = pc.power_law([250, 500, 1000], [2e-6 * n**1.5 for n in (250, 500, 1000)])
    assert a == pytest.approx(2e-6, rel=1e-10) and b == pytest.approx(1.5, rel=1e-12)
    assert pc.power_law([100], [0.3]) == pytest.approx((0.003, 1.0))


def test_projection_by_hand(pc):
    # step time 1 ms × (N/250)^2, jam 2 s × N/250, to-pressure 1 s × N/250, at N = 250 and 500
    res = []
    for n in (250, 500):
        k = n / 250
        res.append({
            "N": n, "jam_s": 2.0 * k, "to_pressure_s": 1.0 * k,
            "constant_volume": {"x": {"ms_per_step": 1.0 * k**2}},
            "fixed_pressure": {"y": {"ms_per_step": 3.0 * k**2}},
        })
    rows = pc.project({"results": res, "pressure": 1e-4}, [1000, 2000], samples=10, steps=100)
    cv = next(r for r in rows if r["code"] == "x")
    fp = next(r for r in rows if r["code"] == "y")
    # N = 1000: k = 4 -> sample = 8 s + 100 × 16 ms = 9.6 s; N = 2000: k = 8 -> 16 + 6.4 = 22.4 s
    assert cv["sample_s_1000"] == pytest.approx(9.6, rel=1e-9)
    assert cv["cpu_h"] == pytest.approx(10 * (9.6 + 22.4) / 3600, rel=1e-9)
    assert cv["exponent"] == pytest.approx(2.0) and cv["extrapolated"]
    # fixed pressure: prep 3 s × k, steps 3 ms × k²: N = 1000 -> 12 + 4.8; N = 2000 -> 24 + 19.2
    assert fp["sample_s_1000"] == pytest.approx(16.8, rel=1e-9)
    assert fp["cpu_h"] == pytest.approx(10 * (16.8 + 43.2) / 3600, rel=1e-9)


def test_a_code_timed_at_some_n_only_is_fitted_over_those(pc):
    # code "x" at N = 250, 500, 1000 (1 ms × k²), code "z" at N = 250 and 500 only (2 ms × k³):
    # each law is recovered from its own sizes; z is extrapolated to 1000, x is not
    res = []
    for n in (250, 500, 1000):
        k = n / 250
        cv = {"x": {"ms_per_step": 1.0 * k**2}}
        if n < 1000:
            cv["z"] = {"ms_per_step": 2.0 * k**3}
        res.append({"N": n, "jam_s": 2.0 * k, "constant_volume": cv})
    rows = pc.project({"results": res, "pressure": 1e-4}, [1000], samples=10, steps=100)
    x = next(r for r in rows if r["code"] == "x")
    z = next(r for r in rows if r["code"] == "z")
    # N = 1000, k = 4: x 8 s + 100 × 16 ms = 9.6 s; z 8 s + 100 × 128 ms = 20.8 s
    assert x["exponent"] == pytest.approx(2.0) and not x["extrapolated"]
    assert x["sample_s_1000"] == pytest.approx(9.6, rel=1e-9)
    assert z["exponent"] == pytest.approx(3.0) and z["extrapolated"]
    assert z["sample_s_1000"] == pytest.approx(20.8, rel=1e-9)


def test_a_measured_sample_time_replaces_the_fit_at_its_n(pc):
    # the by-hand benchmark above (fixed pressure, code "jamlab"), and a whole sample of 50 s
    # measured at N = 1000: the set is 10 × (50 + the fit's 43.2 s at N = 2000)
    res = []
    for n in (250, 500):
        k = n / 250
        res.append({"N": n, "jam_s": 2.0 * k, "to_pressure_s": 1.0 * k,
                    "fixed_pressure": {"jamlab": {"ms_per_step": 3.0 * k**2},
                                       "other": {"ms_per_step": 3.0 * k**2}}})
    rows = pc.project({"results": res, "pressure": 1e-4}, [1000, 2000], samples=10, steps=100,
                      measured={"fixed_pressure": {1000: 50.0}})
    mine = next(r for r in rows if r["code"] == "jamlab")
    other = next(r for r in rows if r["code"] == "other")
    assert mine["sample_s_1000"] == 50.0 and mine["measured_n"] == [1000]
    assert mine["cpu_h"] == pytest.approx(10 * (50.0 + 43.2) / 3600, rel=1e-9)
    # only the default path is replaced
    assert other["sample_s_1000"] == pytest.approx(16.8, rel=1e-9) and other["measured_n"] == []


def test_measured_samples_come_from_the_run_directory(pc, tmp_path):
    # (their CPU time: every sample stored one)
    from jamlab.runs import Execution, RunDir, Study, read_sample, run_study

    study = Study(phi=["jamming"], n=[16], samples=2, dgamma=1e-3, gamma_max=3e-3, seed=4,
                  pressure=1e-3)
    run_study(study, tmp_path / "r", Execution(workers=0))
    rd = RunDir(tmp_path / "r")
    stored = [float(read_sample(rd.sample_path(k))["attrs"]["cpu_seconds"]) for k in study.keys()
              if rd.state(k) == "done"]
    assert stored
    bench = {"pressure": 1e-3, "dgamma": 1e-3}
    got = pc.measured_samples([tmp_path / "r"], bench, steps=3)
    assert got == {"fixed_pressure": {16: pytest.approx(sum(stored) / len(stored), rel=1e-12)}}
    # a run of another p, δγ or number of steps is refused with exit code 2
    for other, steps in (({"pressure": 1e-4, "dgamma": 1e-3}, 3),
                         ({"pressure": 1e-3, "dgamma": 1e-4}, 3), (bench, 1000)):
        with pytest.raises(SystemExit) as err:
            pc.measured_samples([tmp_path / "r"], other, steps=steps)
        assert err.value.code == 2
    with pytest.raises(SystemExit) as err:
        pc.measured_samples([tmp_path / "missing"], bench, steps=3)
    assert err.value.code == 2


def test_measured_steps_replace_the_fitted_step_time(pc, tmp_path):
    # bench_pressure.py --json: N = 2000 measured on two packings at 0.5 and 0.7 s per step
    cases = [{"N": 2000, "pressure": 1e-4, "seed": s, "steps": 100, "dgamma": 1e-5,
              "variants": {"newton": {"cpu_s": 100 * t, "ms_per_step": 1e3 * t, "plastic": 3}}}
             for s, t in ((1, 0.5), (2, 0.7))]
    f = tmp_path / "b.json"
    f.write_text(json.dumps({"cases": cases}))
    bench = {"pressure": 1e-4, "dgamma": 1e-5}
    stepped = pc.measured_steps([f], bench)
    assert stepped == {2000: pytest.approx(0.6, rel=1e-12)}
    res = []
    for n in (250, 500):
        k = n / 250
        res.append({"N": n, "jam_s": 2.0 * k, "to_pressure_s": 1.0 * k,
                    "fixed_pressure": {"jamlab": {"ms_per_step": 3.0 * k**2}}})
    rows = pc.project({"results": res, **bench}, [1000, 2000], samples=10, steps=100,
                      measured_step=stepped)
    # N = 1000 from the fit (16.8 s); N = 2000: fitted preparation 24 s + 100 × 0.6 s
    assert rows[0]["cpu_h"] == pytest.approx(10 * (16.8 + 24.0 + 60.0) / 3600, rel=1e-9)
    assert rows[0]["measured_step_n"] == [2000]
    with pytest.raises(SystemExit) as err:
        pc.measured_steps([f], {"pressure": 1e-3, "dgamma": 1e-5})
    assert err.value.code == 2


def test_fit_runs_extrapolates_from_the_measured_samples(pc):
    # the benchmark says one thing (constant volume, 1 ms × k² per step), the whole samples
    # measured at N = 500 and 1000 another (40 s and 160 s: t = 40 (N/500)²); with fit_runs
    # N = 2000 is 640 s, without it the benchmark's fit: 16 s + 100 × 64 ms = 22.4 s
    res = []
    for n in (250, 500):
        k = n / 250
        res.append({"N": n, "jam_s": 2.0 * k,
                    "constant_volume": {"jamlab": {"ms_per_step": 1.0 * k**2}}})
    data = {"results": res, "pressure": 1e-4}
    measured = {"constant_volume": {500: 40.0, 1000: 160.0}}
    fitted = next(r for r in pc.project(data, [500, 1000, 2000], 10, 100, measured,
                                        fit_runs=True) if r["code"] == "jamlab")
    assert fitted["fitted_to_runs"] and fitted["exponent"] == pytest.approx(2.0)
    assert fitted["cpu_h"] == pytest.approx(10 * (40 + 160 + 640) / 3600, rel=1e-9)
    assert fitted["extrapolated"]  # N = 2000 is beyond the measured samples
    plain = next(r for r in pc.project(data, [500, 1000, 2000], 10, 100, measured)
                 if r["code"] == "jamlab")
    assert not plain["fitted_to_runs"]
    assert plain["cpu_h"] == pytest.approx(10 * (40 + 160 + 22.4) / 3600, rel=1e-9)
    # one measured N is not a law: the benchmark's fit stays
    one = next(r for r in pc.project(data, [1000, 2000], 10, 100,
                                     {"constant_volume": {1000: 160.0}}, fit_runs=True)
               if r["code"] == "jamlab")
    assert not one["fitted_to_runs"]
    assert one["cpu_h"] == pytest.approx(10 * (160 + 22.4) / 3600, rel=1e-9)


def test_cv_samples_means_and_their_stopped_ones(pc, tmp_path, capsys):
    # whole samples of bench_cv_sample.py: the mean per N of jam + shear CPU s; a sample stopped
    # at its budget is counted with its time and marks that N
    def sample(n, seed, jam, shear, done):
        return {"N": n, "seed": seed, "floppy": "project", "steps": 100, "steps_done": done,
                "dgamma": 1e-5, "jam_cpu_s": jam, "shear_cpu_s": shear}

    path = tmp_path / "cv.json"
    path.write_text(json.dumps({"samples": [
        sample(2000, 1, 10.0, 90.0, 100), sample(2000, 2, 20.0, 280.0, 60),
        sample(4000, 1, 40.0, 760.0, 100),
    ]}))
    means, stopped = pc.measured_cv_samples([path], {"dgamma": 1e-5}, steps=100)
    assert means == {2000: pytest.approx(200.0), 4000: pytest.approx(800.0)}
    assert stopped == {2000}
    assert "stopped after 60 steps" in capsys.readouterr().out
    with pytest.raises(SystemExit):  # another δγ than the benchmark's
        pc.measured_cv_samples([path], {"dgamma": 1e-4}, steps=100)
    with pytest.raises(SystemExit):  # another number of steps than the projection's
        pc.measured_cv_samples([path], {"dgamma": 1e-5}, steps=1000)


def test_projection_from_whole_samples_alone_by_hand(pc):
    # no benchmark: samples measured at N = 500 and 1000 (40 s, 160 s: t = 40 (N/500)²), so
    # N = 2000 costs 640 s; a measured N keeps its own mean
    rows = pc.project_measured({"fixed_pressure": {500: 40.0, 1000: 160.0}}, [1000, 2000], 10)
    assert len(rows) == 1
    r = rows[0]
    assert r["exponent"] == pytest.approx(2.0, rel=1e-12)
    assert r["cpu_h"] == pytest.approx(10 * (160 + 640) / 3600, rel=1e-12)
    assert r["sample_s_1000"] == 160.0 and r["measured_n"] == [1000]
    assert r["extrapolated"] and r["fitted_to_runs"]
    # one N is not a law: refused with exit code 2
    with pytest.raises(SystemExit) as err:
        pc.project_measured({"fixed_pressure": {1000: 160.0}}, [2000], 10)
    assert err.value.code == 2


def test_main_projects_from_runs_alone(pc, tmp_path, capsys):
    from jamlab.runs import Execution, RunDir, Study, read_sample, run_study

    study = Study(phi=["jamming"], n=[16, 24], samples=2, dgamma=1e-3, gamma_max=3e-3, seed=5,
                  pressure=1e-3)
    run_study(study, tmp_path / "r", Execution(workers=0))
    rd = RunDir(tmp_path / "r")
    per_n: dict[int, list[float]] = {}
    for k in study.keys():
        if rd.state(k) == "done":
            per_n.setdefault(k.n, []).append(
                float(read_sample(rd.sample_path(k))["attrs"]["cpu_seconds"]))
    assert sorted(per_n) == [16, 24]
    t16, t24 = (sum(v) / len(v) for v in (per_n[16], per_n[24]))
    # by hand: t = t16 (N/16)^b with b = ln(t24/t16) / ln 1.5; 3 samples at N = 32
    b = math.log(t24 / t16) / math.log(1.5)
    t32 = t16 * 2**b
    pc.main(["--runs", str(tmp_path / "r"), "--sizes", "32", "--samples", "3", "--steps", "3"])
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| fixed pressure"))
    cells = [c.strip() for c in row.split("|")]
    assert cells[3] == f"b = {b:.2f}"
    assert cells[6].startswith(f"{3 * t32 / 3600:,.0f}")
    assert cells[7] == "—" and "this set" in out and "p = 0.001" in out
    # refusals, exit code 2: nothing to project, runs of one N only, another number of steps,
    # inputs that need a benchmark, a file that is not a benchmark
    one = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=5,
                pressure=1e-3)
    run_study(one, tmp_path / "one", Execution(workers=0))
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    for argv in ([], ["--runs", str(tmp_path / "one"), "--steps", "3"],
                 ["--runs", str(tmp_path / "r")],
                 ["--runs", str(tmp_path / "r"), "--steps", "3", "--average"],
                 ["--runs", str(tmp_path / "missing")], [str(bad)],
                 ["--runs", str(tmp_path / "r"), "--steps", "3", "--samples", "0"]):
        with pytest.raises(SystemExit) as err:
            pc.main(argv)
        assert err.value.code == 2, argv


def test_runs_alone_must_share_one_protocol(pc, tmp_path):
    from jamlab.runs import Execution, Study, run_study

    for name, pressure in (("p", 1e-3), ("v", None)):
        run_study(Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=5,
                        pressure=pressure), tmp_path / name, Execution(workers=0))
    assert pc.run_conditions([tmp_path / "p"])["pressure"] == pytest.approx(1e-3)
    assert pc.run_conditions([tmp_path / "v"])["pressure"] is None
    with pytest.raises(SystemExit) as err:
        pc.run_conditions([tmp_path / "p", tmp_path / "v"])
    assert err.value.code == 2
