"""Which packings carry the largest avalanches of a run, and in which state they happen.

A tail of a few events (e.g. the avalanches ≥ 1e-7 ε at p = 1e-6) is only as good as its
independence: if they come from one or two packings, the tail measures those packings. For each
run directory (φ label ``jamming`` at ``--n``, finished samples) and each floor of ``--above``:

- the avalanches counted by the report's rule (:func:`jamlab.reproduce.ensembles.counted_steps`:
  plastic, ``ΔE < 0``, both minima jammed) with ``S`` at or above the floor, **per sample**;
- their dispersion over the samples. Every finished sample covers the same strain window, so
  with independent avalanches at one rate the counts given their total ``K`` are multinomial
  with equal cells. The statistic is ``Σ c_i²`` (equivalently the sample variance at fixed
  ``K``); its p-value is the fraction of ``--trials`` multinomial deals with at least the
  observed value (``(1 + hits)/(1 + trials)``, seeded), the exact small-count version of the
  index-of-dispersion χ² test (also printed, ``(m − 1) s²/c̄`` on ``m − 1`` dof);
- the share of the events in the ``--top`` samples that have most;
- the events in the first and the second half of the strain window, with the two-sided binomial
  p-value of that split against equal halves;
- pairs of such events ``--lags`` steps apart in one sample, against the number expected of
  independent events placed uniformly among a sample's steps (``Σ c_i (c_i − 1)(T − ℓ)/(T (T −
  1))`` for lag ``ℓ``, ``T`` steps): avalanches that come in bursts show at the lags they span;
  and against the pairs at far lags (20–100 steps) per available position, which a rate that
  drifts along the window or differs between samples makes too (:func:`far_lag_baseline`);
- how often an avalanche is followed by one at the next step, by its size and by whether its
  backbone gained or lost contacts (:func:`follow_on`);
- of the pairs at consecutive steps, how many have the larger second (:func:`pair_order`); with
  ``--list-pairs`` each pair at the lowest floor (sample, step, both sizes) and how many of
  their second events reach each floor (:func:`consecutive_pairs`);
- with ``--bursts FLOOR WINDOW X_MIN``, τ with an exponential cut-off at ``X_MIN`` with and
  without the avalanches that follow one of ``S ≥ FLOOR`` within ``WINDOW`` steps
  (:func:`burst_fit`): do bursts move the exponent? And are those followers larger than the
  other avalanches beyond what each sample's own scale and a drift along the window give
  (:func:`follower_sizes`, a permutation test)?

For the highest floor each event is listed: sample, step, strain γ, ``S``, the shear-stress
ratio ``μ = σ_xy/p`` and the pressure of the minimum it starts from (the events' share
``−pΔV/S`` is ``scripts/enthalpy_parts.py``'s). A Mann–Whitney test compares ``μ``
and the step of these events with those of every other counted avalanche of the run: are the
large ones where the stress is high, or late in the window?

    PYTHONPATH=src python scripts/tail_events.py RUNS/n250-p1e-6-fix40 RUNS/n500-p1e-6-fix40 \\
        RUNS/n1000-p1e-6 --n 250 500 1000 --above 3e-8 1e-7
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import stats

from jamlab.analysis import consecutive_events, fit_cutoff_power_law
from jamlab.reproduce.ensembles import counted_steps, finished, intensive_stress
from jamlab.runs import add_run_arguments, open_run, sizes_per_run

LAGS = (1, 2, 3, 5, 10)
"""The lags (in steps) of the pair counts."""


def hits(sizes: np.ndarray, counted: np.ndarray, floor: float) -> np.ndarray:
    """The counted avalanches with ``S = −ΔE ≥ floor``: a boolean ``(samples, steps)`` mask of
    arrays ``sizes`` (``S``) and ``counted`` of that shape."""
    return counted & (sizes >= floor)


def per_sample_counts(sizes: np.ndarray, counted: np.ndarray, floor: float) -> np.ndarray:
    """Counted avalanches with ``S ≥ floor`` in each row (sample) (:func:`hits`)."""
    return np.asarray(hits(sizes, counted, floor).sum(axis=1), dtype=int)


def dispersion(counts: np.ndarray, trials: int, seed: int = 0) -> dict:
    """Dispersion of ``counts`` (one per sample, equal exposure) against equal rates: ``total``,
    ``mean``, ``variance`` (ddof 1), ``index`` (variance/mean), ``chi2`` and its ``p_chi2``
    (``m − 1`` dof, upper tail), ``p_exact`` (multinomial deals of the total, seeded; NaN for
    ``trials = 0``). NaN statistics without events or with fewer than two samples."""
    c = np.asarray(counts, dtype=int)
    m, total = c.size, int(c.sum())
    out = {"total": total, "samples": m, "mean": total / m if m else float("nan")}
    if m < 2 or total == 0:
        out.update(variance=float("nan"), index=float("nan"), chi2=float("nan"),
                   p_chi2=float("nan"), p_exact=float("nan"))
        return out
    var = float(c.var(ddof=1))
    chi2 = (m - 1) * var / out["mean"]
    out.update(variance=var, index=var / out["mean"], chi2=chi2,
               p_chi2=float(stats.chi2.sf(chi2, m - 1)))
    if trials <= 0:
        out["p_exact"] = float("nan")
        return out
    rng = np.random.default_rng(seed)
    deals = rng.multinomial(total, np.full(m, 1.0 / m), size=trials)
    observed = int(np.sum(c.astype(np.int64) ** 2))
    hits = int(np.count_nonzero(np.sum(deals.astype(np.int64) ** 2, axis=1) >= observed))
    out["p_exact"] = (1 + hits) / (1 + trials)
    return out


def top_share(counts: np.ndarray, top: int) -> float:
    """Share of all events in the ``top`` samples with most (NaN without events)."""
    c = np.sort(np.asarray(counts))[::-1]
    return float(c[:top].sum() / c.sum()) if c.sum() else float("nan")


def halves(sizes: np.ndarray, counted: np.ndarray, floor: float) -> tuple[int, int, float]:
    """Counted avalanches with ``S ≥ floor`` in the first and the second half of the steps
    (columns of ``(samples, steps)`` arrays; an odd middle step goes to the second half), and the
    two-sided binomial p-value of that split against ½ (NaN without events)."""
    hit = hits(sizes, counted, floor)
    half = hit.shape[1] // 2
    first, second = int(hit[:, :half].sum()), int(hit[:, half:].sum())
    if first + second == 0:
        return first, second, float("nan")
    return first, second, float(stats.binomtest(first, first + second, 0.5).pvalue)


def lag_pairs(sizes: np.ndarray, counted: np.ndarray, floor: float, lag: int) -> tuple[int, float]:
    """Pairs of counted avalanches with ``S ≥ floor`` exactly ``lag`` steps apart in one row of
    ``(samples, steps)`` arrays, and the number expected with each row's events placed uniformly
    among its ``T`` steps, ``Σ c (c − 1)(T − lag)/(T (T − 1))``."""
    hit = hits(sizes, counted, floor)
    steps = hit.shape[1]
    c = hit.sum(axis=1).astype(float)
    observed = int((hit[:, lag:] & hit[:, :-lag]).sum())
    return observed, float(np.sum(c * (c - 1)) * (steps - lag) / (steps * (steps - 1)))


FAR_LAGS = (20, 100)
"""The lags (inclusive range, in steps) whose pair counts make the far-lag baseline."""


def far_lag_baseline(sizes: np.ndarray, counted: np.ndarray, floor: float, lag: int,
                     far: tuple[int, int] = FAR_LAGS) -> tuple[float, float, float]:
    """The pairs expected ``lag`` steps apart if events were correlated only over long strains,
    and the Poisson p-values of the observed count, one for an excess and one for a deficit:
    ``(expected, p_more, p_fewer)``.

    The uniform placement of :func:`lag_pairs` ignores a rate that drifts along the strain
    window or differs between samples; both also make pairs at far lags. So the baseline is the
    observed pair count per available position at lags ``far[0] … far[1]``, ``Σ_L o_L / Σ_L
    (T − L)``, times the ``T − lag`` positions of ``lag``; ``p_more = P(X ≥ o_lag)`` and
    ``p_fewer = P(X ≤ o_lag)`` for ``X`` Poisson with that mean (the far lags hold many
    positions, so their own noise is left out). A rate that drifts steeply makes the baseline
    somewhat low (independent events whose rate grows 30-fold along the window: 3–12 % below
    the pairs at lag 1; the uniform placement 20–30 % below; ``tests/test_tail_events.py``)."""
    hit = hits(sizes, counted, floor)
    steps = hit.shape[1]
    lags = range(far[0], min(far[1], steps - 1) + 1)
    pairs = sum(int((hit[:, g:] & hit[:, :-g]).sum()) for g in lags)
    positions = sum(hit.shape[0] * (steps - g) for g in lags)
    expected = pairs / positions * hit.shape[0] * (steps - lag) if positions else float("nan")
    observed = int((hit[:, lag:] & hit[:, :-lag]).sum())
    if not expected > 0:
        return float(expected), float("nan"), float("nan")
    return (float(expected), float(stats.poisson.sf(observed - 1, expected)),
            float(stats.poisson.cdf(observed, expected)))


def far_text(observed: int, expected: float, p_more: float, p_fewer: float) -> str:
    """``expected (p …)`` with the p-value of the side the observed count lies on."""
    if observed < expected:
        return f"{expected:.1f} (fewer, p {p_fewer:.2g})"
    return f"{expected:.1f} (p {p_more:.2g})"


def follow_on(sizes: np.ndarray, counted: np.ndarray, z_nr: np.ndarray, floor: float) -> dict:
    """Does an avalanche make one at the next step more likely, and after which ones?

    ``sizes``, ``counted``: ``(samples, steps)``; ``z_nr``: ``(samples, steps + 1)``, the
    backbone coordination of the minima (row 0 the start). For the events ``S ≥ floor``: the
    ``base`` rate (events per step), and the fraction of events followed by one at the next
    step, overall and split by the event's size (decades from ``floor``) and by the sign of its
    ``Δz_nr`` (whether the backbone gained or lost contacts): ``{label: (n, followed, p)}``,
    ``p`` the one-sided binomial p-value of that many followers at the base rate."""
    hit = hits(sizes, counted, floor)
    base = float(hit.mean())
    first = hit[:, :-1]
    nxt = hit[:, 1:][first]
    size = sizes[:, :-1][first]
    dz = (z_nr[:, 1:-1] - z_nr[:, :-2])[first]
    groups = {"all": np.ones(nxt.size, dtype=bool)}
    for k in range(3):
        lo, hi = floor * 10.0**k, (floor * 10.0 ** (k + 1) if k < 2 else np.inf)
        groups[f"S in [{lo:.0e}, {hi:.0e})"] = (size >= lo) & (size < hi)
    groups |= {"Δz_nr < 0": dz < 0, "Δz_nr = 0": dz == 0, "Δz_nr > 0": dz > 0}
    out = {}
    for label, m in groups.items():
        k, followed = int(m.sum()), int(nxt[m].sum())
        p = float(stats.binomtest(followed, k, base, alternative="greater").pvalue) if k else 1.0
        out[label] = (k, followed, p)
    return {"base": base, "groups": out}


def pair_order(sizes: np.ndarray, counted: np.ndarray, floor: float) -> tuple[int, int, float]:
    """Of the pairs of counted avalanches ``S ≥ floor`` at consecutive steps (``(samples,
    steps)`` arrays; :func:`consecutive_pairs`), how many there are, in how many the second is
    the larger, and the two-sided binomial p of that count against ½ — what i.i.d. sizes give
    whatever their law: ``> ½`` is a small event before a large one (a foreshock), ``< ½`` an
    aftershock."""
    pairs = consecutive_pairs(sizes, counted, floor, np.arange(sizes.shape[0]))
    k, larger = len(pairs), sum(second > first for _, _, first, second in pairs)
    p = float(stats.binomtest(larger, k, 0.5).pvalue) if k else 1.0
    return k, larger, p


def consecutive_pairs(sizes: np.ndarray, counted: np.ndarray, floor: float,
                      ids: np.ndarray) -> list[tuple[int, int, float, float]]:
    """The pairs of counted avalanches ``S ≥ floor`` at consecutive steps
    (:func:`jamlab.analysis.consecutive_events`), one by one: ``(sample id, step of the second,
    S first, S second)``, steps numbered as the trace's (step ``k`` goes from minimum ``k − 1``
    to ``k``), in sample and step order."""
    i, k = consecutive_events(hits(sizes, counted, floor))
    return [(int(ids[a]), int(b) + 2, float(sizes[a, b]), float(sizes[a, b + 1]))
            for a, b in zip(i, k, strict=True)]


def followers(sizes: np.ndarray, counted: np.ndarray, floor: float, window: int) -> np.ndarray:
    """The counted avalanches (any size) that lie 1 … ``window`` steps after a counted one with
    ``S ≥ floor`` in the same row: a boolean mask of the ``(samples, steps)`` arrays. An event
    that is itself large and follows another is a follower too."""
    big = hits(sizes, counted, floor)
    after = np.zeros_like(big)
    for lag in range(1, window + 1):
        after[:, lag:] |= big[:, :-lag]
    return counted & after


def burst_fit(sizes: np.ndarray, counted: np.ndarray, floor: float, window: int,
              x_min: float) -> dict:
    """τ with an exponential cut-off at ``x_min`` (:func:`jamlab.analysis.fit_cutoff_power_law`)
    of every counted avalanche and of those left when the :func:`followers` of the events
    ``S ≥ floor`` are dropped: ``all``, ``without`` (the fits), ``dropped`` (followers in all /
    at or above ``x_min``) and ``sigma_diff``, the standard error of the difference of two nested
    fits, ``√(σ_without² − σ_all²)`` (the dropped events' own share of the noise)."""
    drop = followers(sizes, counted, floor, window)
    every = sizes[counted]
    kept = sizes[counted & ~drop]
    f_all = fit_cutoff_power_law(every, x_min)
    f_without = fit_cutoff_power_law(kept, x_min)
    var = f_without.tau_stderr**2 - f_all.tau_stderr**2
    return {"all": f_all, "without": f_without,
            "dropped": (int(drop.sum()), int((sizes[drop] >= x_min).sum())),
            "sigma_diff": float(np.sqrt(var)) if var > 0 else float("nan")}


def follower_sizes(sizes: np.ndarray, counted: np.ndarray, floor: float, window: int,
                   x_min: float, block: int, trials: int, seed: int = 0) -> dict:
    """Are the :func:`followers` of the events ``S ≥ floor`` larger than the other counted
    avalanches? Statistic: the mean of ``ln S`` over the followers with ``S ≥ x_min`` minus that
    over the other counted avalanches ``S ≥ x_min``. Null: the sizes are exchangeable among the
    counted steps of one sample within blocks of ``block`` steps (so a sample's own scale and a
    drift along the strain window are kept, the order within a block is not); ``trials``
    permutations (``numpy.random.default_rng(seed)``), which also re-decide which events are
    large and which follow. Returns ``n`` (followers), ``delta``, ``null_mean``, ``null_sd`` and
    ``p`` (one-sided, ``(1 + hits)/(1 + trials)``)."""
    def stat(s: np.ndarray) -> tuple[float, int]:
        f = followers(s, counted, floor, window)
        a = s[f & (s >= x_min)]
        b = s[counted & ~f & (s >= x_min)]
        if not (a.size and b.size):
            return float("nan"), int(a.size)
        return float(np.mean(np.log(a)) - np.mean(np.log(b))), int(a.size)

    sizes = np.where(counted, sizes, 0.0)
    delta, n = stat(sizes)
    blocks = [(i, np.nonzero(counted[i, k0:k0 + block])[0] + k0)
              for i in range(sizes.shape[0]) for k0 in range(0, sizes.shape[1], block)]
    rng = np.random.default_rng(seed)
    null = np.empty(trials)
    for t in range(trials):
        s = sizes.copy()
        for i, idx in blocks:
            s[i, idx] = sizes[i, rng.permutation(idx)]
        null[t] = stat(s)[0]
    ok = np.isfinite(null)
    p = (1 + int((null[ok] >= delta).sum())) / (1 + int(ok.sum())) if trials else float("nan")
    return {"n": n, "delta": delta, "null_mean": float(np.mean(null[ok])) if ok.any() else
            float("nan"), "null_sd": float(np.std(null[ok])) if ok.any() else float("nan"),
            "p": float(p)}


def run_tail(ds, n: int, floors: list[float]) -> dict:
    """For the finished samples at ``("jamming", n)``: ``samples`` (their ids), ``counts``
    (``{floor: per sample}``), ``halves`` (``{floor:`` :func:`halves` ``}``), ``order`` and
    ``pairs`` (``{floor:`` :func:`pair_order` / :func:`consecutive_pairs` ``}``), ``lags``
    (``{(floor, lag):`` :func:`lag_pairs` ``}`` for the lags of :data:`LAGS`), ``events`` (the
    counted avalanches at or above the highest floor:
    tuples ``(sample id, step, γ, S, μ, p)`` with μ and p of the minimum each starts from, by
    decreasing S), ``mu``, ``step`` of those events and ``mu_rest``, ``step_rest`` of every
    other counted avalanche, and ``arrays``: the ``(samples, steps)`` sizes and counted mask."""
    done = finished(ds, "jamming", n)
    if not done.any():
        raise ValueError(f"no finished sample at N = {n}")
    ids = np.asarray(ds.sample.values)[done]
    ej, counted = counted_steps(ds, "jamming", n)
    sizes = -ej
    gamma = np.asarray(ds.gamma.sel(phi="jamming", N=n).values)[done]
    pressure = np.asarray(ds.pressure.sel(phi="jamming", N=n).values)[done]
    mu = intensive_stress(ds, "jamming", n) / pressure
    counts = {f: per_sample_counts(sizes, counted, f) for f in floors}
    split = {f: halves(sizes, counted, f) for f in floors}
    lags = {(f, lag): lag_pairs(sizes, counted, f, lag) for f in floors for lag in LAGS}
    far = {(f, lag): far_lag_baseline(sizes, counted, f, lag) for f in floors for lag in LAGS}
    z_nr = np.asarray(ds.z_nr.sel(phi="jamming", N=n).values)[done]
    follow = {f: follow_on(sizes, counted, z_nr, f) for f in floors}
    order = {f: pair_order(sizes, counted, f) for f in floors}
    pairs = {f: consecutive_pairs(sizes, counted, f, ids) for f in floors}
    big = hits(sizes, counted, max(floors))
    rest = counted & ~big
    i, k = np.nonzero(big)  # step k -> k + 1 of the trace (row 0 has no step)
    events = sorted(((int(ids[a]), int(b) + 1, float(gamma[a, b + 1]), float(sizes[a, b]),
                      float(mu[a, b]), float(pressure[a, b])) for a, b in zip(i, k, strict=True)),
                    key=lambda e: -e[3])
    ir, kr = np.nonzero(rest)
    return {"samples": ids, "counts": counts, "halves": split, "lags": lags, "far": far,
            "follow": follow, "order": order, "pairs": pairs, "events": events,
            "mu": mu[i, k], "step": k + 1, "mu_rest": mu[ir, kr], "step_rest": kr + 1,
            "arrays": (sizes, counted)}


def mann_whitney(a: np.ndarray, b: np.ndarray) -> float:
    """Two-sided Mann–Whitney p-value of ``a`` against ``b`` (NaN if either is empty)."""
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    return float(stats.mannwhitneyu(a, b, alternative="two-sided").pvalue)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(ap, default_n=500)
    ap.add_argument("--above", type=float, nargs="+", default=[1e-7],
                    help="floors of S (ε); the events of the highest are listed")
    ap.add_argument("--trials", type=int, default=99999,
                    help="multinomial deals for the exact dispersion p-value")
    ap.add_argument("--top", type=int, default=2, help="samples in the top share")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--list-pairs", action="store_true",
                    help="list the pairs at consecutive steps at the lowest floor")
    ap.add_argument("--bursts", type=float, nargs=3, metavar=("FLOOR", "WINDOW", "X_MIN"),
                    help="τ (exponential cut-off at X_MIN) with and without the avalanches "
                         "1 … WINDOW steps after one of S ≥ FLOOR, and their sizes against "
                         "the others by a permutation test")
    ap.add_argument("--burst-block", type=int, default=100,
                    help="steps of the blocks within which --bursts permutes a sample's sizes")
    ap.add_argument("--burst-trials", type=int, default=400,
                    help="permutations of the --bursts size test")
    a = ap.parse_args()
    n_of_run = sizes_per_run(ap, a)
    if not all(x > 0 for x in a.above):
        ap.error("--above floors must be > 0")
    if a.trials < 0 or a.top < 1:
        ap.error("--trials must be >= 0 and --top >= 1")
    if a.bursts is not None and not (a.bursts[0] > 0 and a.bursts[1] >= 1
                                     and a.bursts[1] == int(a.bursts[1]) and a.bursts[2] > 0):
        ap.error("--bursts takes FLOOR > 0, an integer WINDOW >= 1 and X_MIN > 0")
    if a.burst_block < 1 or a.burst_trials < 0:
        ap.error("--burst-block must be >= 1 and --burst-trials >= 0")
    for run, n in zip(a.runs, n_of_run, strict=True):
        t = run_tail(open_run(run), n, a.above)
        m = len(t["samples"])
        print(f"\n{run} (N = {n}): {m} finished samples\n")
        print(f"| S ≥ (ε) | events | per sample | variance | dispersion index | χ² p | exact p "
              f"| share of top {a.top} | 1st / 2nd half of γ (p) |")
        print("|---|---|---|---|---|---|---|---|---|")
        for x in sorted(a.above):
            d = dispersion(t["counts"][x], a.trials, a.seed)
            print(f"| {x:.0e} | {d['total']} | {d['mean']:.2f} | {d['variance']:.2f} | "
                  f"{d['index']:.2f} | {d['p_chi2']:.3g} | {d['p_exact']:.3g} | "
                  f"{top_share(t['counts'][x], a.top):.2f} | {t['halves'][x][0]} / "
                  f"{t['halves'][x][1]} ({t['halves'][x][2]:.2g}) |")
        print("\npairs of avalanches ℓ steps apart, observed / expected of independent ones:")
        for x in sorted(a.above):
            print(f"  S ≥ {x:.0e}: " + ", ".join(
                f"ℓ = {lag}: {t['lags'][x, lag][0]} / {t['lags'][x, lag][1]:.1f}"
                for lag in LAGS))
        print(f"  against the far-lag baseline (pairs per position at ℓ = {FAR_LAGS[0]}–"
              f"{FAR_LAGS[1]}: a rate that drifts along γ or differs between samples), "
              "expected and Poisson p of the observed (of an excess; 'fewer': of a deficit):")
        for x in sorted(a.above):
            print(f"  S ≥ {x:.0e}: " + ", ".join(
                f"ℓ = {lag}: {far_text(t['lags'][x, lag][0], *t['far'][x, lag])}"
                for lag in LAGS))
        print("\nan avalanche followed by one at the next step (n events, followed, binomial p "
              "against the base rate), by its size and by its Δz_nr:")
        for x in sorted(a.above):
            fo = t["follow"][x]
            print(f"  S ≥ {x:.0e}, base rate {fo['base']:.4f} per step: " + "; ".join(
                f"{label} {k}, {f} ({f / k if k else float('nan'):.3f}, p {p:.2g})"
                for label, (k, f, p) in fo["groups"].items()))
        print("\npairs at consecutive steps: the second the larger (of i.i.d. sizes half; more: "
              "a small event before a large one), two-sided binomial p:")
        for x in sorted(a.above):
            k, larger, p = t["order"][x]
            print(f"  S ≥ {x:.0e}: {larger} of {k} ({larger / k if k else float('nan'):.2f}, "
                  f"p {p:.2g})")
        if a.list_pairs:
            low = min(a.above)
            pairs = t["pairs"][low]
            print(f"\npairs at consecutive steps, S ≥ {low:.0e} ε: sample, step of the second, "
                  "S first, S second (ε); how many of the seconds reach each floor: " + ", ".join(
                      f"≥ {x:.0e}: {sum(q[3] >= x for q in pairs)} of {len(pairs)}"
                      for x in sorted(a.above)))
            for q in pairs:
                print(f"  {q[0]:3d} {q[1]:5d} {q[2]:.3e} {q[3]:.3e}")
        if a.bursts is not None:
            floor, window, x_min = a.bursts[0], int(a.bursts[1]), a.bursts[2]
            sizes, counted = t["arrays"]
            b = burst_fit(sizes, counted, floor, window, x_min)
            fa, fw = b["all"], b["without"]
            print(f"\nτ at S ≥ {x_min:.3g} ε (exponential cut-off) without the avalanches "
                  f"1–{window} steps after one ≥ {floor:.3g} ε: dropped {b['dropped'][0]} "
                  f"({b['dropped'][1]} in the window); all {fa.tau:.3f} ± {fa.tau_stderr:.3f} "
                  f"({fa.n_tail}), without {fw.tau:.3f} ± {fw.tau_stderr:.3f} ({fw.n_tail}); "
                  f"difference {fw.tau - fa.tau:+.3f} (nested σ {b['sigma_diff']:.3f})")
            fs = follower_sizes(sizes, counted, floor, window, x_min, a.burst_block,
                                a.burst_trials, a.seed)
            print(f"  the {fs['n']} followers ≥ {x_min:.3g} ε against the other avalanches: "
                  f"<ln S> {fs['delta']:+.3f} (sizes permuted within {a.burst_block}-step blocks "
                  f"of each sample: {fs['null_mean']:+.3f} ± {fs['null_sd']:.3f}; p "
                  f"{fs['p']:.3g}, {a.burst_trials} permutations)")
        top = max(a.above)
        print(f"\nper sample (id: count ≥ {', '.join(f'{x:.0e}' for x in sorted(a.above))}): "
              + "; ".join(f"{s}: " + "/".join(str(t["counts"][x][j]) for x in sorted(a.above))
                          for j, s in enumerate(t["samples"])
                          if any(t["counts"][x][j] for x in a.above)))
        print(f"\nevents ≥ {top:.0e} ε: sample, step, γ, S (ε), μ and p before")
        for e in t["events"]:
            print(f"  {e[0]:3d} {e[1]:5d} {e[2]:.5f} {e[3]:.3e} {e[4]:.4f} {e[5]:.3e}")
        print(f"against the other {len(t['mu_rest'])} counted avalanches: Mann–Whitney p "
              f"μ {mann_whitney(t['mu'], t['mu_rest']):.3g}, step "
              f"{mann_whitney(t['step'], t['step_rest']):.3g}; median μ "
              f"{np.median(t['mu']) if len(t['mu']) else float('nan'):.4f} against "
              f"{np.median(t['mu_rest']) if len(t['mu_rest']) else float('nan'):.4f}")


if __name__ == "__main__":
    main()
