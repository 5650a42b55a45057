"""The packages that load their public names on first use (``jamlab.analysis``, ``jamlab.spheres``):
every listed name is the object its submodule defines, and a command that shears does not pay
for the statistics stack it does not use."""

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

import jamlab.analysis as analysis

SRC = Path(analysis.__file__).parent


def _public_definitions() -> dict[str, str]:
    """``{name: submodule}`` for every public name of a submodule of ``jamlab.analysis``: its
    ``__all__``, or where it has none its top-level functions, classes and constants not
    starting with ``_`` (read from the source, independently of the package's own table)."""
    out: dict[str, str] = {}
    for path in sorted(SRC.glob("*.py")):
        if path.name == "__init__.py":
            continue
        body = ast.parse(path.read_text()).body
        listed = [n for n in body if isinstance(n, ast.Assign)
                  and any(isinstance(t, ast.Name) and t.id == "__all__" for t in n.targets)]
        if listed:
            names = [elt.value for elt in listed[0].value.elts]
        else:
            names = [n.name for n in body if isinstance(n, (ast.FunctionDef, ast.ClassDef))]
            names += [t.id for n in body if isinstance(n, ast.Assign) for t in n.targets
                      if isinstance(t, ast.Name)]
        for name in names:
            if not name.startswith("_"):
                out.setdefault(name, path.stem)
    return out


def test_every_public_name_is_its_submodules_object():
    defined = _public_definitions()
    for name in analysis.__all__:
        assert name in defined, f"{name} is not public in a submodule"
        module = importlib.import_module(f"jamlab.analysis.{defined[name]}")
        assert getattr(analysis, name) is getattr(module, name), name


@pytest.mark.parametrize("name", ["packing_dispersion", "rate_collapse", "size_difference"])
def test_a_function_named_as_its_submodule_stays_the_function(name):
    # the submodule imported first (as another module of jamlab may do) binds its name in the
    # package; the package's name must still be the function, as with eager imports
    code = (f"import importlib, jamlab.analysis as a\n"
            f"m = importlib.import_module('jamlab.analysis.{name}')\n"
            f"print(callable(a.{name}) and a.{name} is m.{name})")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == "True", out


def test_submodules_and_unknown_names():
    assert analysis.finite_size.fit_joint_scaling is analysis.fit_joint_scaling
    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        analysis.no_such_name  # noqa: B018


@pytest.mark.parametrize("module", ["jamlab.analysis.anatomy", "jamlab.spheres.aqs",
                                    "jamlab.spheres.pressure_shear", "jamlab.cli.shear"])
def test_shearing_does_not_import_the_statistics_stack(module):
    code = (f"import sys, {module}\n"
            "print(sorted(m for m in ('scipy.stats', 'scipy.optimize') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]", (module, out)
