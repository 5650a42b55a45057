"""The located confirmation's candidates where the chain's own pieces ran: the verdict now (final
inside :func:`jamlab.spheres.confirm.jump_located`) against the rule before (the whole chain run
again by the caller), candidate by candidate, with their CPU time (``docs/aqs.md``, "The located
confirmation finishes the chain it started").

For each packing of ``benchmarks/bench_pressure.py``'s cache (``jam(N, 3, seed, p_target=min(p,
1e-4))`` brought to ``p``; made there if missing), ``shear_at_pressure`` with the defaults. Where
``jump_located`` computed pieces itself (the post-event branch did not reach back to the located
piece), the whole chain :func:`jamlab.spheres.confirm.jump_in_chain` is run as well on the same
candidate, as the caller did before; the verdict of the rule before is the located part's
``True`` where it reached one before the pieces that precede the located one ran, else the whole
chain's. The extra chain runs after the new verdict is taken; its pieces add to the rows'
iterations (the run's flags are the default run's, its iterations and time are not).

    PYTHONPATH=src python scripts/located_rest_check.py --n 1000 --pressure 1e-4 --steps 200 \
        --seeds 1 2 3 --cache CACHE
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from pathlib import Path

import jamlab.spheres.pressure_shear as ps
from jamlab.spheres.confirm import jump_in_chain

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_pressure.py"
LOCATED = ps.jump_located  # the function itself (each packing's run wraps it afresh)


def instrument(rows: list[dict]) -> None:
    """Wrap the located verdict as the pressure driver calls it (module docstring)."""

    def checked(probe, advance, start, v0, s0, end, v1, s1, step, r, k, share=0.25):
        # CPU time by part: the probes, the located piece (the first advance), the pieces after
        # it, and those before it (later advances from ``start`` itself, and the chain from there)
        spent = {"probes": 0.0, "located piece": 0.0, "after": 0.0, "first": 0.0}
        calls = [0]

        def timed_probe(packing, dh):
            t = time.process_time()
            out = probe(packing, dh)
            spent["probes"] += time.process_time() - t
            return out

        def watched(packing, dh):
            calls[0] += 1
            if calls[0] == 1:
                part = "located piece"
            elif packing is start or spent["first"] > 0:
                part = "first"
            else:
                part = "after"
            t = time.process_time()
            out = advance(packing, dh)
            spent[part] += time.process_time() - t
            return out

        jump, pieces = LOCATED(timed_probe, watched, start, v0, s0, end, v1, s1, step, r, k, share)
        if pieces == 0:
            return jump, pieces
        t = time.process_time()
        chain, _ = jump_in_chain(advance, start, v0, s0, step, r, k, share, v_end=v1)
        t_chain = time.process_time() - t
        ran_before = spent["first"] > 0
        before = True if (jump and not ran_before) else chain
        rows.append({"now": bool(jump), "before": bool(before), "pieces": pieces,
                     "first_pieces_ran": ran_before, **spent, "t_chain": t_chain})
        return jump, pieces

    ps.jump_located = checked


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--pressure", type=float, required=True)
    ap.add_argument("--dgamma", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--cache", type=Path, default=Path("bench_pressure_cache"))
    a = ap.parse_args(argv)
    spec = importlib.util.spec_from_file_location("bench_pressure", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    total: list[dict] = []
    for seed in a.seeds:
        packing = bench.start(a.n, a.pressure, seed, a.cache)
        rows: list[dict] = []
        instrument(rows)
        t = time.process_time()
        res = ps.shear_at_pressure(packing, a.dgamma, pressure=a.pressure, n_steps=a.steps)
        cpu = time.process_time() - t
        extra = sum(x["t_chain"] for x in rows)
        print(f"N={a.n} p={a.pressure:g} seed={seed}: {a.steps} steps, "
              f"{int(res['plastic'].sum())} plastic, {res.attrs['n_candidates']} candidates, "
              f"{len(rows)} with the chain's pieces run inside the located verdict; run "
              f"{cpu - extra:.1f} CPU s without the check's chains", flush=True)
        for x in rows:
            print(f"   now {x['now']!s:5} before {x['before']!s:5} pieces {x['pieces']:2d}; CPU s: "
                  f"probes {x['probes']:.2f}, located piece {x['located piece']:.2f}, after it "
                  f"{x['after']:.2f}, before it {x['first']:.2f}; the whole chain the rule "
                  f"before added {x['t_chain']:.2f}")
        total += rows
    same = sum(x["now"] == x["before"] for x in total)
    # the rule before ran the whole chain where the located part did not show a jump
    saved = sum(x["t_chain"] - x["first"] for x in total
                if x["first_pieces_ran"] or not x["now"])
    ran = sum(x["first_pieces_ran"] for x in total)
    print(f"\n{len(total)} candidates: the same verdict in {same}; {ran} "
          f"ran the pieces before the located one. CPU saved (the whole chain the rule before "
          f"ran, less the pieces before the located one): {saved:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
