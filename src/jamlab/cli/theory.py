"""``jamlab theory``: draw the mean-field jump distribution ``P(ΔE|δγ)`` (paper Fig. 3)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from jamlab.cli._options import Force
from jamlab.cli.multivalue import expand_multi_values, multi_value_command

THEORY_DGAMMA = (1e-30, 1e6)
"""Accepted ``|δγ|`` of ``jamlab theory``."""

def expand_dgamma(args: list[str]) -> list[str]:
    """Rewrite ``--dgamma a b c`` as ``--dgamma a --dgamma b --dgamma c``
    (:func:`jamlab.cli.multivalue.expand_multi_values`)."""
    return expand_multi_values(args, ("--dgamma",))


_TheoryCommand = multi_value_command(("--dgamma",))


def theory(
    out: Annotated[Path, typer.Option("--out", help="Output figure (PNG, PDF, SVG).")],
    mu: Annotated[
        float | None,
        typer.Option("--mu", help="Exponent μ of y'(q) ~ (1-q)^(-μ-1) (default μ_J: jamming)."),
    ] = None,
    dgamma: Annotated[
        list[float] | None,
        typer.Option("--dgamma", help="Strain steps δγ (several values: --dgamma 1e-2 1e-3)."),
    ] = None,
    csv: Annotated[
        Path | None, typer.Option("--csv", help="Also write the numbers as CSV.")
    ] = None,
    q_max: Annotated[float, typer.Option("--q-max", help="Cut-off q_max in (0, 1].")] = 1.0,
    amplitude: Annotated[float, typer.Option("--amplitude", help="Amplitude A of y(q).")] = 1.0,
    points: Annotated[int, typer.Option("--points", help="Points per curve.")] = 300,
    force: Force = False,
) -> None:
    """Draw P(ΔE|δγ) of the printed mean-field formula for y(q) = A((1-q)^-μ - 1), like Fig. 3."""
    import numpy as np

    from jamlab import validation
    from jamlab.cli import UserError
    from jamlab.files import check_outputs
    from jamlab.plots.theory import JUMP_RANGE_TOP, plot_jump_distributions
    from jamlab.theory import ParisiFunction, jump_distribution, mu_jamming

    mu = mu_jamming() if mu is None else mu
    dgammas = list(dgamma) if dgamma else [1e-2, 1e-3, 1e-4]
    for dg in dgammas:
        # a strain step is a small number: |δγ| in [1e-30, 1e6] (beyond, the formula overflows)
        validation.number("|--dgamma|", abs(dg), low=THEORY_DGAMMA[0], high=THEORY_DGAMMA[1])
    validation.integer("--points", points, minimum=2, maximum=1_000_000)
    pf = ParisiFunction.power_law(mu, amplitude=amplitude, q_max=q_max)  # validates them
    if amplitude == 0.0:
        raise UserError("--amplitude 0: y(q) = 0 has no jumps (P(no jump) = 1), nothing to draw")
    for dg in dgammas:
        # the figure draws |ΔE| up to JUMP_RANGE_TOP·|δγ|: refuse a δγ whose jumps lie beyond
        with np.errstate(over="ignore"):  # a huge amplitude overflows y: refused just below
            dist = jump_distribution(pf, dg)
            jumps = 1.0 - dist.p_no_jump
            beyond = float(dist.cdf(-JUMP_RANGE_TOP * abs(dg)))
        if jumps == 0.0 or beyond > 0.01 * jumps:
            raise UserError(
                f"--dgamma {dg:g}: {beyond / jumps if jumps else 0.0:.3g} of the jump probability "
                f"(P(jump) = {jumps:.3g}) lies above |ΔE| = {JUMP_RANGE_TOP:g}|δγ|, the figure's "
                "range (drawn for small steps): give a smaller |δγ| or --amplitude")
    check_outputs({"--out": out, "--csv": csv}, force=force, figures=("--out",))
    table = plot_jump_distributions(
        mu, dgammas, out, q_max=q_max, amplitude=amplitude, n_points=points, csv=csv
    )
    typer.echo(f"wrote {out}" + (f" and {csv}" if csv else ""))
    for dg, t in table.items():
        typer.echo(f"  δγ = {dg:g}: P(no jump) = {float(t['p_no_jump'][0]):.6g}")


def register(app: typer.Typer) -> None:
    app.command("theory", cls=_TheoryCommand)(theory)
