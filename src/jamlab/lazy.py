"""Packages that load their public names on first use (PEP 562): ``jamlab.spheres`` and
``jamlab.analysis`` call :func:`attribute` from their module ``__getattr__`` and :func:`names`
from ``__dir__``."""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["attribute", "names"]


def attribute(package: str, namespace: dict[str, Any], module_of: Mapping[str, str],
              name: str) -> Any:
    """``package``'s attribute ``name``: the public name from its module ``module_of[name]`` (a
    full module path), kept in ``namespace`` (the package's globals) so that later lookups are
    plain reads; else a submodule not imported yet; else ``AttributeError``."""
    module = module_of.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value
    try:  # a submodule not imported yet (``jamlab.spheres.aqs``, ...)
        return importlib.import_module(f"{package}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{package}.{name}":
            raise
    raise AttributeError(f"module {package!r} has no attribute {name!r}")


def names(namespace: Iterable[str], public: Iterable[str]) -> list[str]:
    """The package's ``dir()``: what it holds and what it would load."""
    return sorted(set(namespace) | set(public))
