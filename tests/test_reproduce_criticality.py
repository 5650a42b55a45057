"""The report's criticality rows: verdicts on synthetic fits, worked by hand here.

The rows compare ``θ_e``, ``θ_l``, ``γ`` of the jamming packings with ``SPEC.md`` §6 and the
``τ_J`` they predict (``1 + γ``, ``(3 + θ_e)/(2 + θ_e)``) with the τ fitted from the avalanches.
The rule (``jamlab.report``): agrees iff ``|a − b| ≤ 2 √(σ_a² + σ_b²)``, σ = half the 95 %
interval / 1.96. Every expected number below is computed in this file from those definitions.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from jamlab.analysis.criticality import ExponentFit
from jamlab.analysis.finite_size import fit_cutoff_scaling, fit_joint_scaling
from jamlab.reproduce.criticality import FiniteSizeResult, PackingCriticality
from jamlab.reproduce.criticality_table import criticality_rows, finite_size_rows
from jamlab.reproduce.measurements import TauEstimate

Z = 1.959963984540054


def _fit(value, half):
    return ExponentFit(value, (value - half, value + half), (1e-3, 1e-2), 30, 5000, 400, "cdf",
                       200)


def _crit(theta_e=(0.42, 0.04), theta_l=(0.17, 0.1), gamma=(0.40, 0.02), missing=()):
    fits = {"theta_e": _fit(*theta_e), "theta_l": _fit(*theta_l), "gamma": _fit(*gamma)}
    for m in missing:
        fits[m] = None
    return PackingCriticality(
        packings={64: 30, 128: 30}, fits=fits, fits_by_n={}, reasons={m: "test" for m in missing},
        counts={"packings": 60, "contacts": 9000, "localized_contacts": 400, "gaps": 12000},
        pressures=(1e-7, 9e-8, 1.1e-7), seconds=1.0)


def _tau(tau, sigma):
    fit = SimpleNamespace(tau=tau, ci_low=tau - Z * sigma, ci_high=tau + Z * sigma, x_min=1e-6,
                          n_tail=300)
    return TauEstimate("jamming", fit, sigma, 400, 6000, 60, {}, None,
                       fit_pressures=(1e-4, 1e-5, 1e-3))


class _Rows(dict):
    def __getitem__(self, start):
        hits = [r for q, r in self.items() if q.startswith(start)]
        assert len(hits) == 1, (start, list(self))
        return hits[0]


def _rows(crit, tau):
    return _Rows({r.quantity: r for r in criticality_rows(crit, tau)})


def _verdict(row, label):
    hits = [v for v in row.verdicts if v.startswith(label)]
    assert len(hits) == 1, row.verdicts
    return hits[0]


def test_exponents_against_spec():
    rows = _rows(_crit(theta_e=(0.30, 0.05), gamma=(0.40, 0.04)), _tau(1.40, 0.02))
    # θ_e: |0.30 − 0.42311| = 0.12311, σ = 0.05/1.96 = 0.02551 → 4.83σ: differs
    assert _verdict(rows["θ_e,"], "SPEC").startswith("SPEC §6: differs (4.83σ)")
    # γ: |0.40 − 1/(2 + 0.42311)| = 0.01269, σ = 0.04/1.96 = 0.02041 → 0.62σ: agrees
    assert _verdict(rows["γ,"], "SPEC") == "SPEC §6: agrees (0.62σ)"
    assert rows["θ_e,"].value == 0.30
    assert rows["γ,"].error == pytest.approx(0.04 / Z)


@pytest.mark.parametrize("k, word", [(1.9, "agrees"), (2.1, "differs"), (0.0, "agrees")])
def test_one_plus_gamma_against_the_fitted_tau_at_the_boundary(k, word):
    g, half, s_tau = 0.38, 0.03, 0.025
    comb = math.hypot(half / Z, s_tau)
    tau = 1 + g + k * comb
    rows = _rows(_crit(gamma=(g, half)), _tau(tau, s_tau))
    row = rows["τ_J predicted by 1 + γ"]
    assert row.value == pytest.approx(1.38)
    v = _verdict(row, "τ fitted")
    assert v.split(": ")[1].startswith(word), v
    assert f"({k:.2f}σ)" in v


def test_tau_from_theta_e_is_the_formula_and_its_interval():
    theta, half = 0.35, 0.05
    rows = _rows(_crit(theta_e=(theta, half)), _tau(1.5, 0.01))
    row = rows["τ_J predicted by (3"]
    assert row.value == pytest.approx((3 + theta) / (2 + theta), abs=1e-12)
    lo, hi = (3 + theta + half) / (2 + theta + half), (3 + theta - half) / (2 + theta - half)
    assert f"[{lo:.3f}, {hi:.3f}]" in row.value_text
    assert row.error == pytest.approx((hi - lo) / (2 * Z))
    # 1.4255 vs 1.5 ± 0.01: differs; vs the theory's 1.41269: |Δ| = 0.0128, σ = 0.00455 → 2.81σ
    assert _verdict(row, "τ fitted").split(": ")[1].startswith("differs")
    assert _verdict(row, "theory τ_J").split(": ")[1].startswith("differs")
    rows = _rows(_crit(theta_e=(theta, half)), _tau(1.43, 0.02))
    row = rows["τ_J predicted by (3"]
    assert _verdict(row, "τ fitted").split(": ")[1].startswith("agrees")


def test_missing_fits_say_no_data():
    rows = _rows(_crit(missing=("gamma", "theta_e")), _tau(1.4, 0.02))
    assert _verdict(rows["γ,"], "SPEC") == "SPEC §6: no data"
    assert rows["γ,"].value_text.startswith("n/a (test)")
    assert _verdict(rows["τ_J predicted by 1 + γ"], "τ fitted").endswith("no data")
    assert _verdict(rows["τ_J predicted by (3"], "theory").endswith("no data")
    rows = _rows(_crit(), TauEstimate("jamming", None, math.nan, 3, 10, 2, {}, None))
    assert _verdict(rows["τ_J predicted by 1 + γ"], "τ fitted").endswith("no data")


def test_finite_size_row_and_missing_labels():
    rng = np.random.default_rng(1)
    per_n = {64: [rng.exponential(1.0, 20) for _ in range(10)],
             128: [rng.exponential(2.0, 20) for _ in range(10)]}
    sc = fit_cutoff_scaling(per_n, n_boot=50)
    assert sc.beta == pytest.approx(math.log(sc.cutoff[1] / sc.cutoff[0]) / math.log(2))
    r = FiniteSizeResult({"jamming": sc, "0.75": None, "0.8": None},
                         {"jamming": None, "0.75": None, "0.8": None},
                         {"jamming": math.nan, "0.75": math.nan, "0.8": math.nan},
                         {"jamming": 1.0, "0.75": math.nan, "0.8": math.nan},
                         {"0.75": "need avalanches at two sizes", "0.8": "x"})
    rows = finite_size_rows(r)
    assert rows[0].value == sc.beta and "two sizes" in rows[0].note
    assert "N = 64: 10 samples, 200 avalanches" in rows[0].samples
    assert rows[1].value_text.startswith("n/a (need avalanches")
    assert rows[1].verdicts == ["β of the best collapse: no data"]
    assert rows[0].verdicts[1] == "β of the joint maximum-likelihood fit: no data"
    # with the joint fit: exponential sizes of mean 1 and 2 are τ = 0 with a cut-off S* that
    # doubles from N = 64 to 128, β = 1
    jt = fit_joint_scaling(per_n, 0.01, n_boot=50)
    assert jt.resolved and abs(jt.beta - 1.0) < 3 * jt.beta_err and abs(jt.tau) < 3 * jt.tau_err
    r = FiniteSizeResult(r.scaling, r.collapse, r.quality_unscaled, r.beta_best, r.reasons,
                         {"jamming": jt, "0.75": None, "0.8": None})
    row = finite_size_rows(r)[0]
    assert "joint maximum-likelihood fit on S ≥ 0.01 ε" in row.value_text
    assert "cut-off resolved" in row.value_text
    assert row.verdicts[1].startswith("β of the joint maximum-likelihood fit: ")
    assert not row.verdicts[1].endswith("no data")
