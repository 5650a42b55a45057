"""The exact-law tables of Fig. 3 (``jamlab.plots.theory.exact_jump_distribution_table``): a
second window read from the same law is the table that a law built afresh gives, bit for bit
(the report reads its exponent rows and the fig3_exact panel from one law per δγ)."""

import numpy as np
import pytest

from jamlab.plots.theory import exact_jump_distribution_table

KW = dict(q_max=1.0 - 1e-3, levels=8)


def test_a_window_from_the_same_law_is_the_table_of_a_fresh_law():
    both = exact_jump_distribution_table(0.5, [2e-2, 1e-2], n_points=9,
                                         windows={1e-2: ((0.02, 0.15), 7)}, **KW)
    assert "window" not in both[2e-2]
    apart = exact_jump_distribution_table(0.5, [1e-2], n_points=7, ratios=(0.02, 0.15), **KW)
    window = both[1e-2].pop("window")
    assert sorted(window) == sorted(apart[1e-2])
    for key, value in apart[1e-2].items():
        assert np.array_equal(window[key], value), key
    # and the main table is the one made without a window
    alone = exact_jump_distribution_table(0.5, [2e-2, 1e-2], n_points=9, **KW)
    for dg in (2e-2, 1e-2):
        for key, value in alone[dg].items():
            assert np.array_equal(both[dg][key], value), (dg, key)
    # the window's slopes are those of a law, not a copy of the main table's grid
    assert window["abs_dE"][0] == pytest.approx(0.02 * 1e-2)
    assert np.all(np.isfinite(window["slope_exact"]))


def test_a_window_at_another_dgamma_is_refused():
    with pytest.raises(ValueError, match="need their δγ among"):
        exact_jump_distribution_table(0.5, [1e-2], windows={1e-3: ((0.02, 0.15), 7)}, **KW)


def test_a_law_is_freed_with_its_last_reference():
    # its marginal laws once held it through their functions: a reference cycle of ~0.3 GB at
    # 64 levels that only a full garbage collection freed (a report held several laws at once)
    import gc
    import weakref

    from jamlab.theory import ParisiFunction, exact_jump_law

    law = exact_jump_law(ParisiFunction.power_law(0.5, q_max=1.0 - 1e-3), 1e-2, levels=8)
    law.pdf([-1e-3])
    assert np.isfinite(law.du.cdf(np.array([1e-3]))).all()
    ref = weakref.ref(law)
    enabled = gc.isenabled()
    gc.disable()
    try:
        del law
        assert ref() is None
    finally:
        if enabled:
            gc.enable()


@pytest.mark.parametrize("which", ["unsat", "jamming"])
def test_exact_and_printed_laws_part_at_first_order_in_dgamma(which):
    # the printed formula is right at first order (docs/theory-vs-cascade.md §5): the relative
    # difference 1 − P_exact/P_printed halves with δγ at every |ΔE|/δγ of the table (measured
    # 1.85–2.04 with 16 levels), and the exact law lies below the printed one
    from jamlab.theory import mu_jamming

    mu = 0.5 if which == "unsat" else mu_jamming()
    tab = exact_jump_distribution_table(mu, [1e-2, 5e-3], n_points=9, q_max=1.0 - 1e-3,
                                        levels=16)
    dev = {dg: 1.0 - t["pdf_exact"] / t["pdf_printed"] for dg, t in tab.items()}
    assert np.allclose(tab[1e-2]["abs_dE"] / 1e-2, tab[5e-3]["abs_dE"] / 5e-3, rtol=1e-12)
    assert np.all(dev[5e-3] > 0)
    ratio = dev[1e-2] / dev[5e-3]
    assert np.all((1.8 < ratio) & (ratio < 2.15)), ratio


def test_the_bottom_row_of_fig3_exact_is_the_ratio(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    from jamlab.plots.theory import plot_jump_distributions_exact

    r = np.geomspace(1e-3, 1.0, 5)
    table = {"abs_dE": 1e-2 * r, "pdf_printed": r**-1.0, "pdf_exact": 0.97 * r**-1.0,
             "slope_printed": -np.ones(5), "slope_exact": -np.ones(5)}
    kept = []
    monkeypatch.setattr(plt, "close", kept.append)
    plot_jump_distributions_exact([0.5], [1e-2], tmp_path / "f.png", tables={0.5: {1e-2: table}})
    assert (tmp_path / "f.png").is_file()
    bottom = kept[0].axes[2]
    x, y = bottom.lines[0].get_data()
    assert np.allclose(x, r) and np.allclose(y, 0.97)
    assert bottom.get_ylabel().startswith("P_exact / P_printed")
