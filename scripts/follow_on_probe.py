"""The step after an avalanche, taken again from the avalanche's minimum at the current box side.

At p = 1e-6 an avalanche was followed by another at the very next step 2–12× more often than
independent avalanches would be, and not at the steps after (``scripts/tail_events.py``), also
with δγ halved. Runs made with ``volume_guess="always"`` started every step's box side at the
linear extrapolation of the last two minima, so the step after a jump started from the jump's
volume change repeated. This probe tells which of those follow-on events that start made.

For each sample file given (a finished sample of a fixed-pressure ``jamming`` run), the sample is
replayed from its prepared packing with the run's own options (``shear_at_pressure`` as
``jamlab run`` calls it through ``aqs.shear``, with the run's ``volume_guess``), keeping every
minimum; the replay's ``ΔH`` and plastic flags are compared with the stored trace. Then, for
every counted avalanche (plastic, ``S = −ΔH ≥ --above``, both minima jammed: the report's rule)
ending at minimum ``k``, the step ``k → k + 1`` is taken afresh from that minimum at its own box
side (one ``shear_at_pressure`` step: what ``volume_guess="elastic"`` does after a jump). It
releases when ``−r > --event``, ``r = ΔH − ½ δγ ΔΣ`` its trapezoid residual. The table crosses
that with the run's own step ``k + 1`` (a counted avalanche or not).

    PYTHONPATH=src python scripts/follow_on_probe.py \\
        RUNS/n250-p1e-6-fix40/samples/phi=jamming/N=250/sample-0000{0,1,2}.h5 --above 1e-9

With ``--pairs`` it probes the pairs of counted avalanches at consecutive steps ``k`` and
``k + 1`` instead (``tail_events.py``'s foreshocks: mostly a small one, then a larger one): is
the first a separate instability, or the start of one instability that a step of ``δγ`` split
in two? The replay stops at the last pair; from the minimum ``k − 1`` before each pair the two
steps are taken again in ``2 m`` substeps of ``δγ/m`` (``--substeps m``), one fixed-pressure
run as the study's. Printed for each pair: the run's two sizes, the substeps the replay flags
plastic (counted by the report's rule: plastic, ``ΔH < 0``, both minima jammed), each with
its ``S``, and the sum of the substeps' ``−ΔH`` against the run's two. Two releases with an
elastic substep between are two instabilities at distinct strains; releases in adjacent
substeps are one at this resolution.

With ``--where`` it asks where the two events of each such pair happen. The replay stops at
the last pair and keeps the minima around every counted avalanche ``S ≥ --above`` up to there.
An event's plastic displacement is its step's non-affine displacement less that of the last
step before it the run did not flag plastic (the branch's smooth response, same δγ), rattlers
left out. Printed
for each consecutive pair: both participation ratios, the shared weight ``Σ min(w_i, w'_i)`` of
the two fields' per-particle shares ``w``, the cosine of the two fields, the distance between
their most-moving particles, and the elastic reference's share of the first step's
displacement. The same measures are then summarised against pairs of events 2 … ``--lag-min``
− 1 steps apart and ``≥ --lag-min`` apart in the same samples.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import h5py
import numpy as np

from jamlab.analysis import classify_steps, consecutive_events
from jamlab.analysis.anatomy import participation_ratio
from jamlab.provenance import differ, machine, summary_text
from jamlab.runs import RunDir, prepared_packing
from jamlab.runs.origin import provenance_records
from jamlab.spheres.contacts import remove_rattlers
from jamlab.spheres.pressure_shear import CONFIRM_BELOW, FROM_AQS_OPTION, shear_at_pressure


def options(study) -> dict:
    """The fixed-pressure options ``jamlab run`` gives ``aqs.shear`` for ``study``."""
    return dict(pressure=study.pressure, ftol=study.force_tol,
                minimizer=FROM_AQS_OPTION["linear"], confirm="located",
                confirm_below=CONFIRM_BELOW, volume_guess=study.volume_guess)


def stored_columns(sample: Path) -> dict:
    """The trace columns ``energy_jump``, ``plastic``, ``jammed`` stored in a sample file."""
    with h5py.File(sample, "r") as h5:
        return {k: h5[f"trace/{k}"][()] for k in ("energy_jump", "plastic", "jammed")}


def pair_steps(stored: dict, above: float) -> tuple[np.ndarray, list[int]]:
    """Of a sample's :func:`stored_columns`: the mask of the counted avalanches (the report's
    rule, :func:`jamlab.analysis.classify_steps`) with ``S ≥ above``, one entry per step from
    step 1, and the trace steps ``k`` at which a pair of them at ``k`` and ``k + 1`` starts."""
    dh = stored["energy_jump"]
    hit = classify_steps(dh[1:], stored["plastic"][1:], jammed=stored["jammed"]) & (
        -dh[1:] >= above)
    return hit, [int(b) + 1 for b in consecutive_events(hit)[0]]


def other_machine(sample: Path) -> str:
    """Why a replay may part from the stored trace at rounding level: ``""`` when every
    invocation recorded in the sample's ``provenance`` ran on this machine and libraries
    (``jamlab.provenance.differ``; e.g. ``JAMLAB_CHOLMOD_BLAS`` changes the BLAS kernels), else
    a sentence naming the first that did not."""
    with h5py.File(sample, "r") as h5:
        records = provenance_records(h5.attrs.get("provenance")) or []
    here = machine()
    for r in records:
        if differ(r, here):
            return (f" (made on another machine or BLAS: {summary_text(r)}; "
                    f"here: {summary_text(here)})")
    return ""


def verdict(sample: Path, same: bool) -> str:
    """``equal to the stored trace``, or ``DIFFERS …`` with :func:`other_machine`'s reason."""
    return ("equal to the stored trace" if same
            else "DIFFERS from the stored trace" + other_machine(sample))


