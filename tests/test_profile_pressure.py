"""``scripts/profile_pressure.py``: its count of backbone orderings against the factorisations
counted apart (one ordering per ``linalg.factorise``), and its printed groups within the profile."""

from __future__ import annotations

import re

from tests.script_helpers import script_module

import jamlab.spheres.aqs.continuation as continuation
import jamlab.spheres.aqs.linalg as linalg
import jamlab.spheres.aqs.saddle as saddle
import jamlab.spheres.aqs.steps as steps
import jamlab.spheres.newton_relax as newton_relax


def test_orderings_are_the_factorisations(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(linalg, "nested_dissection", linalg.nested_dissection)  # restored after
    factorised = []
    inner = linalg.factorise

    def counted(*a, **k):
        factorised.append(1)
        return inner(*a, **k)

    for module in (linalg, newton_relax, continuation, steps, saddle):
        monkeypatch.setattr(module, "factorise", counted)
    prof = script_module("profile_pressure")
    calls = {}
    wrap = prof.count_orderings

    def keep():  # installed after the warm-up run: from here on both count the profiled run
        factorised.clear()
        calls.update(t=wrap())
        return calls["t"]

    monkeypatch.setattr(prof, "count_orderings", keep)
    assert prof.main(["--n", "64", "--steps", "15", "--pressure", "1e-3", "--dgamma", "1e-4",
                      "--cache", str(tmp_path), "--top", "5"]) == 0
    out = capsys.readouterr().out
    tally = calls["t"]
    assert 0 < tally["calls"] == len(factorised)  # one ordering per factorisation
    assert 0 <= tally["repeats"] < tally["calls"]
    total = float(re.search(r"plastic: ([0-9.]+) s profiled", out).group(1))
    shares = [float(v) for v in re.findall(r"\| (-?[0-9.]+) \| -?[0-9.]+ % \|", out)]
    assert len(shares) == len(prof.GROUPS) + 1
    # every printed number is rounded to 0.01 s: at most 0.005 s off each
    assert abs(sum(shares) - total) <= 0.005 * (len(shares) + 1) + 1e-9


def test_bad_arguments():
    prof = script_module("profile_pressure")
    import pytest

    for argv in (["--steps", "0"], ["--top", "-1"]):
        with pytest.raises(SystemExit) as err:
            prof.main(argv)
        assert err.value.code == 2
