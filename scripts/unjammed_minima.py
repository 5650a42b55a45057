"""What the unjammed minima of a fixed-pressure run are (issue 18, p = 1e-6).

A fixed-pressure run keeps the box at the target pressure, yet a few of its minima fail the
jammed flag (``rigidity.is_jammed``): one contact short of isostatic. For every minimum a run's
``jammed`` column marks as unjammed this script replays the sample from its prepared packing
(``runs.load.prepared_packing``) as the run did (one ``shear_at_pressure`` with the run's
options up to the last such step, keeping the minima wanted through its ``observer``), checks
that the replayed minimum is the recorded one (enthalpy, pressure and φ of row ``k``), and
reports:

- the flag's own numbers (backbone size, contacts against the isostatic count, pressure);
- the smallest gaps ``h = r_ij − σ_ij > 0`` between backbone particles that are not in contact,
  against the mean contact overlap (a pair far nearer than the overlaps is a contact at touching,
  one whose force is below the resolution), and whether that pair was a contact one step before;
- the smallest singular value ``s_min`` of the backbone's compatibility matrix: a network with
  fewer contacts than ``d (N' − 1)`` that carries a pressure balances its forces only through an
  almost-degenerate geometry, ``s_min |f| ≲ √N' ftol``;
- the lowest eigenvalues of the backbone Hessian (dense), of the minimum and of the one before:
  a resolved negative one (below ``−NEGATIVE_CURVATURE λ_max``, the rule of
  ``jamlab.spheres.aqs.saddle``) makes the recorded minimum a saddle;
- whether the run's own saddle test (``saddle.saddle_push`` on the pinned backbone Hessian,
  rattlers held as fixed spring ends: what ``barostat.leave_saddle`` decides) finds it;
- the contacts lost and gained from the minimum before.

On a run made after the fixed-pressure saddle test (``barostat.leave_saddle``) the
minima left unjammed are those the run's test does not call saddles.

Usage::

    PYTHONPATH=src python scripts/unjammed_minima.py RUN_DIR [--n N] [--max-samples M]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

from jamlab.runs.load import prepared_packing
from jamlab.runs.storage import RunDir
from jamlab.spheres.aqs.linalg import backbone_matrix, factorise
from jamlab.spheres.aqs.record import observe
from jamlab.spheres.aqs.saddle import NEGATIVE_CURVATURE, unstable_mode
from jamlab.spheres.contacts import contacts, remove_rattlers
from jamlab.spheres.neighbors import NeighborList
from jamlab.spheres.potential import hessian
from jamlab.spheres.pressure_shear import CONFIRM_BELOW, FROM_AQS_OPTION, shear_at_pressure
from jamlab.spheres.rigidity import is_jammed


def _gaps(packing, keep):
    """Gaps ``r − σ`` of every pair of backbone particles (``keep``), brute force over pairs
    with the box's minimum image (independent of the neighbour list and the kernels)."""
    idx = np.flatnonzero(keep)
    pos = np.asarray(packing.positions)[idx]
    dia = np.asarray(packing.diameters, dtype=np.float64)
    dia = np.broadcast_to(dia, (packing.n,))[idx] if dia.ndim else np.full(len(idx), float(dia))
    i, j = np.triu_indices(len(idx), k=1)
    d = packing.box.minimum_image(pos[i] - pos[j])
    h = np.linalg.norm(d, axis=1) - 0.5 * (dia[i] + dia[j])
    return idx[i], idx[j], h


# the trace's columns (energy is the enthalpy at fixed pressure) and the replay's
COLUMNS = {"energy": "enthalpy", "pressure": "pressure", "phi": "phi"}


