"""Fixed-pressure AQS with the Newton inner minimiser against plain FIRE on many samples.

The same packings (``jam(N, 3, seed)``, brought to ``p`` by one FIRE fixed-pressure step) are
sheared with both minimisers (``--compare minimizer``, the default) or with both confirmations
of the plastic flag (``--compare confirm``: the candidates Newton continued not redone, against
all redone; Newton minimiser), with the located confirmation against it (``--compare
located``: each redone candidate first decided on the piece where the branch ends, by Newton
alone), or with the relaxations' Verlet skin
(:data:`jamlab.spheres.neighbors.RELAX_SKIN`, ``--compare skin``: 0.1 against the earlier 0.2,
which changes only rounding; ``--compare thin-skin``: 0.03 against 0.1), or with the
candidates that surely released enough not redone (``--compare band``: the default
``confirm_below`` against every candidate redone), or with
the backbone factorisation (``--compare factorisation``: CHOLMOD's Cholesky against SuperLU's
``LDLᵀ``, :data:`jamlab.spheres.aqs.linalg.FACTORISATION`; a preconditioner: rounding only), or
with the Newton relaxer's FIRE fallbacks finished by Newton below ``max|F| = 1e-9`` against FIRE
to ``ftol`` (``--compare finish``, :data:`jamlab.spheres.newton_relax.FINISH_BELOW`), or with
the rattlers not freed one at a time moved together and, if still caged, put on the backbone for
one more Newton against FIRE polishing at once (``--compare caged``,
:data:`jamlab.spheres.newton_relax.SETTLE_CAGED`).
Paired comparison per sample (plastic flags equal, the sizes
``S = −ΔH`` of the flagged steps equal) and the pooled statistics (plastic fraction, ``⟨S⟩``,
two-sample KS on the sizes), with the CPU time of each. Prints a markdown table.

    python scripts/newton_vs_fire_pressure.py --n 250 --pressure 1e-3 --seeds 1-40 \
        --steps 50 --dgamma 1e-4 [--compare confirm]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import numpy as np
from scipy.stats import ks_2samp

from jamlab.analysis.powerlaw import fit_power_law
from jamlab.spheres import barostat, newton_relax
from jamlab.spheres.aqs import driver, linalg
from jamlab.spheres.packing import jam
from jamlab.spheres.pressure_shear import CONFIRM_BELOW, shear_at_pressure


def seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


VARIANTS: dict[str, tuple[tuple[str, dict], tuple[str, dict]]] = {
    "minimizer": (("newton", {"minimizer": "newton"}), ("fire", {"minimizer": "fire"})),
    "confirm": (("continued", {"confirm": "continued"}), ("chain", {"confirm": "chain"})),
    "located": (("located", {"confirm": "located"}), ("continued", {"confirm": "continued"})),
    "skin": (("skin 0.1", {}), ("skin 0.2", {})),
    "thin-skin": (("skin 0.03", {}), ("skin 0.1", {})),
    "band": (("band (default)", {"confirm_below": CONFIRM_BELOW}),
             ("all redone", {"confirm_below": math.inf})),
    "factorisation": (("CHOLMOD", {}), ("SuperLU", {})),
    "finish": (("finished by Newton", {}), ("FIRE to ftol", {})),
    "caged": (("caged settled", {}), ("caged by FIRE", {})),
}
"""Per comparison: the variant under test, then the reference (whose sizes choose S_min)."""


def set_relax_skin(skin: float) -> None:
    for module in (driver, barostat, newton_relax):
        module.RELAX_SKIN = skin


def _setter(module, name: str, value) -> Callable[[], None]:
    return lambda: setattr(module, name, value)


SETTINGS: dict[str, Callable[[], None]] = {
    # the relaxations' Verlet skin, in every module that reads it
    "skin 0.1": lambda: set_relax_skin(0.1),
    "skin 0.2": lambda: set_relax_skin(0.2),
    "skin 0.03": lambda: set_relax_skin(0.03),
    # the backbone factorisation (jamlab.spheres.aqs.linalg.FACTORISATION)
    "CHOLMOD": _setter(linalg, "FACTORISATION", "cholmod"),
    "SuperLU": _setter(linalg, "FACTORISATION", "superlu"),
    # how the Newton relaxer's FIRE fallback ends (jamlab.spheres.newton_relax.FINISH_BELOW)
    "finished by Newton": _setter(newton_relax, "FINISH_BELOW", newton_relax.FINISH_BELOW),
    "FIRE to ftol": _setter(newton_relax, "FINISH_BELOW", None),
    # a rattler not freed alone: moved together with the others, then Newton with the caged
    # ones on the backbone, or FIRE polishes at once
    # (jamlab.spheres.newton_relax.SETTLE_CAGED)
    "caged settled": _setter(newton_relax, "SETTLE_CAGED", True),
    "caged by FIRE": _setter(newton_relax, "SETTLE_CAGED", False),
}
"""Variants that are a module-wide setting rather than a keyword of ``shear_at_pressure``: what
sets it, called before each of that variant's runs."""


MIN_TAIL = 50
"""The fewest sizes above ``S_min`` a τ of :func:`print_size_comparison` is fitted from."""


