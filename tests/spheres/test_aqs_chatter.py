"""A pair switched in and out of the contact set at one strain ends the branch at once.

The fixture (``tests/data/chatter``) is a real minimum at jamming whose step chattered: before
``CHATTER_SWITCHES`` the continuation switched one pair 999 times and ended only at the event
cap. The independent reference is that earlier behaviour (the cap, here lowered to 100 events
to keep the test short): the switches it makes are the one pair, alternately out and in, at one
strain, and its verdict is the one the chatter rule reaches after a few switches.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

import jamlab.spheres.aqs.continuation as continuation
from jamlab.spheres.aqs.parameters import AQSParameters
from jamlab.spheres.io import read_packing
from jamlab.spheres.neighbors import RELAX_SKIN, NeighborList

FIXTURE = Path(__file__).resolve().parents[1] / "data" / "chatter" / "jam1000-chatter.h5"
TARGET = 0.00034  # the step's end: the start is at 3.3e-4, δγ = 1e-5


@pytest.fixture(scope="module")
def start():
    return read_packing(FIXTURE)


def _continue(start, params, monkeypatch, switches_cap=None):
    log = []
    keeps_pd = continuation.switch_keeps_pd

    def logged(cur, ci, cj, fac, pi, pj, signs, prm):
        log.append((cur.strain, tuple(zip(pi.tolist(), pj.tolist(), signs.tolist(), strict=True))))
        return keeps_pd(cur, ci, cj, fac, pi, pj, signs, prm)

    monkeypatch.setattr(continuation, "switch_keeps_pd", logged)
    if switches_cap is not None:
        monkeypatch.setattr(continuation, "CHATTER_SWITCHES", switches_cap)
    nl = NeighborList(start, skin=RELAX_SKIN)
    branch = continuation.continue_network(start, None, TARGET, nl, 1e-12, params)
    return branch, log


def test_the_event_cap_alone_sees_one_pair_switched_back_and_forth(start, monkeypatch):
    params = replace(AQSParameters(), max_events=100)
    branch, log = _continue(start, params, monkeypatch, switches_cap=10**9)
    assert branch.packing is None and branch.events == params.max_events + 1
    assert len(log) == params.max_events
    strains = {s for s, _ in log}
    assert len(strains) == 1  # no progress in strain while it switches
    tail = [sw for _, sw in log[len(log) // 2:]]
    assert all(len(sw) == 1 and sw[0][:2] == tail[0][0][:2] for sw in tail)  # one pair
    signs = [sw[0][2] for sw in tail]
    assert all(a == -b for a, b in zip(signs, signs[1:], strict=False))  # out, in, out, …


def test_the_chatter_rule_ends_the_same_branch_after_a_few_switches(start, monkeypatch):
    branch, log = _continue(start, AQSParameters(), monkeypatch)
    assert branch.packing is None  # the cap's verdict: the branch ends, FIRE takes the step
    assert branch.events <= continuation.CHATTER_SWITCHES + 2
    assert len(log) <= continuation.CHATTER_SWITCHES + 1
