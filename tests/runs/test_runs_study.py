"""Study validation, TOML loading and the CLI's multi-value options."""

import math

import pytest

from jamlab.cli.runs import expand_multi_values
from jamlab.runs import SampleKey, Study, load_toml
from jamlab.runs.study import merge, parse_phi, phi_label

BASE = dict(phi=["jamming", 0.8, 0.75], n=[32, 16], samples=3, dgamma=1e-3, gamma_max=1e-2)


def test_study_normalises_order_and_types():
    s = Study(**BASE)
    assert s.phi == ("jamming", 0.75, 0.8)
    assert s.n == (16, 32)
    assert Study(**{**BASE, "phi": ["0.75", "JAMMING", "0.8"], "n": ["16", "32.0"]}) == s
    assert len(s.keys()) == s.n_samples == 3 * 2 * 3
    assert len(set(s.keys())) == s.n_samples


def test_floppy_is_stored_only_when_not_the_default():
    # earlier run directories (no key) keep their study; a projected run records its choice
    assert "floppy" not in Study(**BASE).to_dict() and Study(**BASE).floppy == "fire"
    s = Study(**BASE, floppy="project")
    assert s.to_dict()["floppy"] == "project" and Study.from_dict(s.to_dict()) == s
    assert [d.split(":")[0] for d in s.differences(Study(**BASE))] == ["floppy"]


def test_study_round_trips_through_dict():
    s = Study(**BASE, seed=7, dim=2)
    assert Study.from_dict(s.to_dict()) == s
    assert s.differences(Study.from_dict(s.to_dict())) == []
    other = Study(**{**BASE, "samples": 4}, seed=7, dim=2)
    assert [d.split(":")[0] for d in s.differences(other)] == ["samples"]


@pytest.mark.parametrize(
    "change, words",
    [
        ({"phi": ["jammed"]}, "unknown phi"),
        ({"phi": [-0.5]}, "phi"),
        ({"phi": ["nan"]}, "phi"),
        ({"phi": [0.8, "0.80"]}, "twice"),
        ({"phi": []}, "at least one"),
        ({"n": [-16]}, "n must be an integer >= 2"),
        ({"n": [16.5]}, "integer"),
        ({"n": [16, 16]}, "twice"),
        ({"samples": -3}, "samples must be an integer in \\[1, 1000000\\]"),
        ({"samples": 0}, "samples must be an integer in \\[1, 1000000\\]"),
        ({"samples": 10**20}, "samples must be an integer in \\[1, 1000000\\]"),
        ({"checkpoint_every": 10**20}, "checkpoint_every must be an integer in \\[0, 10000000\\]"),
        ({"seed": -1}, "seed"),
        ({"dgamma": 0.0}, "dgamma"),
        ({"dgamma": 1e-2}, "smaller than gamma_max"),
        ({"dgamma": 2e-2}, "smaller than gamma_max"),
        ({"gamma_max": math.inf}, "gamma_max"),
        ({"dim": 1}, "dim"),
        ({"task": "nope"}, "unknown task"),
        ({"floppy": "newton"}, "floppy must be"),
        ({"floppy": "project", "pressure": 1e-4}, "constant-volume runs only"),
    ],
)
def test_study_rejects_bad_values_with_a_message(change, words):
    with pytest.raises(ValueError, match=words):
        Study(**{**BASE, **change})


def test_from_dict_rejects_unknown_and_missing_keys():
    with pytest.raises(ValueError, match="unknown study parameter"):
        Study.from_dict({**BASE, "gama_max": 1})
    with pytest.raises(ValueError, match="missing study parameter.*dgamma"):
        Study.from_dict({k: v for k, v in BASE.items() if k != "dgamma"})


def test_phi_labels_round_trip_exactly():
    for phi in (0.75, 0.8, 0.1 + 0.2, 0.64, 0.99):
        assert parse_phi(phi_label(phi)) == phi
    assert phi_label("jamming") == "jamming"
    assert SampleKey(0.8, 500, 42).relpath() == "samples/phi=0.8/N=500/sample-00042.h5"


def test_toml_file(tmp_path):
    (tmp_path / "s.toml").write_text(
        'phi = ["jamming", 0.75]\nn = [16]\nsamples = 2\ndgamma = 1e-3\ngamma_max = 1e-2\n'
        'seed = 5\nout = "runs/x"\n[execution]\nworkers = 2\n'
    )
    params, out, execution = load_toml(tmp_path / "s.toml")
    assert Study.from_dict(params) == Study(
        phi=["jamming", 0.75], n=[16], samples=2, dgamma=1e-3, gamma_max=1e-2, seed=5
    )
    assert out == str(tmp_path / "runs/x")
    assert execution == {"workers": 2}
    assert merge(params, [("seed", 9), ("samples", None)])["seed"] == 9
    (tmp_path / "bad.toml").write_text("phi = [\n")
    with pytest.raises(ValueError, match="cannot parse"):
        load_toml(tmp_path / "bad.toml")


def test_expand_multi_values():
    args = ["--phi", "jamming", "0.75", "0.8", "--n", "500", "-5", "--samples", "3", "-q"]
    assert expand_multi_values(args) == [
        "--phi", "jamming", "--phi", "0.75", "--phi", "0.8",
        "--n", "500", "--n", "-5", "--samples", "3", "-q",
    ]  # fmt: skip
    # a study file after the values is not a value
    assert expand_multi_values(["--n", "16", "s.toml"]) == ["--n", "16", "s.toml"]
    assert expand_multi_values(["--phi=0.8", "x"]) == ["--phi=0.8", "x"]


def test_example_study_file_is_valid():
    from pathlib import Path

    example = Path(__file__).resolve().parents[2] / "examples" / "study.toml"
    params, out, execution = load_toml(example)
    study = Study.from_dict(params)
    assert study.phi == ("jamming", 0.75, 0.8, 0.9) and study.n == (500, 1000)
    assert out is not None and execution["workers"] >= 1


def test_an_aqs_study_below_jamming_is_refused():
    # an over-jammed preparation at phi < 0.62 in 3D fails every sample (as `prepare` refuses it)
    with pytest.raises(ValueError, match="phi 0.3 is below jamming"):
        Study(phi=[0.3], n=[16], samples=1, dgamma=1e-3, gamma_max=1e-2)
    assert Study(phi=[0.62], n=[16], samples=1, dgamma=1e-3, gamma_max=1e-2).phi == (0.62,)
    # other dimensions: the preparation's own rule; the toy task has no preparation
    Study(phi=[0.3], n=[16], samples=1, dgamma=1e-3, gamma_max=1e-2, dim=2)
    Study(phi=[0.3], n=[16], samples=1, dgamma=1e-3, gamma_max=1e-2, task="toy")