def compatibility_min_singular(packing, keep):
    """Smallest singular value ``s_min`` of the backbone's compatibility matrix (rows: contacts
    among the ``keep`` particles, unit vectors ``±n_ij``; columns: their ``d N'`` coordinates),
    and the norm of the contact forces ``|f|`` (``f_ij = (ε/σ_ij)(1 − r_ij/σ_ij)^(α−1)``,
    ε = 1). A minimum with fewer backbone contacts than ``d (N' − 1)`` that carries pressure
    needs a force vector almost in its left null space: ``|Aᵀ f| ≤ √N' ftol`` bounds
    ``s_min |f|``."""
    ci, cj, cd = contacts(packing)
    live = keep[ci] & keep[cj]
    ci, cj, cd = ci[live], cj[live], cd[live]
    kept = np.flatnonzero(keep)
    where = -np.ones(packing.n, dtype=np.int64)
    where[kept] = np.arange(len(kept))
    d = packing.dim
    r = np.linalg.norm(cd, axis=1)
    u = cd / r[:, None]
    a = np.zeros((len(ci), d * len(kept)))
    rows = np.arange(len(ci))
    for ax in range(d):
        a[rows, d * where[ci] + ax] = u[:, ax]
        a[rows, d * where[cj] + ax] = -u[:, ax]
    dia = np.asarray(packing.diameters, dtype=np.float64)
    sig = 0.5 * (dia[ci] + dia[cj])
    f = (1.0 / sig) * (1.0 - r / sig) ** (packing.alpha - 1.0)
    u_, sv, vt = np.linalg.svd(a, full_matrices=False)
    stress = u_[:, -1]  # the near self-stress (over contacts) of the smallest singular value
    mode = vt[-1].reshape(-1, d)  # its floppy mode (over backbone particles)
    weight = np.sort(stress**2)[::-1]
    n_stress = int(np.searchsorted(np.cumsum(weight), 0.9) + 1)
    m2 = (mode**2).sum(axis=1)
    pr_mode = float(m2.sum() ** 2 / (len(m2) * (m2**2).sum()))
    return float(sv[-1]), float(np.linalg.norm(f)), n_stress, pr_mode


def lowest_eigenvalues(packing, keep, count=5):
    """The ``count`` lowest eigenvalues of the Hessian restricted to the backbone's coordinates
    (dense ``eigvalsh``; ``d`` of them are the translations, zero to rounding), and the largest.
    A resolved negative one makes the recorded minimum a saddle that only passed the force
    test."""
    h = hessian(packing, backbone=keep).toarray()
    coords = (packing.dim * np.flatnonzero(keep)[:, None] + np.arange(packing.dim)).ravel()
    w = np.linalg.eigvalsh(h[np.ix_(coords, coords)])
    return w[:count], float(w[-1])


def contact_set(packing):
    ci, cj, _ = contacts(packing)
    return set(zip(ci.tolist(), cj.tolist(), strict=True))


