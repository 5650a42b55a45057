"""The LAMMPS reference data the tests compare with, shipped in ``tests/data/reference``.

They are facts produced by a peer program (LAMMPS), not by jamlab; their provenance (LAMMPS
version, commands, conventions) is in ``tests/data/reference/README.md`` and each folder's
``meta.json``. Tests read them without LAMMPS installed and never skip for want of them.
"""

from pathlib import Path

REFERENCE = Path(__file__).resolve().parent / "data" / "reference"
N1000 = REFERENCE / "lammps-aqs-n1000-phi0.80"
N500 = REFERENCE / "lammps-aqs-n500-phi0.80-1000steps"
