"""Constant-volume AQS statistics of two source trees on the same packings (a change that must
not change the physics: same flags, or the same statistics where rounding picks other minima).

``run`` shears ``jam(N, 3, seed, p_target)`` packings at constant volume with the default path
(or ``--minimizer fire``) under the jamlab on ``PYTHONPATH`` (``--src TREE`` runs itself in a
subprocess with ``PYTHONPATH=TREE``) and saves per sample the plastic flags, the ``jammed``
flags, the energy jumps and the CPU time; ``compare A B`` prints the paired comparison (samples
with identical flags, with identical sizes), the pooled statistics (avalanches between jammed
minima, ⟨S⟩, two-sample KS on the sizes, τ above the same ``S_min``, chosen on ``B``) and the
CPU time ratio. Exit code 0 either way: the numbers are the result.

    python scripts/tree_statistics.py run --src /tmp/base/src --out A.npz --n 250 --seeds 1-40
    python scripts/tree_statistics.py run --src src --out B.npz --n 250 --seeds 1-40
    python scripts/tree_statistics.py compare B.npz A.npz
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # CPU time of one thread (spinning BLAS threads inflate it)

import numpy as np  # noqa: E402


def seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def run(a: argparse.Namespace) -> None:
    if a.src is not None:
        env = dict(os.environ, PYTHONPATH=str(Path(a.src).resolve()))
        argv = [sys.executable, __file__, "run", "--out", a.out, "--n", str(a.n), "--seeds",
                a.seeds_text, "--steps", str(a.steps), "--dgamma", repr(a.dgamma),
                "--p-target", repr(a.p_target), "--minimizer", a.minimizer]
        raise SystemExit(subprocess.call(argv, env=env))
    import jamlab
    from jamlab.spheres.aqs import shear
    from jamlab.spheres.packing import jam

    out: dict[str, np.ndarray] = {}
    for seed in a.seeds:
        pk = jam(a.n, 3, seed=seed, p_target=a.p_target).packing
        t = time.process_time()
        r = shear(pk, a.dgamma, n_steps=a.steps, minimizer=a.minimizer)
        cpu = time.process_time() - t
        tr = r.trace
        out[f"plastic_{seed}"] = np.asarray(tr.plastic)
        out[f"jammed_{seed}"] = np.asarray(tr.jammed)
        out[f"energy_jump_{seed}"] = np.asarray(tr.energy_jump)
        out[f"cpu_{seed}"] = np.array(cpu)
        print(f"seed {seed}: {cpu:.1f} CPU s, plastic {int(np.sum(tr.plastic))}", flush=True)
    out["seeds"] = np.array(a.seeds)
    out["source"] = np.array(str(Path(jamlab.__file__).resolve().parent))
    np.savez(a.out, **out)


def sizes_of(data, seed: int) -> np.ndarray:
    from jamlab.analysis.avalanches import avalanche_sizes

    # (the trace's step columns have a row 0 without a step: NaN jump, not plastic)
    return avalanche_sizes(data[f"energy_jump_{seed}"][1:], data[f"plastic_{seed}"][1:],
                           jammed=data[f"jammed_{seed}"])


def compare(a: argparse.Namespace) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from newton_vs_fire_pressure import print_size_comparison

    new, ref = np.load(a.new), np.load(a.ref)
    common = [int(s) for s in new["seeds"] if s in set(ref["seeds"].tolist())]
    same_flags = same_sizes = 0
    worst = 0.0
    pooled = {"new": [], "ref": []}
    flags = {"new": 0, "ref": 0}
    cpu = {"new": 0.0, "ref": 0.0}
    for s in common:
        sample = {}
        for name, data in (("new", new), ("ref", ref)):
            sample[name] = sizes_of(data, s)
            pooled[name].extend(sample[name].tolist())
            flags[name] += int(np.sum(data[f"plastic_{s}"]))
            cpu[name] += float(data[f"cpu_{s}"])
        pn, pr = new[f"plastic_{s}"], ref[f"plastic_{s}"]
        if np.array_equal(pn, pr):
            same_flags += 1
            sn, sr = sample["new"], sample["ref"]
            if sn.size != sr.size:  # the same flags, other steps between jammed minima
                continue
            d = float(np.max(np.abs(sn - sr) / np.abs(sr))) if sn.size else 0.0
            worst = max(worst, d)
            same_sizes += int(d < 1e-6)
    print(f"{len(common)} common samples; new = {a.new}, reference = {a.ref}\n")
    print("| | new | reference |\n|---|---|---|")
    print(f"| plastic flags (all steps) | {flags['new']} | {flags['ref']} |")
    s = {k: np.asarray(v) for k, v in pooled.items()}
    print(f"| avalanches between jammed minima | {s['new'].size} | {s['ref'].size} |")
    m = {k: (np.mean(v), np.std(v) / np.sqrt(max(1, v.size))) for k, v in s.items()}
    print(f"| ⟨S⟩ | {m['new'][0]:.4e} ± {m['new'][1]:.1e} | {m['ref'][0]:.4e} ± "
          f"{m['ref'][1]:.1e} |")
    print(f"| CPU s per sample | {cpu['new'] / len(common):.2f} | {cpu['ref'] / len(common):.2f} |")
    print(f"\nCPU time reference / new: {cpu['ref'] / cpu['new']:.2f}")
    print(f"samples with identical flags: {same_flags} / {len(common)}; with identical sizes "
          f"(avalanches between jammed minima, relative 1e-6): {same_sizes} (largest relative "
          f"size difference {worst:.1e})")
    if s["new"].size and s["ref"].size:
        print_size_comparison(s, "new", "ref", fit=s["ref"].size >= 100)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--src", default=None)
    r.add_argument("--out", required=True)
    r.add_argument("--n", type=int, default=250)
    r.add_argument("--seeds", dest="seeds_text", default="1-40")
    r.add_argument("--steps", type=int, default=100)
    r.add_argument("--dgamma", type=float, default=1e-5)
    r.add_argument("--p-target", type=float, default=1e-7)
    r.add_argument("--minimizer", choices=("linear", "fire"), default="linear")
    c = sub.add_parser("compare")
    c.add_argument("new")
    c.add_argument("ref")
    a = ap.parse_args()
    if a.cmd == "run":
        a.seeds = seeds(a.seeds_text)
        run(a)
    else:
        compare(a)


if __name__ == "__main__":
    main()