def describe(packing, before, ftol):
    """The unjammed minimum ``packing`` described, beside the minimum ``before`` it (the
    previous step's)."""
    state = is_jammed(packing, ftol)
    keep = remove_rattlers(packing).mask
    i, j, h = _gaps(packing, keep)
    overlap = -h[h < 0]
    open_ = h >= 0
    order = np.argsort(h[open_])
    gi, gj, gaps = i[open_][order], j[open_][order], h[open_][order]
    s_min, f_norm, n_stress, pr_mode = compatibility_min_singular(packing, keep)
    now, then = contact_set(packing), contact_set(before)
    eig, eig_max = lowest_eigenvalues(packing, keep)
    # the verdict of the run's own test (leave_saddle): the pinned backbone Hessian, rattlers
    # held as fixed spring ends
    nl = NeighborList(packing)
    _, held = observe(packing, nl)
    fac = factorise(packing, nl, held)
    # saddle_push's decision, from the primitives it uses (so that the script also runs on
    # source trees from before saddle_push, to describe the runs made with them)
    pinned_saddle = (fac.free.size > 0 and not fac.positive_definite
                     and unstable_mode(backbone_matrix(packing, nl, fac), packing.dim) is not None)
    eig_before, _ = lowest_eigenvalues(before, remove_rattlers(before).mask)
    lost = sorted(then - now)
    nearest = (int(gi[0]), int(gj[0]))
    return {
        "state": state,
        "mean_overlap": float(overlap.mean()),
        "gaps": gaps[:3],
        "nearest_ratio": float(gaps[0] / overlap.mean()),
        "nearest_was_contact": nearest in then,
        "lost": lost,
        "gained": sorted(now - then),
        "s_min": s_min,
        "n_stress": n_stress,
        "eig": eig,
        "eig_max": eig_max,
        "pinned_saddle": pinned_saddle,
        "eig_before": eig_before,
        "pr_mode": pr_mode,
        "balance": s_min * f_norm / (np.sqrt(state.n_backbone) * ftol),
        "before_jammed": bool(is_jammed(before, ftol)),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--n", type=int, default=None)
    ap.add_argument("--max-samples", type=int, default=None)
    ap.add_argument("--touching", type=float, default=1e-2,
                    help="a nearest backbone gap below this fraction of the mean overlap counts "
                         "as a contact at touching (default 1e-2)")
    args = ap.parse_args(argv)
    run = RunDir(args.run)
    study = run.study()
    if study.pressure is None:
        ap.error("a fixed-pressure run is needed (its study has no pressure)")
    files = sorted(args.run.glob("samples/phi=*/N=*/sample-*.h5"))
    if args.n is not None:
        files = [f for f in files if f.parent.name == f"N={args.n}"]
    if not files:
        ap.error(f"no sample files under {args.run}")
    done, rows, n_minima = 0, [], 0
    for f in files:
        with h5py.File(f, "r") as h5:
            jammed = h5["trace/jammed"][()].astype(bool)
            recorded = {name: h5[f"trace/{name}"][()] for name in COLUMNS}
        n_minima += len(jammed)
        bad = np.flatnonzero(~jammed)
        if len(bad) == 0:
            continue
        if args.max_samples is not None and done >= args.max_samples:
            break
        done += 1
        wanted = set(bad.tolist()) | set((bad - 1).tolist())
        minima = {}

        def observe(n, packing, wanted=wanted, minima=minima):
            if n in wanted:
                minima[n] = packing

        # one replay, as the run's (shear(..., pressure=p) without checkpoints) up to the last
        # unjammed step, keeping the minima wanted; its rows are checked against the file's
        res = shear_at_pressure(
            prepared_packing(f), study.dgamma, pressure=study.pressure, n_steps=int(bad.max()),
            ftol=study.force_tol, minimizer=FROM_AQS_OPTION["linear"], confirm="located",
            confirm_below=CONFIRM_BELOW, observer=observe)
        for k in bad:
            if k == 0:
                print(f"{f.parent.name}/{f.stem}: the prepared packing is unjammed")
                continue
            before = minima[k - 1]
            rel = max(abs(np.asarray(res.columns[column])[k] - recorded[name][k])
                      / abs(recorded[name][k]) for name, column in COLUMNS.items())
            d = describe(minima[k], before, study.force_tol)
            s = d["state"]
            print(f"{f.parent.name}/{f.stem} step {k}: replay rel. diff {rel:.1e}; backbone "
                  f"{s.n_backbone}, contacts {s.n_contacts_backbone} vs {s.n_contacts_iso} "
                  f"(excess {s.excess}), p {s.pressure:.3e}; nearest backbone gaps "
                  f"{', '.join(f'{g:.2e}' for g in d['gaps'])} (mean overlap "
                  f"{d['mean_overlap']:.2e}); s_min {d['s_min']:.1e}, s_min|f|/(√N' ftol) "
                  f"{d['balance']:.2f}, its self-stress on {d['n_stress']} contacts (90 %), "
                  f"floppy mode participation {d['pr_mode']:.3f}; saddle by the run's test "
                  f"{d['pinned_saddle']}; lowest Hessian eigenvalues "
                  f"{', '.join(f'{e:.1e}' for e in d['eig'])} (step before: "
                  f"{', '.join(f'{e:.1e}' for e in d['eig_before'])}); from step {k - 1} "
                  f"(jammed {d['before_jammed']}): lost "
                  f"{d['lost']}, gained {d['gained']}", flush=True)
            if rel > 1e-12:
                print("  the replay is not the recorded minimum: not counted", flush=True)
                continue
            rows.append(d)
    if not rows:
        print("no unjammed minimum replayed")
        return 0
    ratio = np.array([r["nearest_ratio"] for r in rows])
    touching = ratio < args.touching
    saddle = np.array([r["eig"][0] < -NEGATIVE_CURVATURE * r["eig_max"] for r in rows])
    print(f"{len(rows)} unjammed minima replayed (of {n_minima} minima in the files read): "
          f"{int(touching.sum())} with a backbone pair nearer than {args.touching:g} × the mean "
          f"overlap to touching (a contact whose force is below the resolution), of which "
          f"{sum(r['nearest_was_contact'] for r, t in zip(rows, touching, strict=True) if t)} were "
          f"in contact "
          f"one step before; the others' nearest gap / mean overlap "
          f"{', '.join(f'{x:.2f}' for x in np.sort(ratio[~touching]))}; s_min |f| / (√N' ftol) "
          f"≤ {max(r['balance'] for r in rows):.2f} in all; previous minimum jammed in "
          f"{sum(r['before_jammed'] for r in rows)}; saddles (lowest backbone Hessian eigenvalue "
          f"below −{NEGATIVE_CURVATURE:g} λ_max): {int(saddle.sum())} of {len(rows)} "
          f"(λ_min from {min(r['eig'][0] for r in rows):.2e} to "
          f"{max(r['eig'][0] for r in rows):.2e}); saddles by the run's own test "
          f"(saddle.saddle_push, rattlers held): {sum(r['pinned_saddle'] for r in rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
