"""Which rule made a finished fixed-pressure sample's plastic flags (``jamlab status``).

Until 2026-12-02 a candidate step that the Newton relaxer continued through (no FIRE) was
always called a kink; since then it is flagged plastic when it released for certain more than
``confirm_below`` units, as any other candidate (``docs/aqs.md``, "Jumps Newton continued
through"). A sample made since records how many it flagged that way
(``shear_n_candidates_continued_sure``); one made before does not, and its flags are the old
rule's (``scripts/continued_jumps.py scan`` counts, from its stored rows, what that rule missed).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from jamlab.runs.study import SampleKey, Study

__all__ = ["CONTINUED_SURE", "flag_rule_lines"]

CONTINUED_SURE = "shear_n_candidates_continued_sure"
"""The sample attribute a fixed-pressure sample made by the current rule carries."""


def flag_rule_lines(study: Study, attrs: Mapping[SampleKey, Mapping[str, Any]]) -> list[str]:
    """One line on the rule behind the finished samples' flags (``attrs``: each finished
    sample's root attributes, :data:`CONTINUED_SURE` among those read); empty at constant
    volume or with no finished sample."""
    if study.pressure is None or not attrs:
        return []
    before = sum(CONTINUED_SURE not in a for a in attrs.values())
    added = sum(int(a[CONTINUED_SURE]) for a in attrs.values() if CONTINUED_SURE in a)
    if before:
        return [f"plastic flags: {before} of {len(attrs)} finished samples by the rule before "
                "2026-12-02, which called every candidate the Newton relaxer continued a kink "
                "(docs/aqs.md, \"Jumps Newton continued through\"; scripts/continued_jumps.py "
                "scan counts what it missed)"]
    return [f"plastic flags: the current rule; {added} candidate(s) the Newton relaxer continued "
            "flagged plastic for the enthalpy they surely released"]
