"""θ = 0.42311 is written once (jamlab.paper, the literature value the theory takes) and the
numbers derived from it once (jamlab.theory.exponents); the paper's printed values once
(jamlab.paper). Anything else must use those, not re-type them."""

from pathlib import Path

import jamlab

SRC = Path(jamlab.__file__).parent
OWNERS = {SRC / "theory" / "exponents.py", SRC / "paper.py"}
LITERALS = ("0.42311", "0.706346", "1.41269", "1.415736")  # θ, μ_J, τ_J (1.412693), κ


def test_theta_and_its_exponents_are_not_retyped():
    found = [f"{path.relative_to(SRC)}:{i}: {literal}"
             for path in sorted(SRC.rglob("*.py")) if path not in OWNERS
             for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             for literal in LITERALS if literal in line]
    assert found == []


def test_the_owners_do_hold_them():
    assert "THETA_JAMMING = 0.42311" in (SRC / "paper.py").read_text()
    assert "PAPER_TAU_J = 1.41269" in (SRC / "paper.py").read_text()
    from jamlab.analysis.criticality import GAMMA, THETA_E
    from jamlab.theory import THETA_JAMMING, tau_jamming

    assert THETA_E == THETA_JAMMING == 0.42311 and abs(GAMMA - 0.41269) < 5e-6
    assert abs(tau_jamming() - 1.412693) < 5e-7
