"""What the plastic flag's confirmation costs at fixed pressure, and the located verdict against
the chain (``docs/aqs.md``, "Fixed pressure: the jump decided on its own piece").

``chains``: one run per seed with ``confirm="continued"``; per redone candidate the chain's
verdict (J jump, K kink), its pieces' CPU ms (``F``: the relaxer gave the piece to FIRE) and
the totals: CPU s of the run, of FIRE anywhere, of the chains, and of the jump chains' pieces
before the jump and of the jump piece itself (and its FIRE).

``compare``: the same packings sheared with ``confirm="continued"`` and ``"located"`` (the
deferred redoing runs after the last step, so the rows must be identical); per seed the
plastic flags, the steps where they differ, the located decisions, CPU s of the runs and of the
confirmation.

``flips``: for every step where the two flags differ, the residual of each of the chain's 16
pieces relative to the step's ``|r_H|`` and ``H`` at the chain's end minus the single step's.

    PYTHONPATH=src python scripts/confirm_costs.py chains --n 1000 --seeds 1 --steps 100
    PYTHONPATH=src python scripts/confirm_costs.py compare --n 1000 --seeds 1 2 --steps 100
    PYTHONPATH=src python scripts/confirm_costs.py flips --n 250 --seeds 1 --steps 200
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import jamlab.spheres.barostat as barostat
import jamlab.spheres.newton_relax as newton_relax
import jamlab.spheres.pressure_shear as ps
from jamlab.spheres.confirm import trapezoid_residual
from jamlab.spheres.fire import minimize
from jamlab.spheres.packing import jam
from jamlab.spheres.potential import evaluate


def packing(n: int, pressure: float, seed: int):
    return jam(n, 3, seed=seed, p_target=pressure).packing


def chains(a) -> None:
    pieces: list = []
    fire_s = [0.0]

    def timed_minimize(*args, **kw):
        t = time.process_time()
        out = minimize(*args, **kw)
        fire_s[0] += time.process_time() - t
        return out

    barostat.minimize = newton_relax.minimize = timed_minimize
    advance, chain = ps._advance, ps.jump_in_chain

    def spy_advance(pressure, kw, slope):
        inner, relaxer = advance(pressure, kw, slope), kw.get("relax")

        def piece(cur, dh):
            before = relaxer.counters["n_fire_fallbacks"] if relaxer is not None else 0
            f0, t = fire_s[0], time.process_time()
            out = inner(cur, dh)
            fell = relaxer is not None and relaxer.counters["n_fire_fallbacks"] > before
            pieces[-1][1].append((time.process_time() - t, fire_s[0] - f0, fell))
            return out

        return piece

    def spy_chain(*args, **kw):
        pieces.append([None, []])
        out = chain(*args, **kw)
        pieces[-1][0] = out[0]
        return out

    ps._advance, ps.jump_in_chain = spy_advance, spy_chain
    for seed in a.seeds:
        pk = packing(a.n, a.pressure, seed)
        pieces.clear()
        fire_s[0] = 0.0
        t = time.process_time()
        ps.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                             confirm="continued")
        t = time.process_time() - t
        total = sum(x[0] for _, pc in pieces for x in pc)
        in_chains = sum(x[1] for _, pc in pieces for x in pc)
        before = sum(x[0] for v, pc in pieces if v for x in pc[:-1])
        last = sum(pc[-1][0] for v, pc in pieces if v)
        last_fire = sum(pc[-1][1] for v, pc in pieces if v)
        print(f"seed {seed}: run {t:.1f} CPU s, FIRE anywhere {fire_s[0]:.1f} s; "
              f"{len(pieces)} chains ({sum(bool(v) for v, _ in pieces)} jumps) {total:.1f} s, "
              f"their FIRE {in_chains:.1f} s; jump chains: pieces before the jump {before:.1f} s, "
              f"the jump piece {last:.1f} s (its FIRE {last_fire:.1f} s)")
        for v, pc in pieces:
            print("   ", "J" if v else "K", f"{len(pc):2d} pieces (ms):",
                  " ".join(f"{1e3 * x[0]:.0f}{'F' if x[2] else ''}" for x in pc))


def compare(a) -> None:
    confirm = ps._confirm
    spent = [0.0]

    def timed(*args, **kw):
        t = time.process_time()
        confirm(*args, **kw)
        spent[0] += time.process_time() - t

    ps._confirm = timed
    totals = {m: [0.0, 0.0, 0] for m in ("continued", "located")}
    differ = 0
    for seed in a.seeds:
        pk = packing(a.n, a.pressure, seed)
        runs = {}
        for m in ("continued", "located"):
            spent[0] = 0.0
            t = time.process_time()
            runs[m] = ps.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                                           confirm=m)
            totals[m][0] += time.process_time() - t
            totals[m][1] += spent[0]
            totals[m][2] += int(runs[m]["plastic"].sum())
            runs[m] = (runs[m], time.process_time() - t, spent[0])
        (c, tc, sc), (loc, tl, sl) = runs["continued"], runs["located"]
        same = all(np.array_equal(c[k], loc[k]) for k in ("enthalpy", "shear_stress",
                                                          "box_length"))
        d = np.flatnonzero(c["plastic"] != loc["plastic"])
        differ += d.size
        print(f"seed {seed}: rows identical {same}; plastic continued {int(c['plastic'].sum())}"
              f", located {int(loc['plastic'].sum())}, differ at {d.tolist()}; located "
              f"decisions {loc.attrs['n_candidates_located']}; CPU s {tc:.1f} / {tl:.1f}, "
              f"confirmation {sc:.1f} / {sl:.1f}", flush=True)
    (tc, sc, pc), (tl, sl, pl) = totals["continued"], totals["located"]
    print(f"all: CPU s continued {tc:.1f}, located {tl:.1f} (ratio {tc / tl:.2f}); "
          f"confirmation {sc:.1f} / {sl:.1f} s; plastic {pc} / {pl}; flags differ at {differ}")


def flips(a) -> None:
    kept: dict = {}
    confirm = ps._confirm

    def spy(pending, rows, confirmed, pressure, kw, *rest):
        for c in pending:
            kept[c[0]] = (c, kw, pressure)
        confirm(pending, rows, confirmed, pressure, kw, *rest)

    ps._confirm = spy
    for seed in a.seeds:
        pk = packing(a.n, a.pressure, seed)
        kept.clear()
        c = ps.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                                 confirm="continued")
        loc = ps.shear_at_pressure(pk, a.dgamma, pressure=a.pressure, n_steps=a.steps,
                                   confirm="located")
        for n in np.flatnonzero(c["plastic"] != loc["plastic"]):
            (_, start, slope, step, r, end), kw, pressure = kept[n]
            ev = evaluate(start)
            v, s = ev.energy + pressure * start.box.volume, ev.shear_stress
            advance, cur, res = ps._advance(pressure, kw, slope), start, []
            for _ in range(a.pieces):
                cur, v2, s2, _ = advance(cur, step / a.pieces)
                res.append(trapezoid_residual(v, s, v2, s2, step / a.pieces))
                v, s = v2, s2
            e1 = evaluate(end)
            print(f"seed {seed} row {n}: continued {bool(c['plastic'][n])}, located "
                  f"{bool(loc['plastic'][n])}; r_H = {r:.3e}; pieces r/|r_H|: "
                  + " ".join(f"{x / abs(r):+.2f}" for x in res)
                  + f"; H(chain end) - H(single step) = "
                  f"{v - (e1.energy + pressure * end.box.volume):+.3e}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=("chains", "compare", "flips"))
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--pieces", type=int, default=16)
    a = ap.parse_args()
    {"chains": chains, "compare": compare, "flips": flips}[a.what](a)


if __name__ == "__main__":
    main()