def replay(sample: Path, n_steps: int | None = None, keep=None):
    """``(study, stored trace columns, replayed trace, minima)`` of one sample file: the shear
    redone from its prepared packing with the run's options and restart points (its first
    ``n_steps`` steps; all by default), the minima kept (``minima[n]`` ends step ``n``; only the
    steps in ``keep`` if given)."""
    study = RunDir(sample.parents[3]).study()
    if study.pressure is None:
        raise ValueError(f"{sample}: not a fixed-pressure run")
    stored = stored_columns(sample)
    minima = {}

    def observe(n, p):
        if keep is None or n in keep:
            minima[n] = p

    # a run's checkpoints are restart points of the solver state (``Study.checkpoint_every``):
    # the replay restarts where the run did, or it parts from it at rounding level
    res = shear_at_pressure(prepared_packing(sample), study.dgamma,
                            n_steps=stored["energy_jump"].size - 1 if n_steps is None else n_steps,
                            observer=observe, save_every=study.checkpoint_every or None,
                            **options(study))
    return study, stored, res.trace(), minima


def fresh_release(start, study) -> float:
    """``−r`` of one fixed-pressure step ``δγ`` taken from the minimum ``start`` at its own box
    side (a one-step run has no history to extrapolate)."""
    t = shear_at_pressure(start, study.dgamma, n_steps=1, **options(study)).trace()
    return -(float(t.energy_jump[1]) - 0.5 * study.dgamma * float(t.stress_jump[1]))


def fine_steps(start, study, substeps: int):
    """The two steps ``δγ`` after the minimum ``start`` redone in ``2 substeps`` steps of
    ``δγ/substeps``: ``(S, counted)`` per substep, ``S = −ΔH``, ``counted`` by the report's rule
    (:func:`jamlab.analysis.classify_steps`)."""
    t = shear_at_pressure(start, study.dgamma / substeps, n_steps=2 * substeps,
                          **options(study)).trace()
    dh = np.asarray(t.energy_jump)[1:]
    return -dh, classify_steps(dh, np.asarray(t.plastic)[1:], jammed=np.asarray(t.jammed))


def gaps(counted: np.ndarray) -> str:
    """How the counted substeps lie: ``none``, ``one``, ``adjacent`` (all in one run of
    consecutive substeps) or ``separated`` (an elastic substep between two of them)."""
    k = np.flatnonzero(counted)
    if k.size == 0:
        return "none"
    if k.size == 1:
        return "one"
    return "adjacent" if np.all(np.diff(k) == 1) else "separated"


