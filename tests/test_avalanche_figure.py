"""Fig. 5 (``jamlab.plots.report.plot_avalanche_histograms``): a φ without avalanches is an
empty panel that says so and is absent from the rescaled panel (a placeholder histogram of the
reproduce step was drawn there as a point of data: ``φ = 0.75`` at (1, 2) beside its own panel's
"no avalanches")."""

import numpy as np

from jamlab.analysis import log_histogram


def test_a_phi_without_avalanches_is_not_drawn_in_the_rescaled_panel(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    from jamlab.plots.report import plot_avalanche_histograms

    rng = np.random.default_rng(2)
    sizes = 1e-3 * (1.0 - rng.random(200)) ** -1.0
    hist = log_histogram(sizes, 5, n_total=400)
    kept = []
    monkeypatch.setattr(plt, "close", kept.append)
    plot_avalanche_histograms({"0.75": {}, "0.8": {32: hist}}, {"0.75": None, "0.8": hist},
                              {"0.75": None, "0.8": None}, {"0.75": 1.0, "0.8": 1.0},
                              tmp_path / "f.png")
    assert (tmp_path / "f.png").is_file()
    panels = kept[0].axes
    assert any(t.get_text() == "no avalanches" for t in panels[0].texts)
    drawn = [line.get_label() for line in panels[2].lines]
    assert "φ = 0.80" in drawn and "φ = 0.75" not in drawn
    x, y = next(line for line in panels[2].lines if line.get_label() == "φ = 0.80").get_data()
    ok = hist.counts > 0
    assert len(x) == ok.sum()
    # S over the typical size (geometric mean of the binned sizes): the count-weighted mean of
    # log x is 0
    assert abs(np.average(np.log(x), weights=hist.counts[ok])) < 1e-12