def print_size_comparison(sizes: dict, new: str, ref: str, fit: bool = True) -> None:
    """Print the two-sample KS test of the pooled sizes ``sizes[new]`` against ``sizes[ref]``
    and, with ``fit``, τ of both above the same ``S_min`` (chosen on the reference's sizes by the
    KS rule) and their difference in σ; with fewer than :data:`MIN_TAIL` reference sizes it says
    so instead of fitting. Also used by ``tree_statistics.py``."""
    ks = ks_2samp(sizes[new], sizes[ref])
    print(f"two-sample KS on the sizes: D = {ks.statistic:.3f}, p-value = {ks.pvalue:.3f}")
    if not fit:
        return
    if len(sizes[ref]) < MIN_TAIL:
        print(f"tau not fitted: {len(sizes[ref])} reference sizes, fewer than {MIN_TAIL}")
        return
    # τ: x_min chosen on the reference's sizes (KS rule), the same x_min for both
    chosen = fit_power_law(sizes[ref], min_tail=MIN_TAIL)
    fits = {m: fit_power_law(sizes[m], x_min=chosen.x_min) for m in (new, ref)}
    for m, f in fits.items():
        print(f"tau ({m}) = {f.tau:.3f} ± {f.tau_stderr:.3f} from {f.n_tail} sizes above "
              f"S_min = {f.x_min:.3g}")
    d = abs(fits[new].tau - fits[ref].tau)
    sig = float(np.hypot(fits[new].tau_stderr, fits[ref].tau_stderr))
    print(f"difference {d:.3f} = {d / sig:.2f} sigma (independent-error sigma; the samples "
          "are the same packings, so this overstates the noise of a difference)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--pressure", type=float, default=1e-3)
    ap.add_argument("--seeds", type=seeds, default=seeds("1-40"))
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--dgamma", type=float, default=1e-4)
    ap.add_argument("--compare", choices=sorted(VARIANTS), default="minimizer")
    ap.add_argument("--save", default=None, help="write the pooled sizes (npz)")
    a = ap.parse_args()
    (new, new_kw), (ref, ref_kw) = VARIANTS[a.compare]
    options = {new: new_kw, ref: ref_kw}
    sizes = {new: [], ref: []}
    flags = {new: 0, ref: 0}
    steps = {new: 0, ref: 0}
    cpu = {new: 0.0, ref: 0.0}
    candidates = {new: 0, ref: 0}
    same_flags = same_sizes = used = 0
    worst = 0.0
    for seed in a.seeds:
        r = jam(a.n, 3, seed=seed, p_target=min(a.pressure, 1e-4))
        first = shear_at_pressure(r.packing, 1e-6, pressure=a.pressure, n_steps=1,
                                  minimizer="fire")
        if not (first["converged"].all() and first["jammed"].all()):
            print(f"seed {seed}: no jammed minimum at p={a.pressure:g}, skipped")
            continue
        used += 1
        runs = {}
        for m in (new, ref):
            if m in SETTINGS:
                SETTINGS[m]()
            t = time.process_time()
            runs[m] = res = shear_at_pressure(first.packing, a.dgamma, pressure=a.pressure,
                                              n_steps=a.steps, **options[m])
            cpu[m] += time.process_time() - t
            candidates[m] += int(res.attrs["n_candidates"])
            tr = res.trace()
            ok = tr.jammed[1:] & tr.jammed[:-1]
            plastic = res["plastic"][1:]
            sizes[m].extend((-res["enthalpy_jump"][1:][plastic]).tolist())
            flags[m] += int(plastic.sum())
            steps[m] += int(ok.sum())
        pn, pf = runs[new]["plastic"], runs[ref]["plastic"]
        if np.array_equal(pn, pf):
            same_flags += 1
            sn = -runs[new]["enthalpy_jump"][pn]
            sf = -runs[ref]["enthalpy_jump"][pf]
            if sn.size:
                d = float(np.max(np.abs(sn - sf) / np.abs(sf)))
                worst = max(worst, d)
            same_sizes += int(sn.size == 0 or d < 1e-6)
        print(f"seed {seed}: plastic {new} {int(pn.sum())} {ref} {int(pf.sum())}"
              + ("" if np.array_equal(pn, pf) else
                 f" (differ at steps {np.flatnonzero(pn != pf).tolist()})"), flush=True)
    both = bool(sizes[ref]) and bool(sizes[new])  # (lists here)
    print(f"\nN={a.n}, p={a.pressure:g}, δγ={a.dgamma:g}, {a.steps} steps, {used} samples\n")
    print(f"| | {new} | {ref} |\n|---|---|---|")
    print(f"| plastic steps / jammed steps | {flags[new]} / {steps[new]} | "
          f"{flags[ref]} / {steps[ref]} |")
    print(f"| candidate steps (abs r_H > 0.1 δγ²) | {candidates[new]} | {candidates[ref]} |")
    for m in (new, ref):
        s = np.asarray(sizes[m])
        sizes[m] = s
    mean = {m: (np.mean(sizes[m]), np.std(sizes[m]) / np.sqrt(max(1, sizes[m].size)))
            for m in sizes}
    print(f"| ⟨S⟩ | {mean[new][0]:.4e} ± {mean[new][1]:.1e} | "
          f"{mean[ref][0]:.4e} ± {mean[ref][1]:.1e} |")
    print(f"| CPU s per sample | {cpu[new] / used:.2f} | {cpu[ref] / used:.2f} |")
    print(f"\nCPU time {ref} / {new}: {cpu[ref] / cpu[new]:.2f}")
    print(f"\nsamples with identical plastic flags: {same_flags} / {used}; with identical sizes "
          f"(relative 1e-6): {same_sizes} / {used} (largest relative size difference {worst:.1e})")
    if both:
        print_size_comparison(sizes, new, ref)
    if a.save is not None:
        np.savez(a.save, **{f"sizes_{m}": np.asarray(v) for m, v in sizes.items()})


if __name__ == "__main__":
    main()