def probe_pairs(samples: list[Path], above: float, substeps: int) -> None:
    """The ``--pairs`` probe (module docstring), printed."""
    verdicts: dict[str, int] = {}
    print("sample, step k of the first, the run's S at k and k + 1 (ε); the replay's counted "
          "substeps (index from 1, k's step is 1 … m): S; the replay's Σ(−ΔH) against the run's")
    for sample in samples:
        stored = stored_columns(sample)
        dh = stored["energy_jump"]
        hit, firsts = pair_steps(stored, above)
        if not firsts:
            print(f"{sample.name}: no pair ≥ {above:.0e}", flush=True)
            continue
        t0 = time.process_time()
        study, _, trace, minima = replay(sample, n_steps=max(max(firsts) - 1, 1),
                                         keep={k - 1 for k in firsts})
        n = np.asarray(trace.energy_jump).size
        same = np.array_equal(np.asarray(trace.energy_jump)[1:], dh[1:n])
        print(f"{sample.name}: replay to step {n - 1} "
              f"{time.process_time() - t0:.0f} CPU s, "
              f"{verdict(sample, same)}",
              flush=True)
        for k in firsts:
            size, hits = fine_steps(minima[k - 1], study, substeps)
            v = gaps(hits)
            verdicts[v] = verdicts.get(v, 0) + 1
            rows = ", ".join(f"{j + 1}: {size[j]:.2e}" for j in np.flatnonzero(hits))
            print(f"  {sample.name} {k:5d} {-dh[k]:.2e} {-dh[k + 1]:.2e} | {rows or '—'} | "
                  f"{size.sum():.3e} against {-dh[k] - dh[k + 1]:.3e} ({v})", flush=True)
    print("\nthe pairs by how the replay's releases lie: "
          + ", ".join(f"{v} {n}" for v, n in sorted(verdicts.items())))


def nonaffine(before, after) -> np.ndarray:
    """The non-affine displacement ``(N, d)`` from minimum ``before`` to minimum ``after`` of one
    fixed-pressure run: ``x_after − λ (x_before + δγ y_before e_x)`` with ``λ = L_after /
    L_before`` and ``δγ`` the strain between them (the affine map of a step,
    ``state.affine_shear`` then ``barostat.rescale_box``), in ``after``'s minimum image (so
    wraps between the two minima do not count)."""
    pos = np.array(before.positions, dtype=np.float64)
    pos[:, 0] += (after.strain - before.strain) * pos[:, 1]
    pos *= after.box.length / before.box.length
    return after.box.minimum_image(np.asarray(after.positions) - pos)


def weights(u: np.ndarray) -> np.ndarray:
    """Each particle's share ``|u_i|² / Σ_j |u_j|²`` of a displacement field."""
    sq = np.einsum("ij,ij->i", u, u)
    return sq / sq.sum()


def shared_weight(u: np.ndarray, v: np.ndarray) -> float:
    """``Σ_i min(w_i(u), w_i(v))`` (:func:`weights`): 1 when two displacement fields move the
    same particles in the same proportions, ≈ 0 when they move different particles."""
    return float(np.minimum(weights(u), weights(v)).sum())


def cosine(u: np.ndarray, v: np.ndarray) -> float:
    """``u · v / (|u| |v|)`` over all particles and components: > 0 when ``v`` goes on the way
    ``u`` went, < 0 when it goes back."""
    return float(np.sum(u * v) / np.sqrt(np.sum(u * u) * np.sum(v * v)))


def centre_distance(u: np.ndarray, v: np.ndarray, at) -> float:
    """The distance (minimum image of packing ``at``) between the particles that move most in
    ``u`` and in ``v``, in particle diameters."""
    i, j = int(np.argmax(weights(u))), int(np.argmax(weights(v)))
    d = at.box.minimum_image(np.asarray(at.positions)[i] - np.asarray(at.positions)[j])
    return float(np.linalg.norm(d))


def elastic_before(plastic: np.ndarray, step: int) -> int:
    """The last step before trace step ``step`` that the run did not flag plastic (0: none)."""
    e = step - 1
    while e >= 1 and plastic[e]:
        e -= 1
    return e


def backbone(minima: dict, steps) -> np.ndarray:
    """The particles in the backbone (``contacts.remove_rattlers``) of every minimum in
    ``steps``."""
    return np.logical_and.reduce([remove_rattlers(minima[k]).mask for k in steps])


