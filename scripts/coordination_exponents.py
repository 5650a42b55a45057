"""φ_J over seeds and the exponents of z_nr − z_iso and p against φ − φ_J, averaged over seeds.

    python scripts/coordination_exponents.py --n 256 --seeds 1 2 3 4 [--steps 30] [--no-curve]

Prints, per seed, φ_J, p, rattlers, minimisations and time, then mean ± standard deviation of φ_J
and (unless --no-curve) the fitted a (z_nr − z_iso and z_nr − 2d) and b (p) over
φ − φ_J ∈ [1e-4, 1e-1], mean ± standard error over seeds.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from jamlab.spheres.packing import coordination_curve, fit_power_law, jam


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--no-curve", action="store_true")
    args = ap.parse_args()
    phis, a_iso, a_2d, b, cpus = [], [], [], [], []
    curves = []
    for seed in args.seeds:
        t = time.process_time()
        res = jam(args.n, args.dim, seed)
        s = res.state
        print(
            f"seed {seed}: phi_J={res.phi_j:.6f} p={s.pressure:.3e} ok={res.ok} "
            f"rattlers={s.n_rattlers} minimisations={res.n_minimizations} "
            f"cpu={time.process_time() - t:.1f}s {res.reason}",
            flush=True,
        )
        if not res.ok:
            continue
        phis.append(res.phi_j)
        cpus.append(time.process_time() - t)
        if args.no_curve:
            continue
        c = coordination_curve(res.packing, res.phi_j, steps=args.steps)
        curves.append(c)
        a_iso.append(fit_power_law(c.dphi, c.z_nr - c.z_iso)[0])
        a_2d.append(fit_power_law(c.dphi, c.z_nr - 2 * args.dim)[0])
        b.append(fit_power_law(c.dphi, c.pressure)[0])
        print(
            f"   a(z_nr-z_iso)={a_iso[-1]:.4f} a(z_nr-2d)={a_2d[-1]:.4f} b={b[-1]:.4f}", flush=True
        )
    phis = np.array(phis)
    print(
        f"N={args.n} d={args.dim}: phi_J = {phis.mean():.5f} ± {phis.std(ddof=1):.5f} (std), "
        f"range [{phis.min():.5f}, {phis.max():.5f}], {len(phis)} seeds"
    )
    print(f"CPU to jam: mean {np.mean(cpus):.1f} s, max {np.max(cpus):.1f} s")
    for name, v in (("a (z_nr - z_iso)", a_iso), ("a (z_nr - 2d)", a_2d), ("b (p)", b)):
        if len(v) > 1:
            v = np.array(v)
            print(f"{name} = {v.mean():.4f} ± {v.std(ddof=1) / np.sqrt(len(v)):.4f} (s.e.)")
    if len(curves) > 1:
        # the ensemble-averaged curve (mean over seeds at each Δφ), then one fit
        dphi = curves[0].dphi
        mean = {
            "z_nr - z_iso": np.mean([c.z_nr - c.z_iso for c in curves], axis=0),
            "z_nr - 2d": np.mean([c.z_nr for c in curves], axis=0) - 2 * args.dim,
            "p": np.mean([c.pressure for c in curves], axis=0),
        }
        for name, y in mean.items():
            for lo, hi in ((1e-4, 1e-1), (1e-4, 1e-2), (1e-3, 1e-1)):
                e, se, _ = fit_power_law(dphi, y, lo, hi)
                print(f"ensemble-mean {name}: exponent {e:.4f} ± {se:.4f} (fit) on [{lo}, {hi}]")


if __name__ == "__main__":
    main()
