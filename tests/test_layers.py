"""Module boundaries: no module uses another module's underscored names, and no source file
grows past the size a reader can hold (issue: ``spheres/`` in layers).

Checked on every Python file of ``src/jamlab``, ``tests``, ``scripts`` and ``benchmarks`` with
``ast`` (the source is parsed, not imported):

- ``from jamlab.a import _f`` and ``import jamlab.a._m`` / ``jamlab.a._f`` are refused, except a
  private module imported by a module of the package that owns it (``jamlab.spheres._kernels``
  from ``jamlab/spheres/...``);
- ``x._name`` is refused when ``_name`` is defined (function, class, method, attribute or
  assignment) somewhere in jamlab but not in the module that uses it (``self._x`` inside its own
  class's module is fine).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "jamlab"
MAX_LINES = 600


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _files(*dirs: str) -> list[Path]:
    out: list[Path] = []
    for d in dirs:
        out += sorted((ROOT / d).rglob("*.py"))
    return out


def _module_name(path: Path) -> str | None:
    try:
        rel = path.relative_to(ROOT / "src")
    except ValueError:
        return None
    parts = list(rel.with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _defined_private(tree: ast.AST) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            if _private(node.name):
                names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store) and _private(node.id):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            if _private(node.attr):
                names.add(node.attr)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if _private(node.target.id):
                names.add(node.target.id)
    return names


def _own_package(module: str | None, private_module: str) -> bool:
    """``private_module`` (``jamlab.p._m``) may be imported by modules of ``jamlab.p``."""
    if module is None:
        return False
    package = private_module.rsplit(".", 1)[0]
    return module == package or module.startswith(package + ".")


def violations() -> list[str]:
    trees = {p: ast.parse(p.read_text(), str(p)) for p in _files("src", "tests", "scripts",
                                                                 "benchmarks")}
    jamlab_private: set[str] = set()
    for p, t in trees.items():
        if _module_name(p):
            jamlab_private |= _defined_private(t)
    out: list[str] = []
    for p, tree in trees.items():
        module = _module_name(p)
        own = _defined_private(tree)
        rel = p.relative_to(ROOT)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                if not node.module.startswith("jamlab"):
                    continue
                for part in node.module.split(".")[1:]:
                    if _private(part) and not _own_package(module, node.module):
                        out.append(f"{rel}:{node.lineno}: from {node.module} import ...")
                for alias in node.names:
                    if _private(alias.name):
                        target = f"{node.module}.{alias.name}"
                        if not _own_package(module, target):
                            out.append(f"{rel}:{node.lineno}: from {node.module} import "
                                       f"{alias.name}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    parts = alias.name.split(".")
                    if parts[0] == "jamlab" and any(_private(x) for x in parts[1:]):
                        if not _own_package(module, alias.name):
                            out.append(f"{rel}:{node.lineno}: import {alias.name}")
            elif isinstance(node, ast.Attribute) and _private(node.attr):
                if node.attr in jamlab_private and node.attr not in own:
                    out.append(f"{rel}:{node.lineno}: .{node.attr}")
    return out


def test_no_module_uses_another_modules_private_names():
    bad = violations()
    assert not bad, f"{len(bad)} uses of another module's private names:\n" + "\n".join(bad)


def test_no_source_file_is_too_long():
    long = {
        str(p.relative_to(ROOT)): n
        for p in sorted(SRC.rglob("*.py"))
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    }
    assert not long, f"files above {MAX_LINES} lines: {long}"


def test_the_checker_catches_what_it_should(tmp_path):
    """The checker itself against known good and bad snippets (a check that cannot fail proves
    nothing)."""
    bad = ast.parse("from jamlab.spheres.aqs import _newton\nimport jamlab.spheres._kernels\n")
    names = [n for n in ast.walk(bad) if isinstance(n, ast.ImportFrom | ast.Import)]
    assert len(names) == 2
    assert _own_package("jamlab.spheres.aqs.driver", "jamlab.spheres._kernels")
    assert not _own_package("jamlab.runs.tasks", "jamlab.spheres._kernels")
    assert not _own_package(None, "jamlab.spheres._kernels")
    assert _defined_private(ast.parse("class A:\n    def _f(self):\n        self._x = 1\n")) == {
        "_f",
        "_x",
    }
