"""The real sample (prepare + AQS shear) through the run machinery, at tiny N."""

import numpy as np
import pytest

from jamlab.runs import Execution, RunDir, Study, read_sample, run_study, sample_seed

packing = pytest.importorskip("jamlab.spheres.packing")
aqs = pytest.importorskip("jamlab.spheres.aqs")
if not (hasattr(packing, "jam") and hasattr(packing, "prepare")):
    pytest.skip("jamlab.spheres.packing.jam/prepare not available yet", allow_module_level=True)

STUDY = Study(phi=["jamming", 0.8], n=[16], samples=2, dgamma=1e-3, gamma_max=3e-3, seed=1)


@pytest.mark.slow
def test_aqs_samples_equal_a_direct_computation_whatever_the_workers(tmp_path, same_runs):
    run_study(STUDY, tmp_path / "w0", Execution(workers=0))
    run_study(STUDY, tmp_path / "w2", Execution(workers=2))
    same_runs(tmp_path / "w0", tmp_path / "w2")
    rd = RunDir(tmp_path / "w0")
    for key in STUDY.keys():
        seed = sample_seed(STUDY.seed, key)
        if key.phi == "jamming":
            prepared = packing.jam(key.n, STUDY.dim, seed, p_target=STUDY.p_target)
        else:
            prepared = packing.prepare(key.n, STUDY.dim, key.phi, seed)
        if rd.state(key) == "failed":  # recorded failures are real ones
            assert not prepared.ok, rd.read_failure(key)
            continue
        assert prepared.ok
        stored = read_sample(rd.sample_path(key))
        assert stored["attrs"]["seed"] == str(seed)
        config = prepared.packing
        trace = aqs.shear(config, STUDY.dgamma, STUDY.gamma_max).trace
        np.testing.assert_array_equal(stored["packing"]["positions"], config.positions)
        for name in ("gamma", "energy", "shear_stress", "plastic", "energy_jump"):
            np.testing.assert_array_equal(stored["trace"][name], getattr(trace, name))
        assert stored["attrs"]["phi_actual"] == config.phi


def test_study_pressure_field_and_a_fixed_pressure_sample(tmp_path):
    base = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=4)
    assert base.pressure is None and "pressure" not in base.to_dict()  # earlier runs unchanged
    study = Study(**{**base.to_dict(), "pressure": "1e-3"})
    assert study.pressure == 1e-3 and Study.from_dict(study.to_dict()) == study
    for bad in (-1.0, 0.0, float("nan"), "x", True):
        with pytest.raises(ValueError, match="pressure"):
            Study(**{**base.to_dict(), "pressure": bad})
    run_study(study, tmp_path / "r", Execution(workers=0))
    rd = RunDir(tmp_path / "r")
    key = study.keys()[0]
    assert rd.state(key) == "done", rd.read_failure(key)
    sample = read_sample(rd.sample_path(key))
    stored = sample["trace"]
    seed = sample_seed(study.seed, key)
    config = packing.jam(16, 3, seed, p_target=study.p_target).packing
    direct = aqs.shear(config, 1e-3, 3e-3, pressure=1e-3).trace
    for name in ("gamma", "energy", "pressure", "jammed", "phi", "plastic"):
        np.testing.assert_array_equal(stored[name], getattr(direct, name))
    # the run's own counters travel with the sample (saddles pushed off, the relaxer's work...)
    counters = {k: v for k, v in direct.attrs.items() if k.startswith("n_")}
    assert {"n_saddles_left", "n_unjammed", "n_fire_fallbacks", "n_newton_calls"} <= set(counters)
    assert counters["n_newton_calls"] > 0
    for name, value in counters.items():
        assert sample["attrs"][f"shear_{name}"] == value, name
    assert sample["attrs"]["shear_plastic_threshold"] == direct.attrs["plastic_threshold"]
    assert np.all(np.abs(stored["pressure"] - 1e-3) <= 1e-9)
    from jamlab.runs import open_run

    ds = open_run(tmp_path / "r")
    assert "jammed" in ds and "phi_step" in ds
    np.testing.assert_array_equal(ds.jammed.values[0, 0, 0], direct.jammed.astype(float))


def test_a_projected_sample_records_its_protocol(tmp_path):
    # floppy="project" reaches the shear, and the sample file says so (with the counters); a
    # FIRE sample of the same study keeps its earlier attributes
    base = dict(phi=["jamming"], n=[32], samples=1, dgamma=1e-3, gamma_max=1e-2, seed=4)
    for floppy in ("project", "fire"):
        study = Study(**base, floppy=floppy)
        run_study(study, tmp_path / floppy, Execution(workers=0))
        rd = RunDir(tmp_path / floppy)
        key = study.keys()[0]
        assert rd.state(key) == "done", rd.read_failure(key)
        stored = read_sample(rd.sample_path(key))
        config = packing.jam(32, 3, sample_seed(study.seed, key), p_target=study.p_target).packing
        direct = aqs.shear(config, 1e-3, 1e-2, params=aqs.AQSParameters(floppy=floppy)).trace
        for name in ("gamma", "energy", "jammed", "plastic"):
            np.testing.assert_array_equal(stored["trace"][name], getattr(direct, name))
        if floppy == "project":
            assert stored["attrs"]["shear_floppy"] == "project"
            assert stored["attrs"]["shear_n_projected"] == direct.attrs["n_projected"] > 0
            assert stored["attrs"]["shear_n_projection_failed"] == direct.attrs[
                "n_projection_failed"]
        else:
            assert not any("floppy" in k or "projec" in k for k in stored["attrs"])


def test_prepared_packing_is_the_samples_start(tmp_path):
    # the packing a sample file keeps, read back: positions, diameters and the pair law of the
    # run's study, the box side — equal to the preparation made directly with the sample's seed
    from jamlab.runs import prepared_packing

    study = Study(phi=["jamming"], n=[16], samples=1, dgamma=1e-3, gamma_max=3e-3, seed=2,
                  sizes="bidisperse", alpha=2.5)
    run_study(study, tmp_path / "r", Execution(workers=0))
    rd = RunDir(tmp_path / "r")
    key = study.keys()[0]
    assert rd.state(key) == "done", rd.read_failure(key)
    direct = packing.jam(16, 3, sample_seed(study.seed, key), p_target=study.p_target,
                         sizes="bidisperse", alpha=2.5).packing
    got = prepared_packing(rd.sample_path(key), gamma=0.25)
    np.testing.assert_array_equal(got.positions, direct.positions)
    np.testing.assert_array_equal(got.diameters, direct.diameters)
    assert got.alpha == 2.5 and got.box.length == direct.box.length and got.box.strain == 0.25
