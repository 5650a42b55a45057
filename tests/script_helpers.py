"""The repository's scripts as modules for the tests (they are files, not a package):
``load_by_path(path, key)`` loads a file once under ``key`` in ``sys.modules``;
``script_module(name)`` is ``scripts/<name>.py``."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def load_by_path(path: Path, key: str) -> ModuleType:
    """The file ``path`` as a module named ``key``, loaded once."""
    if key not in sys.modules:
        spec = importlib.util.spec_from_file_location(key, path)
        module = importlib.util.module_from_spec(spec)
        # registered before it runs (importlib's recipe): a dataclass in it looks its module up
        sys.modules[key] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[key]
            raise
    return sys.modules[key]


def script_module(name: str) -> ModuleType:
    """``scripts/<name>.py`` as a module."""
    return load_by_path(SCRIPTS / f"{name}.py", f"jamlab_scripts_{name}")


def exit_code(module: ModuleType, argv: list[str], monkeypatch) -> int | str | None:
    """The code ``module.main()`` exits with when run as ``<script> *argv`` (the test fails if
    it returns instead of exiting)."""
    import pytest

    monkeypatch.setattr(sys, "argv", [f"{module.__name__}.py", *argv])
    with pytest.raises(SystemExit) as e:
        module.main()
    return e.value.code


def assert_out_kept(module: ModuleType, out: Path, monkeypatch) -> None:
    """Finished data at ``out``: ``<script> --out out`` exits with code 2 and leaves the file as
    it was (nothing finished is ever overwritten)."""
    out.write_bytes(b"finished data")
    assert exit_code(module, ["--out", str(out)], monkeypatch) == 2
    assert out.read_bytes() == b"finished data"
