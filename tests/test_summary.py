"""The summary stored in configuration files (``jamlab.summary``): ``jamlab inspect`` prints it
only when it is what the current code computes for the current contents, and recomputes it
otherwise (a changed position, box side, stored number, or code)."""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest

import jamlab.spheres as sp
import jamlab.summary as summary
from cli_helpers import jamlab
from jamlab.spheres.io import read_packing, write_packing


def _packings():
    above = sp.prepare(48, 3, 0.8, 2).packing
    sheared = sp.affine_shear(sp.random_packing(60, 2, 0.85, seed=3, sizes="bidisperse"), 0.37)
    hertz = sp.prepare(40, 3, 0.75, 4, sizes="polydisperse:0.1", alpha=2.5).packing
    return {"above": above, "sheared": sheared, "hertz": hertz}


@pytest.mark.parametrize("name", ["above", "sheared", "hertz"])
def test_stored_summary_is_the_computed_one(tmp_path, name):
    packing = _packings()[name]
    path = write_packing(tmp_path / "c.h5", packing)
    stored = summary.stored_summary(path)
    assert stored is not None
    # recomputed from the file by the library (not through the stored text)
    assert stored == summary.compute_summary(read_packing(path))
    assert stored["energy"] == sp.energy(packing)
    r = jamlab("inspect", path, "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == stored


def _copy(path, tmp_path, name):
    target = tmp_path / name
    shutil.copy(path, target)
    return target


def test_any_change_makes_inspect_recompute(tmp_path, monkeypatch):
    packing = _packings()["above"]
    path = write_packing(tmp_path / "c.h5", packing)
    good = summary.stored_summary(path)
    # a moved particle: the stored numbers no longer describe the file
    moved = _copy(path, tmp_path, "moved.h5")
    with h5py.File(moved, "r+") as h5:
        pos = h5["positions"][()]
        pos[0, 0] += 1e-3
        h5["positions"][...] = pos
    assert summary.stored_summary(moved) is None
    r = jamlab("inspect", moved, "--json")
    fresh = json.loads(r.stdout)
    assert fresh == summary.compute_summary(read_packing(moved)) and fresh != good
    # another box side, a forged number, a removed key, or no summary at all
    for name, edit in (
        ("box", lambda h5: h5.attrs.__setitem__("box_length", h5.attrs["box_length"] * 1.001)),
        ("forged", lambda h5: h5.attrs.__setitem__(
            "summary", h5.attrs["summary"].replace(repr(good["energy"]), "1.0"))),
        ("nokey", lambda h5: h5.attrs.__delitem__("summary_key")),
        ("plain", lambda h5: (h5.attrs.__delitem__("summary"),
                              h5.attrs.__delitem__("summary_key"))),
    ):
        other = _copy(path, tmp_path, f"{name}.h5")
        with h5py.File(other, "r+") as h5:
            edit(h5)
        assert summary.stored_summary(other) is None, name
        r = jamlab("inspect", other, "--json")
        if name == "box":  # φ no longer matches: the file is refused, not summarised
            assert r.returncode == 2 and "inconsistent file" in r.stderr
            continue
        assert r.returncode == 0, r.stderr
        assert json.loads(r.stdout) == summary.compute_summary(read_packing(other)), name
    # other code computing the summary: the key changes (the digest covers the sources)
    assert summary.stored_summary(path) == good
    monkeypatch.setattr(summary, "_code_digest", lambda: b"other code")
    assert summary.stored_summary(path) is None


def test_the_digest_covers_the_kernels():
    root = summary.Path(summary.__file__).resolve().parent
    covered = {p.relative_to(root).as_posix() for pattern in summary.CODE
               for p in root.glob(pattern)}
    assert {"spheres/kernels/pairs.py", "spheres/pair.py", "spheres/potential.py",
            "spheres/contacts.py", "summary.py"} <= covered
    assert np.all([(root / c).is_file() for c in covered])
