"""A ``jamlab run`` study whose shear uses other FIRE parameters: does the minimiser's dynamics
change the avalanche statistics?

At p = 1e-6 the minimum a plastic step ends in depends on FIRE's path (``docs/aqs.md``,
"Following FIRE's straight escapes by a line search"). This script runs a study exactly as
``jamlab run`` does (same seeds, same preparation, same trace and sample files, so
``scripts/compare_runs.py`` can compare it sample by sample with the default run), except that
every FIRE minimisation of the shear uses ``FireParameters(**overrides)`` (``--fire
name=value``, repeatable; e.g. ``variant=fire`` for the original FIRE of Bitzek et al. 2006,
``dt_max=0.1``). The preparation (``jam``) is unchanged. The run is in-process
(``--workers 0``, so the change reaches the shear); the overrides are written to
``OUT/fire_params.json`` at the first shear; a run directory with other overrides, or a run
without them (a plain ``jamlab run``), is refused (exit 2). Resumes
as ``jamlab run`` does.

    PYTHONPATH=src python scripts/fire_variant_run.py --fire variant=fire -- \\
        --phi jamming --n 250 --samples 20 --dgamma 1e-5 --gamma-max 0.01 --pressure 1e-6 \\
        --out RUNS/n250-p1e-6-fire1
    PYTHONPATH=src python scripts/compare_runs.py RUNS/n250-p1e-6-fix40 RUNS/n250-p1e-6-fire1 \\
        --s-min 1e-10
"""

from __future__ import annotations

import json
import sys
from dataclasses import fields
from pathlib import Path

from jamlab.spheres.fire import FireParameters


def parse_overrides(items: list[str]) -> dict:
    """``name=value`` pairs as :class:`FireParameters` keyword arguments (checked by it)."""
    kinds = {f.name: f.type for f in fields(FireParameters)}
    out: dict = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or name not in kinds:
            raise ValueError(f"--fire {item!r}: expected name=value with name one of "
                             f"{', '.join(kinds)}")
        kind = str(kinds[name])
        out[name] = value if kind == "str" else int(value) if kind == "int" else float(value)
    FireParameters(**out)  # its own checks
    return out


def main(argv: list[str]) -> int:
    if "--" not in argv:
        print("error: usage: fire_variant_run.py --fire name=value … -- <jamlab run options>",
              file=sys.stderr)
        return 2
    mine, run_args = argv[: argv.index("--")], argv[argv.index("--") + 1:]
    items = [mine[i + 1] for i, x in enumerate(mine[:-1]) if x == "--fire"]
    if not items or len(items) * 2 != len(mine):
        print("error: give one or more --fire name=value before --", file=sys.stderr)
        return 2
    try:
        overrides = parse_overrides(items)
    except (TypeError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if "--out" not in run_args[:-1] or "--workers" in run_args:
        print("error: the jamlab run options need --out DIR, and not --workers (forced to 0)",
              file=sys.stderr)
        return 2
    out = Path(run_args[run_args.index("--out") + 1])
    record = out / "fire_params.json"
    if record.is_file() and json.loads(record.read_text()) != overrides:
        print(f"error: {out} was run with FIRE overrides {record.read_text().strip()}, "
              f"not {overrides}", file=sys.stderr)
        return 2
    if (out / "manifest.json").is_file() and not record.is_file():
        # a plain jamlab run (or one stopped before its first shear): its samples are not ours
        print(f"error: {out} is a run without FIRE overrides; give another --out",
              file=sys.stderr)
        return 2
    import jamlab.spheres.aqs as aqs  # the module the aqs task calls (jamlab.runs.physics)
    from jamlab.cli import main as jamlab_main

    shear, params = aqs.shear, FireParameters(**overrides)

    def shear_with(*args, **kwargs):
        if not record.is_file():  # the run directory exists by now (with its manifest)
            record.write_text(json.dumps(overrides) + "\n")
        return shear(*args, fire_params=params, **kwargs)

    aqs.shear = shear_with
    try:
        jamlab_main(["run", *run_args, "--workers", "0"])
    except SystemExit as exc:
        return int(exc.code or 0)
    finally:
        aqs.shear = shear
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
