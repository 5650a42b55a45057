"""The main entry points carry numpydoc docstrings whose Examples run (doctest).

Each name in ENTRY_POINTS must have ``Parameters``, ``Returns`` and ``Examples`` sections, at
least one ``>>>`` example in its Examples section, and every example must give the output
written under it. Examples import what they use (they run with empty globals) and run in a
temporary directory. Add an entry point here when its docstring gets an example.
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import io

import pytest

ENTRY_POINTS = [
    "jamlab.analysis.powerlaw.fit_power_law",
    "jamlab.reproduce.reproduce",
    "jamlab.spheres.packing.jam",
    "jamlab.spheres.packing.prepare",
    "jamlab.theory.jumps.jump_distribution",
    "jamlab.theory.cascade.sample_cascade_jumps",
    "jamlab.runs.load.open_run",
    "jamlab.spheres.aqs.driver.shear",
]

SECTIONS = ("Parameters", "Returns", "Examples")


def resolve(dotted: str):
    """The object named ``dotted`` (a module path followed by attribute names)."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(f"cannot import {dotted}")


def docstring_problems(obj, name: str) -> list[str]:
    """What is wrong with ``obj``'s docstring: missing sections, no example, failing examples."""
    doc = inspect.getdoc(obj) or ""
    problems = [f"{name}: no '{s}' section" for s in SECTIONS
                if f"\n{s}\n{'-' * len(s)}\n" not in f"\n{doc}\n"]
    examples = doc.split("\nExamples\n--------\n", 1)[-1] if "\nExamples\n" in doc else ""
    if ">>>" not in examples:
        problems.append(f"{name}: no >>> example in its Examples section")
        return problems
    tests = doctest.DocTestFinder(recurse=False).find(obj, name, globs={})
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report = io.StringIO()
    for test in tests:
        runner.run(test, out=report.write)
    if runner.failures:
        problems.append(f"{name}: {runner.failures} failing example(s)\n{report.getvalue()}")
    return problems


@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_entry_point_docstring_has_running_examples(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert docstring_problems(resolve(name), name) == []


def _no_example(x: float) -> float:
    """Twice ``x``.

    Parameters
    ----------
    x : float

    Returns
    -------
    float

    Examples
    --------
    Only prose here.
    """
    return 2 * x


def _wrong_example(x: float) -> float:
    """Twice ``x``.

    Parameters
    ----------
    x : float

    Returns
    -------
    float

    Examples
    --------
    >>> 2 * 3
    7
    """
    return 2 * x


def _no_sections(x: float) -> float:
    """Twice ``x``.

    >>> 2 * 3
    6
    """
    return 2 * x


def test_the_check_catches_a_missing_or_failing_example():
    assert docstring_problems(_no_example, "f") == ["f: no >>> example in its Examples section"]
    (problem,) = docstring_problems(_wrong_example, "f")
    assert problem.startswith("f: 1 failing example(s)") and "Expected:\n    7" in problem
    assert docstring_problems(_no_sections, "f") == [
        "f: no 'Parameters' section", "f: no 'Returns' section", "f: no 'Examples' section",
        "f: no >>> example in its Examples section"]
