"""Ensembles of other size distributions and pair laws (``Study.sizes``, ``Study.alpha``)."""

from __future__ import annotations

import numpy as np
import pytest

from jamlab.runs import Execution, Study, read_sample, run_study
from jamlab.spheres.packing import prepare
from jamlab.spheres.state import size_distribution


def test_bidisperse_hertzian_2d_study_equals_a_direct_computation(tmp_path):
    study = Study(phi=[0.9], n=[32], samples=2, dgamma=1e-3, gamma_max=5e-3, dim=2,
                  sizes="bidisperse", alpha=2.5, seed=3)  # fmt: skip
    run_study(study, tmp_path / "r", Execution(workers=0))
    files = sorted((tmp_path / "r").rglob("sample-*.h5"))
    assert len(files) == 2
    s = read_sample(files[0])
    assert np.array_equal(s["packing"]["diameters"], size_distribution(32, "bidisperse"))
    assert s["attrs"]["prep_param_alpha"] == 2.5 and s["attrs"]["prep_param_sizes"] == "bidisperse"
    # the prepared positions are those of a direct call with the sample's seed
    seed = int(s["attrs"]["seed"])
    direct = prepare(32, 2, 0.9, seed, sizes="bidisperse", alpha=2.5)
    assert np.array_equal(s["packing"]["positions"], direct.packing.positions)


@pytest.mark.parametrize(
    "bad,match",
    [({"sizes": "tri"}, "sizes"), ({"alpha": 1.0}, "alpha"), ({"alpha": "x"}, "alpha")],
)
def test_bad_pair_law_is_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        Study(phi=[0.8], n=[32], samples=1, dgamma=1e-3, gamma_max=5e-3, **bad)


def test_box_check_uses_the_largest_diameter():
    # N = 6 bidisperse discs at phi = 0.9: L = 2.78 < 2 x 1.4, refused before any computation
    # (monodisperse, L = 2.29 > 2 x 1 passes)
    Study(phi=[0.9], n=[6], samples=1, dgamma=1e-3, gamma_max=5e-3, dim=2).check_geometry()
    study = Study(phi=[0.9], n=[6], samples=1, dgamma=1e-3, gamma_max=5e-3, dim=2,
                  sizes="bidisperse")  # fmt: skip
    with pytest.raises(ValueError, match="2 max"):
        study.check_geometry()
