"""Property test (issue 15): every command, driven with random bad arguments and malformed files,
answers with one line ``jamlab: error: ...`` and exit code 2, no traceback, and leaves every file
that existed before byte-identical (and creates none).

Each example starts from a valid command line and breaks one or two of its arguments with a value
that is wrong by construction (out of range, not a number, a malformed or missing file, an output
that is an input or a directory), so that exit code 2 is the only right answer. The commands run
in-process (``jamlab.cli.main``) to keep ~50 examples per command under two minutes; an exception
other than ``SystemExit`` escaping ``main`` is a traceback and fails the test.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import jamlab.spheres as sp  # noqa: E402
from jamlab.cli import main  # noqa: E402
from jamlab.spheres.fire import minimize  # noqa: E402
from jamlab.spheres.io import write_packing  # noqa: E402

EXAMPLES = int(os.environ.get("JAMLAB_FUZZ_EXAMPLES", "50"))  # ~50 per command in CI

# -- the fixture directory: good inputs and malformed files -----------------------------------

MALFORMED = (
    "empty.h5",
    "text.h5",
    "noattrs.h5",
    "group.h5",
    "flat.h5",
    "strings.h5",
    "nan.h5",
    "farstrain.h5",
    "baddim.h5",
    "badbox.h5",
    "missing.h5",
    "adir",
)


def _make_files(root: Path) -> None:
    packing = minimize(sp.random_packing(32, 3, 0.8, seed=1), ftol=1e-12).packing
    good = write_packing(root / "good.h5", packing)
    (root / "empty.h5").write_bytes(b"")
    (root / "text.h5").write_text("not hdf5\n")
    with h5py.File(root / "noattrs.h5", "w") as h5:
        h5["positions"] = packing.positions
    with h5py.File(root / "group.h5", "w") as h5:
        h5.create_group("positions")
        h5.attrs.update({"box_length": packing.box.length, "strain": 0.0, "dim": 3})
    for name, edit in (
        ("flat.h5", lambda h5: h5.__setitem__("positions", np.arange(6.0))),
        ("strings.h5", lambda h5: h5.__setitem__("positions", np.array([b"a", b"b"]))),
        ("nan.h5", lambda h5: h5.__setitem__("positions", np.full((32, 3), np.nan))),
        ("farstrain.h5", lambda h5: h5.attrs.__setitem__("strain", 1e17)),
        ("baddim.h5", lambda h5: h5.attrs.__setitem__("dim", 7)),
        ("badbox.h5", lambda h5: h5.attrs.__setitem__("box_length", -1.0)),
    ):
        target = root / name
        target.write_bytes(good.read_bytes())
        with h5py.File(target, "a") as h5:
            if name in ("flat.h5", "strings.h5", "nan.h5"):
                del h5["positions"]
            edit(h5)
    (root / "adir").mkdir()
    (root / "adir" / "keep.txt").write_text("keep\n")
    np.savetxt(root / "pos.txt", packing.positions)
    (root / "xyz").mkdir()
    np.savetxt(root / "xyz" / "positions.txt", packing.positions)
    (root / "xyz" / "meta.json").write_text("{not json")
    (root / "bad.toml").write_text("phi = [0.8\n")
    (root / "workers.toml").write_text(
        'phi = [0.8]\nn = [32]\nsamples = 1\ndgamma = 1e-3\ngamma_max = 3e-3\ntask = "toy"\n'
        '[execution]\nworkers = "two"\n'
    )
    (root / "norun").mkdir()
    (root / "norun" / "manifest.json").write_text(json.dumps({"format": "other"}))


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("fuzz")
    _make_files(path)
    return path


def _snapshot(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "d"
        for p in sorted(root.rglob("*"))
    }


def run_bad(root: Path, argv: list[str]) -> None:
    """Run ``jamlab argv`` in ``root``: exit 2, one line, no traceback, no file changed."""
    before = _snapshot(root)
    err, out = io.StringIO(), io.StringIO()
    with (
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(out),
        warnings.catch_warnings(record=True) as caught,
    ):
        warnings.simplefilter("always")
        try:
            main(argv)
            code = 0
        except SystemExit as exc:
            code = exc.code
    # a warning would be printed on stderr: one more line
    lines = [line for line in err.getvalue().splitlines() if line.strip()]
    lines += [f"warning: {w.message}" for w in caught]
    assert code == 2, (argv, code, err.getvalue(), out.getvalue())
    assert len(lines) == 1 and lines[0].startswith("jamlab: error: "), (argv, err.getvalue())
    assert "Traceback" not in err.getvalue()
    assert _snapshot(root) == before, argv


# -- bad values -------------------------------------------------------------------------------

NOT_A_NUMBER = st.sampled_from(["abc", "", "1,5", "0x", "--", "1e", "nan(", "½"]) | st.text(
    st.characters(blacklist_categories=("Cs",)), max_size=6
).filter(lambda t: not _parses(t) and not t.startswith("-"))
NON_FINITE = st.sampled_from(["nan", "inf", "-inf", "1e400", "-1e400", "NaN", "Infinity"])


def _parses(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def positive_bad() -> st.SearchStrategy[str]:
    """Not a finite number > 0."""
    return (
        NOT_A_NUMBER
        | NON_FINITE
        | st.sampled_from(["0", "-0", "-1", "-1e-300"])
        | st.floats(max_value=0, allow_nan=False, allow_infinity=False).map(repr)
    )


def integer_bad(minimum: int, maximum: int | None = None) -> st.SearchStrategy[str]:
    """Not an integer in [minimum, maximum]."""
    too_small = st.integers(max_value=minimum - 1).map(str)
    choices = [NOT_A_NUMBER, NON_FINITE, too_small, st.sampled_from(["1.5", "2.25", "0.5"])]
    if maximum is not None:
        choices.append(st.integers(min_value=maximum + 1).map(str))
    return st.one_of(*choices)


SEED_BAD = integer_bad(0, 2**64 - 1) | st.just(str(2**64))
PHI_BAD = positive_bad() | st.sampled_from(["1", "1.0", "5.0", "1e300"])
BAD_CONFIG = st.sampled_from(MALFORMED)


@st.composite
def broken(draw, valid: dict[str, str], bad: dict[str, st.SearchStrategy[str]]) -> dict:
    """``valid`` with one or two of the ``bad`` options replaced."""
    names = draw(st.lists(st.sampled_from(sorted(bad)), min_size=1, max_size=2, unique=True))
    args = dict(valid)
    for name in names:
        args[name] = draw(bad[name])
    return args


def argv(command: list[str], args: dict[str, str], root: Path) -> list[str]:
    out = list(command)
    for name, value in args.items():
        if value is None:  # a flag
            out.append(name)
        elif name.startswith("@"):  # a positional argument
            out.append(str(root / value) if value in _FILES else value)
        else:
            out.extend([name, str(root / value) if value in _FILES else value])
    return out


_FILES = set(MALFORMED) | {
    "good.h5", "pos.txt", "xyz/positions.txt", "xyz/meta.json", "bad.toml", "workers.toml",
    "norun", "new.h5", "new.png", "new.csv", "nodir/new.h5", "run-new",
}  # fmt: skip
OUT_BAD = st.sampled_from(["adir", "good.h5", "nodir/new.h5"])  # good.h5: the input
OUT_BAD_NO_INPUT = st.sampled_from(["adir", "nodir/new.h5"])  # replacing an output is allowed


def _fuzz(command: list[str], valid: dict[str, str], bad: dict[str, st.SearchStrategy[str]]):
    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(args=broken(valid, bad))
    def test(root, args):
        run_bad(root, argv(command, args, root))

    return test


test_inspect = _fuzz(["inspect"], {"@config": "good.h5"}, {"@config": BAD_CONFIG})

test_minimize = _fuzz(
    ["minimize"],
    {"@config": "good.h5", "--out": "new.h5", "--ftol": "1e-12", "--max-iter": "100"},
    {
        "@config": BAD_CONFIG,
        "--out": OUT_BAD,
        "--ftol": positive_bad(),
        "--max-iter": integer_bad(0),
    },
)

test_random_packing = _fuzz(
    ["random-packing"],
    {"--out": "new.h5", "--n": "32", "--phi": "0.5", "--dim": "3", "--seed": "0"},
    {
        "--out": OUT_BAD_NO_INPUT,
        "--n": integer_bad(2),
        "--phi": PHI_BAD,
        "--dim": integer_bad(2),
        "--seed": SEED_BAD,
    },
)

test_import_xyz = _fuzz(
    ["import-xyz"],
    {"@positions": "pos.txt", "--out": "new.h5", "--box-length": "3.55", "--strain": "0"},
    {
        "@positions": st.sampled_from(["missing.h5", "adir", "text.h5", "empty.h5", "good.h5"]),
        "--out": st.sampled_from(["adir", "pos.txt", "nodir/new.h5"]),
        "--box-length": positive_bad() | st.sampled_from(["0.5", "1", "2"]),
        "--strain": NOT_A_NUMBER | NON_FINITE | st.sampled_from(["1e17", "-1e7", "1e300"]),
    },
)

test_import_xyz_meta = _fuzz(
    ["import-xyz"],
    {"@positions": "xyz/positions.txt", "--out": "new.h5"},
    {"--out": st.sampled_from(["new.h5", "adir", "xyz/meta.json", "xyz/positions.txt"])},
)

test_prepare = _fuzz(
    ["prepare"],
    {"--n": "32", "--phi": "0.8", "--seed": "1", "--quiet": None, "--out": "new.h5"},
    {
        "--out": OUT_BAD_NO_INPUT,
        "--n": integer_bad(2),
        "--phi": PHI_BAD | st.sampled_from(["jammed", "0.3"]),
        "--seed": SEED_BAD,
        "--ftol": positive_bad(),
        "--p-target": positive_bad(),
        "--dim": integer_bad(2) | st.sampled_from(["10", "12"]),
        "--search": st.sampled_from(["", "bisect", "WINDOW2"]),
    },
)

test_coordination = _fuzz(
    ["coordination"],
    {"@config": "good.h5", "--out": "new.png", "--steps": "3", "--quiet": None},
    {
        "@config": BAD_CONFIG,
        "--out": OUT_BAD,
        "--csv": st.sampled_from(["good.h5", "adir", "new.png", "nodir/new.h5"]),
        "--steps": integer_bad(2),
        "--ftol": positive_bad(),
        "--dphi-min": positive_bad(),
        "--dphi-max": positive_bad() | st.sampled_from(["0.5", "1"]),
    },
)

SHEAR_VALID = {"@config": "good.h5", "--dgamma": "1e-3", "--gamma-max": "3e-3", "--out": "new.h5"}
test_shear = _fuzz(
    ["shear"],
    SHEAR_VALID,
    {
        "@config": BAD_CONFIG,
        "--out": OUT_BAD,
        "--dgamma": positive_bad() | st.sampled_from(["1e-320", "5e-324", "1", "3e-3"]),
        "--gamma-max": positive_bad() | st.sampled_from(["1e300", "1e5", "1e-4"]),
        "--ftol": positive_bad(),
        "--minimizer": st.sampled_from(["", "newton", "FIRE", "cg"]),
        "--save-every": integer_bad(1),
        "--plot": st.sampled_from(["adir", "good.h5", "nodir/new.h5", "new.h5"]),
    },
)

test_shear_resume = _fuzz(
    ["shear"],
    {**SHEAR_VALID, "--resume": None},
    {
        "--out": st.sampled_from(["new.h5", "good.h5", "text.h5", "adir", "group.h5"]),
        "--dgamma": positive_bad(),
    },
)

test_theory = _fuzz(
    ["theory"],
    {"--out": "new.png", "--points": "20", "--dgamma": "1e-3"},
    {
        "--out": OUT_BAD_NO_INPUT,
        "--csv": st.sampled_from(["adir", "new.png", "nodir/new.csv"]),
        "--dgamma": NOT_A_NUMBER | NON_FINITE | st.sampled_from(["0", "1e300", "-1e300", "1e-320"]),
        "--points": integer_bad(2),
        "--mu": NOT_A_NUMBER | NON_FINITE | st.sampled_from(["-1", "0", "1", "2"]),
        "--q-max": NOT_A_NUMBER | NON_FINITE | st.sampled_from(["0", "-0.5", "1.5"]),
    },
)

test_cascade = _fuzz(
    ["cascade"],
    {"--linear": "1", "--k": "4", "--n": "100", "--seed": "1", "--dgamma": "0.1",
     "--out": "new.png"},  # fmt: skip
    {
        "--out": OUT_BAD_NO_INPUT,
        "--csv": st.sampled_from(["adir", "new.png", "nodir/new.csv"]),
        "--tree": st.sampled_from(["adir", "new.png"]),
        "--seed": SEED_BAD,
        "--k": integer_bad(1),
        "--n": integer_bad(1) | st.just("1000000000"),
        "--dgamma": NOT_A_NUMBER | NON_FINITE,
        "--linear": NOT_A_NUMBER | NON_FINITE,
    },
)

RUN_VALID = {
    "--phi": "0.8", "--n": "32", "--samples": "1", "--dgamma": "1e-3", "--gamma-max": "3e-3",
    "--task": "toy", "--workers": "0", "--quiet": None, "--out": "run-new",
}  # fmt: skip
test_run = _fuzz(
    ["run"],
    RUN_VALID,
    {
        "--out": st.sampled_from(["good.h5", "adir", "norun"]),
        "--phi": PHI_BAD | st.sampled_from(["jammed"]),
        "--n": integer_bad(2),
        "--samples": integer_bad(1),
        "--dgamma": positive_bad() | st.sampled_from(["1e-320", "3e-3"]),
        "--gamma-max": positive_bad() | st.sampled_from(["1e300"]),
        "--seed": SEED_BAD,
        "--dim": integer_bad(2),
        "--workers": st.sampled_from(["-1", "two", "1.5"]),
        "--scheduler": st.sampled_from(["nowhere", ""]),
        "--task": st.sampled_from(["", "physics", "TOY"]),
        "--force-tol": positive_bad(),
    },
)

test_run_study_file = _fuzz(
    ["run"],
    {"@study": "bad.toml", "--out": "run-new", "--quiet": None},
    {"@study": st.sampled_from(["bad.toml", "workers.toml", "missing.h5", "good.h5", "adir"])},
)

test_status = _fuzz(
    ["status"],
    {"@run": "norun"},
    {"@run": st.sampled_from(["norun", "adir", "missing.h5", "good.h5"])},
)

