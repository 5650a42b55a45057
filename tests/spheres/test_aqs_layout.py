"""Layout of the AQS package (issue 14): small modules, no private names across modules.

Scans the source with :mod:`ast` (independent of importing it): no ``from a import _f`` and no
``a._f`` on an imported name, except the private kernel modules of ``jamlab.spheres``, which
its own modules may import; and no module above 600 lines. A public entry point check: the
names the rest of jamlab and users import still resolve.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "jamlab" / "spheres" / "aqs"
MODULES = sorted(PACKAGE.glob("*.py"))
ALLOWED_PRIVATE_MODULES = {("jamlab.spheres", "_kernels"), ("jamlab.spheres", "_aqs_kernels")}


def private_uses(source: str) -> list[str]:
    """``from a import _f`` and ``name._f`` (``name`` bound by an import) in ``source``."""
    tree = ast.parse(source)
    imported: set[str] = set()
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                imported.add((alias.asname or alias.name).split(".")[0])
        elif isinstance(node, ast.ImportFrom) and node.module != "__future__":
            for alias in node.names:
                imported.add(alias.asname or alias.name)
                private = alias.name.startswith("_") and not alias.name.startswith("__")
                if private and (node.module, alias.name) not in ALLOWED_PRIVATE_MODULES:
                    found.append(f"from {node.module} import {alias.name}")
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in imported
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            found.append(f"{node.value.id}.{node.attr} (line {node.lineno})")
    return found


def test_the_scanner_finds_private_uses():
    src = "import a.b as m\nfrom x import _f, g\nfrom jamlab.spheres import _kernels as K\n"
    src += "m._h(1)\nK.contact_pairs\ng.y\nself_like = object()\nself_like._z\n"
    assert private_uses(src) == ["from x import _f", "m._h (line 4)"]


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_no_private_names_across_modules(path):
    assert private_uses(path.read_text()) == []


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_modules_are_small(path):
    assert len(path.read_text().splitlines()) <= 600


def test_public_entry_points():
    from jamlab.spheres import shear as shear_from_spheres
    from jamlab.spheres.aqs import (
        MINIMIZERS,
        AQSParameters,
        ShearResult,
        checkpoint_paths,
        n_steps_for,
        shear,
    )

    assert shear is shear_from_spheres
    assert MINIMIZERS == ("linear", "fire")
    assert n_steps_for(1e-5, 1e-3) == 100
    assert checkpoint_paths("run.h5")[0].name == "run.last.h5"
    assert AQSParameters().max_events == 1000 and ShearResult.__name__ == "ShearResult"
