"""``scripts/sample_cost.py``'s tally of the Newton relaxer's calls by their place in the enthalpy
minimisation: each minimisation by the relaxer itself makes one first call and one call per volume
step, so the tally must equal those minimisations counted apart and the ``volume_steps`` their
results report."""

from __future__ import annotations

from tests.script_helpers import script_module

import jamlab.spheres.barostat as barostat
import jamlab.spheres.newton_relax as relax_module
import jamlab.spheres.pressure_shear as ps
from jamlab.spheres.packing import jam


def test_tally_matches_the_minimisations(monkeypatch):
    for module, name in ((barostat, "minimize_enthalpy"), (ps, "minimize_enthalpy"),
                         (relax_module.NewtonRelaxer, "__call__")):
        monkeypatch.setattr(module, name, getattr(module, name))  # restored after the test
    sample_cost = script_module("sample_cost")
    tally = sample_cost.instrument_volume_steps()
    results = []
    tallied = barostat.minimize_enthalpy

    def recorded(*a, **k):
        res = tallied(*a, **k)
        # (the confirmation's probes pass the relaxer's ``newton_only``, not the relaxer)
        if isinstance(k.get("relax"), relax_module.NewtonRelaxer):
            results.append(res)
        return res

    monkeypatch.setattr(barostat, "minimize_enthalpy", recorded)
    monkeypatch.setattr(ps, "minimize_enthalpy", recorded)
    pk = jam(64, 3, seed=2, p_target=1e-3).packing
    ps.shear_at_pressure(pk, 1e-4, pressure=1e-3, n_steps=20)
    first = sum(v for k, v in tally.items() if k[0] == 0 and k[2] == "calls")
    later = sum(v for k, v in tally.items() if k[0] > 0 and k[2] == "calls")
    assert len(results) >= 20  # every step
    assert first == len(results)
    assert later == sum(r.volume_steps for r in results) > 0
    assert all(v >= 0 for v in tally.values())
