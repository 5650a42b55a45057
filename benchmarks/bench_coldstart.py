"""First-run cost of the ``jamlab`` command: cold and warm ``prepare`` + ``shear``, warm start-up.

For each source tree (``--src``, default ``src``; ``--compare-src`` adds another one, e.g. the
pre-refactor ``/work/wt-base/src``, printed side by side), in fresh subprocesses with
``PYTHONPATH`` set to that tree and ``NUMBA_CACHE_DIR`` pointing at a temporary directory of this
run (so nothing is written into the trees, and no cache of an earlier run is seen):

- **cold**: the numba cache directory is emptied, then
  ``jamlab prepare --n 64 --phi 0.8 --seed 1 --quiet --out X`` and
  ``jamlab shear X --dgamma 1e-4 --gamma-max 2e-3 --out T`` (as on a fresh install);
- **warm**: the same two commands again with the cache filled;
- **warm start-up**: ``jamlab --help`` and ``jamlab inspect X`` — of the file as ``prepare``
  wrote it (summary stored, :mod:`jamlab.summary`) and of a copy without the stored summary
  (computed with the kernels, as for older files);
- **install step** ``jamlab warmup`` (:mod:`jamlab.warmup`; the README's set-up command runs it)
  from an emptied cache, then the **first prepare + shear after it** — the first run of a user who
  installed as the README says (a tree without the command prints FAILED there).

Each is repeated ``--repeat`` times (cold: the cache is emptied before every repetition) and
the trees are run alternately (``A B A B …``; the machine is shared, so alternating spreads a
disturbance over both). Printed: best and median wall time, and best and median CPU time
(user + system of the child, from ``resource.getrusage(RUSAGE_CHILDREN)``), which a loaded
machine inflates less than wall time. Asserts nothing about time. Python byte-code is not
written (nothing is written into the trees): byte-compile a tree you have edited first
(``python -m compileall -q src``), or its start-up includes recompiling the edited modules.

The targets of issue 16: cold prepare + shear ≤ 5 s in total (moonshot 2 s), warm ``--help`` and
``inspect`` ≤ 0.5 s.

Run: ``python benchmarks/bench_coldstart.py [--src src] [--compare-src /work/wt-base/src]
[--repeat 3]``.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py

# the ``jamlab`` console script, run as ``python -c`` so that PYTHONPATH decides which tree
LAUNCH = "import sys; from jamlab.cli import main; sys.argv[0] = 'jamlab'; main()"


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Run ``cmd``; return (wall, user + sys CPU of the child) in seconds; NaN if it failed
    (its last line of stderr is printed: a tree where a command is broken is still timed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        print(f"FAILED ({proc.returncode}): {' '.join(cmd[3:])}: {last}", file=sys.stderr)
        return math.nan, math.nan
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


class Tree:
    """One source tree with its own numba cache directory and scratch files."""

    def __init__(self, src: Path, scratch: Path, label: str) -> None:
        self.src = src
        self.label = label
        self.work = scratch / label
        self.cache = self.work / "numba-cache"
        self.work.mkdir(parents=True)
        self.env = dict(
            os.environ,
            PYTHONPATH=str(src),
            NUMBA_CACHE_DIR=str(self.cache),
            PYTHONDONTWRITEBYTECODE="1",  # never write into the trees
        )
        self.times: dict[str, list[tuple[float, float]]] = {}

    def jamlab(self, *args: str) -> list[str]:
        return [sys.executable, "-c", LAUNCH, *args]

    def clear_cache(self) -> None:
        shutil.rmtree(self.cache, ignore_errors=True)

    def record(self, name: str, cmd: list[str]) -> None:
        self.times.setdefault(name, []).append(timed(cmd, self.env))

    def one_round(self, k: int) -> None:
        config = self.work / f"config-{k}.h5"
        trace = self.work / f"trace-{k}.h5"
        prepare = ("prepare", "--n", "64", "--phi", "0.8", "--seed", "1", "--quiet")
        shear = ("--dgamma", "1e-4", "--gamma-max", "2e-3")
        self.clear_cache()
        self.record("cold prepare", self.jamlab(*prepare, "--out", str(config)))
        self.record("cold shear", self.jamlab("shear", str(config), *shear, "--out", str(trace)))
        for path in (config, trace, trace.with_name(f"{trace.stem}.last.h5")):
            path.unlink(missing_ok=True)  # (commands refuse an existing output)
        self.record("warm prepare", self.jamlab(*prepare, "--out", str(config)))
        self.record("warm shear", self.jamlab("shear", str(config), *shear, "--out", str(trace)))
        self.record("warm --help", self.jamlab("--help"))
        self.record("warm inspect", self.jamlab("inspect", str(config)))
        # the same file without the stored summary (an older file, another program's): computed
        plain = self.work / f"plain-{k}.h5"
        shutil.copy(config, plain)
        with h5py.File(plain, "r+") as h5:
            for name in ("summary", "summary_key"):
                if name in h5.attrs:
                    del h5.attrs[name]
        self.record("warm inspect, computed", self.jamlab("inspect", str(plain)))
        self.times.setdefault("cold prepare+shear", []).append(
            tuple(a + b for a, b in zip(self.times["cold prepare"][-1],
                                        self.times["cold shear"][-1], strict=True))
        )
        for path in (config, trace, trace.with_name(f"{trace.stem}.last.h5")):
            path.unlink(missing_ok=True)  # (commands refuse an existing output)
        self.clear_cache()
        self.record("install: warmup", self.jamlab("warmup"))
        self.record("then prepare", self.jamlab(*prepare, "--out", str(config)))
        self.record("then shear", self.jamlab("shear", str(config), *shear, "--out", str(trace)))
        self.times.setdefault("then prepare+shear", []).append(
            tuple(a + b for a, b in zip(self.times["then prepare"][-1],
                                        self.times["then shear"][-1], strict=True))
        )


def summary(values: list[tuple[float, float]]) -> str:
    ok = [v for v in values if not math.isnan(v[1])]
    if not ok:
        return "failed"
    walls = [w for w, _ in ok]
    cpus = [c for _, c in ok]
    return (
        f"{min(walls):6.2f} {statistics.median(walls):6.2f}  "
        f"{min(cpus):6.2f} {statistics.median(cpus):6.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--src", default="src", help="source tree to time (default: src)")
    parser.add_argument("--compare-src", default=None, help="a second tree, printed beside it")
    parser.add_argument("--repeat", type=int, default=3, help="rounds per tree (default 3)")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="jamlab-coldstart-") as scratch:
        trees = []
        if args.compare_src:
            trees.append(Tree(Path(args.compare_src).resolve(), Path(scratch), "compare"))
        trees.append(Tree(Path(args.src).resolve(), Path(scratch), "src"))
        for k in range(args.repeat):
            for tree in trees:
                tree.one_round(k)
                print(f"round {k + 1}/{args.repeat} done: {tree.label} ({tree.src})",
                      file=sys.stderr, flush=True)

        print(f"jamlab first run, {args.repeat} rounds per tree, N = 64, phi = 0.8 "
              "(seconds: wall best, median; CPU user+sys best, median)")
        for tree in trees:
            print(f"  {tree.label}: {tree.src}")
        header = f"{'':20s}" + "".join(
            f"| {t.label + ': wall  med   cpu   med':33s}" for t in trees
        )
        print(header)
        for name in ("cold prepare", "cold shear", "cold prepare+shear", "warm prepare",
                     "warm shear", "warm --help", "warm inspect", "warm inspect, computed",
                     "install: warmup",
                     "then prepare+shear"):
            row = f"{name:20s}" + "".join(f"| {summary(t.times[name]):33s}" for t in trees)
            if len(trees) == 2:
                a = min((c for _, c in trees[0].times[name]), key=lambda c: (math.isnan(c), c))
                b = min((c for _, c in trees[1].times[name]), key=lambda c: (math.isnan(c), c))
                row += f"| cpu ratio {a / b:5.1f}x"
            print(row)
        print("targets: first prepare+shear <= 5 s (moonshot 2 s; 'then' = after the install "
              "step, 'cold' = without it); warm --help, inspect <= 0.5 s")


if __name__ == "__main__":
    main()
