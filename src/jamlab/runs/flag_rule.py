"""Which rule made a finished fixed-pressure sample's plastic flags (``jamlab status``).

Until 2026-12-02 a candidate step that the Newton relaxer continued through (no FIRE) was
always called a kink; since then it is flagged plastic when it released for certain more than
``confirm_below`` units, as any other candidate (``docs/aqs.md``, "Jumps Newton continued
through"). A sample made since records how many it flagged that way
(``shear_n_candidates_continued_sure``); one made before does not, and its flags are the old
rule's (``scripts/continued_jumps.py scan`` counts, from its stored rows, what that rule missed).

Until 2026-12-03 a candidate the chain redid was a kink unless one of its pieces kept more than a
quarter of the step's residual; since then the chain's largest piece is redone smaller and the
step is flagged when its residual holds above the run's threshold (``docs/aqs.md``, "The chain's
share misses small jumps"). A sample made since records how many it flagged that way
(``shear_n_candidates_held``); ``scripts/continued_jumps.py reflag`` replays one made before and
judges it again.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from jamlab.runs.study import SampleKey, Study

__all__ = ["CONTINUED_SURE", "FLAG_RULE_ATTRS", "HELD", "flag_rule_lines"]

CONTINUED_SURE = "shear_n_candidates_continued_sure"
"""The sample attribute a fixed-pressure sample made since 2026-12-02 carries."""
HELD = "shear_n_candidates_held"
"""The sample attribute a fixed-pressure sample made by the current rule carries."""
FLAG_RULE_ATTRS: tuple[str, ...] = (CONTINUED_SURE, HELD)
"""The sample attributes :func:`flag_rule_lines` reads."""


def flag_rule_lines(study: Study, attrs: Mapping[SampleKey, Mapping[str, Any]]) -> list[str]:
    """The lines on the rules behind the finished samples' flags (``attrs``: each finished
    sample's root attributes, :data:`FLAG_RULE_ATTRS` among those read); empty at constant
    volume or with no finished sample."""
    if study.pressure is None or not attrs:
        return []
    before = sum(CONTINUED_SURE not in a for a in attrs.values())
    between = sum(CONTINUED_SURE in a and HELD not in a for a in attrs.values())
    lines = []
    if before:
        lines.append(f"plastic flags: {before} of {len(attrs)} finished samples by the rule "
                     "before 2026-12-02, which called every candidate the Newton relaxer "
                     "continued a kink (docs/aqs.md, \"Jumps Newton continued through\"; "
                     "scripts/continued_jumps.py scan counts what it missed)")
    if between:
        lines.append(f"plastic flags: {between} of {len(attrs)} finished samples by the rule "
                     "before 2026-12-03, which called a kink every redone candidate none of "
                     "whose pieces kept a quarter of its residual (docs/aqs.md, \"The chain's "
                     "share misses small jumps\"; scripts/continued_jumps.py reflag judges "
                     "them again)")
    if before or between:
        return lines
    added = sum(int(a[CONTINUED_SURE]) for a in attrs.values())
    held = sum(int(a[HELD]) for a in attrs.values())
    return [f"plastic flags: the current rule; {added} candidate(s) the Newton relaxer continued "
            f"flagged plastic for the enthalpy they surely released, {held} whose residual a "
            "piece held when redone smaller"]