def step_parts(minima: dict, step: int, ref: int) -> tuple[np.ndarray, np.ndarray]:
    """The non-affine displacement of trace step ``step`` (minimum ``step − 1`` to ``step``) and
    that of the elastic step ``ref`` (the same δγ), both zero on the rattlers (outside the
    :func:`backbone` of any of the four minima), whose moves in their cages are not the
    backbone's rearrangement."""
    keep = backbone(minima, {step - 1, step, ref - 1, ref})
    raw = nonaffine(minima[step - 1], minima[step])
    elastic = nonaffine(minima[ref - 1], minima[ref])
    raw[~keep] = 0.0
    elastic[~keep] = 0.0
    return raw, elastic


def event_field(minima: dict, step: int, ref: int) -> np.ndarray:
    """The plastic displacement of trace step ``step``: its non-affine displacement less that
    of the elastic step ``ref``, which removes the branch's own smooth non-affine motion to
    first order; rattlers left out (:func:`step_parts`)."""
    raw, elastic = step_parts(minima, step, ref)
    return raw - elastic


def where_pairs(samples: list[Path], above: float, lag_min: int) -> None:
    """The ``--where`` probe (module docstring), printed."""
    from scipy import stats

    close: dict[str, list[tuple[float, float, float, float]]] = {"consecutive": [], "near": [],
                                                           "far": []}
    print("sample, steps of the two events, their S (ε), participation ratios, shared weight, "
          "cosine (signed), distance of the most-moving particles (d), elastic share of the first")
    for sample in samples:
        stored = stored_columns(sample)
        dh, plastic = stored["energy_jump"], stored["plastic"]
        hit, firsts = pair_steps(stored, above)
        if not firsts:
            print(f"{sample.name}: no pair ≥ {above:.0e}", flush=True)
            continue
        end = max(firsts) + 1
        events = [int(b) + 1 for b in np.flatnonzero(hit) if b + 1 <= end]
        far = [(a, b) for a in events for b in events if b - a >= lag_min]
        near = [(a, b) for a in events for b in events if 2 <= b - a < lag_min]
        pairs = ([("consecutive", k, k + 1) for k in firsts] + [("near", a, b) for a, b in near]
                 + [("far", a, b) for a, b in far])
        refs = {j: elastic_before(plastic, j) for _, a, b in pairs for j in (a, b)}
        need = set()
        for j, e in refs.items():
            if e < 1:
                raise ValueError(f"{sample}: no elastic step before step {j}")
            need |= {j - 1, j, e - 1, e}
        t0 = time.process_time()
        _, _, trace, minima = replay(sample, n_steps=end, keep=need)
        n = np.asarray(trace.energy_jump).size
        same = np.array_equal(np.asarray(trace.energy_jump)[1:], dh[1:n])
        print(f"{sample.name}: replay to step {n - 1} {time.process_time() - t0:.0f} CPU s, "
              f"{verdict(sample, same)}; "
              f"{len(firsts)} consecutive pairs, {len(near)} 2 – {lag_min - 1} steps apart, "
              f"{len(far)} ≥ {lag_min} steps apart",
              flush=True)
        parts = {j: step_parts(minima, j, e) for j, e in refs.items()}
        fields = {j: raw - elastic for j, (raw, elastic) in parts.items()}
        for kind, a, b in pairs:
            u, v = fields[a], fields[b]
            cos = cosine(u, v)
            row = (shared_weight(u, v), abs(cos), centre_distance(u, v, minima[b]), cos)
            close[kind].append(row)
            if kind == "consecutive":
                raw, elastic = parts[a]
                print(f"  {sample.name} {a:5d} {b:5d} {-dh[a]:.2e} {-dh[b]:.2e} "
                      f"{participation_ratio(u):.3f} {participation_ratio(v):.3f} "
                      f"{row[0]:.3f} {row[3]:+.3f} {row[2]:6.2f} "
                      f"{np.sum(elastic * elastic) / np.sum(raw * raw):.1e}", flush=True)
    print("\nthe two events of a pair: median [quartiles] of each measure; consecutive pairs, "
          f"pairs 2 – {lag_min - 1} steps apart (near) and ≥ {lag_min} apart (far) in the same "
          "samples; two-sided Mann–Whitney p of consecutive against far")
    for m, name in enumerate(("shared weight", "|cosine|", "distance (d)")):
        c, n, f = (np.array([r[m] for r in close[k]]) for k in ("consecutive", "near", "far"))
        if c.size == 0 or f.size == 0:
            print(f"  {name}: too few pairs")
            continue
        p = float(stats.mannwhitneyu(c, f, alternative="two-sided").pvalue)
        text = [f"{np.median(x):.3g} [{np.percentile(x, 25):.3g}, {np.percentile(x, 75):.3g}] "
                f"({x.size})" if x.size else "none" for x in (c, n, f)]
        print(f"  {name}: consecutive {text[0]}, near {text[1]}, far {text[2]}, p {p:.2g}")
    ahead = {k: (sum(r[3] > 0.0 for r in v), len(v)) for k, v in close.items()}
    print("  the second goes on the way the first went (cosine > 0): "
          + ", ".join(f"{k} {a} of {b}" for k, (a, b) in ahead.items()))
    same = {k: (sum(r[2] == 0.0 for r in v), len(v)) for k, v in close.items()}
    print("  the same particle moves most in both: "
          + ", ".join(f"{k} {a} of {b}" for k, (a, b) in same.items()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("samples", type=Path, nargs="+")
    ap.add_argument("--above", type=float, default=1e-10, help="avalanches probed: S ≥ (ε)")
    ap.add_argument("--event", type=float, default=1e-11,
                    help="the fresh step releases: −r > (ε)")
    ap.add_argument("--pairs", action="store_true",
                    help="probe the pairs of avalanches at consecutive steps instead")
    ap.add_argument("--where", action="store_true",
                    help="where the two events of each consecutive pair happen, against pairs "
                         "of events far apart")
    ap.add_argument("--lag-min", type=int, default=20,
                    help="with --where: the far pairs are at least this many steps apart")
    ap.add_argument("--substeps", type=int, default=10,
                    help="with --pairs: each step redone in this many substeps")
    a = ap.parse_args()
    if a.above <= 0 or a.event <= 0:
        ap.error("--above and --event must be > 0")
    if a.substeps < 1:
        ap.error("--substeps must be >= 1")
    for s in a.samples:
        if not s.is_file():
            ap.error(f"no sample file {s}")
    if a.lag_min < 2:
        ap.error("--lag-min must be >= 2")
    if a.pairs and a.where:
        ap.error("--pairs and --where are two probes: give one")
    if a.pairs:
        probe_pairs(a.samples, a.above, a.substeps)
        return
    if a.where:
        where_pairs(a.samples, a.above, a.lag_min)
        return
    table = np.zeros((2, 2), dtype=int)  # [run's next step counted][fresh step releases]
    rows = []
    for sample in a.samples:
        t0 = time.process_time()
        study, stored, trace, minima = replay(sample)
        dh = np.asarray(trace.energy_jump)
        same = np.array_equal(dh[1:], stored["energy_jump"][1:]) and np.array_equal(
            np.asarray(trace.plastic), stored["plastic"])
        counted = classify_steps(dh[1:], np.asarray(trace.plastic)[1:],
                                 jammed=np.asarray(trace.jammed))
        size = -dh[1:]
        ends = [k + 1 for k in np.flatnonzero(counted & (size >= a.above)) if k + 1 < size.size]
        print(f"{sample.name}: replay {time.process_time() - t0:.0f} CPU s "
              f"(volume_guess {study.volume_guess}), "
              f"{verdict(sample, same)};"
              f" {len(ends)} avalanches ≥ {a.above:.0e}", flush=True)
        for k in ends:
            fresh = fresh_release(minima[k], study)
            nxt = float(size[k]) if counted[k] else 0.0
            table[int(counted[k]), int(fresh > a.event)] += 1
            rows.append((sample.name, k, float(size[k - 1]), nxt, fresh))
    print(f"\nthe step after {table.sum()} avalanches ≥ {a.above:.0e} ε:\n")
    print("| the run's next step | fresh step releases | fresh step elastic |\n|---|---|---|")
    for i, label in ((1, "an avalanche"), (0, "no avalanche")):
        print(f"| {label} | {table[i, 1]} | {table[i, 0]} |")
    print("\nsample, step k of the avalanche, its S, the run's next S (0: none), the fresh −r")
    for r in rows:
        if r[3] > 0 or r[4] > a.event:
            print(f"  {r[0]} {r[1]:5d} {r[2]:.2e} {r[3]:.2e} {r[4]:.2e}")


if __name__ == "__main__":
    main()
