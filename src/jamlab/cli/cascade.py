"""``jamlab cascade``: sample static jumps of a Derrida–Ruelle cascade, plot them beside theory."""

from __future__ import annotations

import typer

from jamlab.cli._options import Force


def _floats(text: str, name: str) -> list[float]:
    try:
        return [float(t) for t in text.replace(" ", "").split(",") if t]
    except ValueError:
        raise ValueError(
            f"--{name} must be a comma-separated list of numbers, got {text!r}"
        ) from None


def register(app: typer.Typer) -> None:
    @app.command("cascade")
    def cascade(
        q: str = typer.Option(None, "--q", help="Level overlaps q_1..q_k, comma-separated."),
        y: str = typer.Option(None, "--y", help="Level parameters y_1..y_k, comma-separated."),
        linear: float = typer.Option(None, "--linear", help="y(q) = SLOPE q (use with --k)."),
        power_law: float = typer.Option(
            None, "--power-law", help="y(q) = A((1-q)^-MU - 1) + y0 (use with --k)."
        ),
        amplitude: float = typer.Option(
            None, "--amplitude", help="A of --power-law (default 1)."
        ),
        y0: float = typer.Option(
            None, "--y0", help="Atom of y' at q = 0 (y(0+); --linear, --power-law; default 0)."
        ),
        q_max: float = typer.Option(
            None, "--q-max", help="Cut-off: y constant above q_max (--linear, --power-law; "
            "default 1)."
        ),
        k: int = typer.Option(
            None, "--k", help="Levels when discretising --linear or --power-law (default 16, "
            "at most 4096)."
        ),
        dgamma: float = typer.Option(
            0.1, "--dgamma", help="Strain step δγ (bounded by the sampler's 5e7 nodes per sample: "
            "docs/theory-vs-cascade.md §3)."
        ),
        n: int = typer.Option(
            100_000, "--n", help="Number of samples (at most 1e10 nodes in all, by a bound up "
            "front and a projection while sampling: docs/theory-vs-cascade.md §3)."
        ),
        seed: int = typer.Option(1, "--seed", help="Random seed (explicit, reproducible)."),
        out: str = typer.Option("cascade.png", "--out", help="Histogram figure (PNG)."),
        csv: str = typer.Option(None, "--csv", help="Write the samples as CSV."),
        tree: str = typer.Option(
            None, "--tree", help="Also draw one sampled cascade (PNG): the first sample's, with "
            "the states within 1.5 of its ground states, at most 65534 nodes (a narrower window "
            "is noted on stderr and in the title; unsettled ground states are an error)."
        ),
        force: Force = False,
    ) -> None:
        """Sample jumps of the k-level cascade (SPEC §2) at strain δγ; histogram |ΔE| (log bins)
        beside the printed theory and the exact recursion; print p_no_jump sampled vs theory."""
        import numpy as np

        from jamlab import validation
        from jamlab.files import atomic_write, check_outputs
        from jamlab.plots.cascade import cascade_tree_figure, jump_histograms_figure
        from jamlab.theory.cascade import (
            MAX_LEVELS,
            TREE_MAX_NODES,
            sample_cascade_jumps,
            sample_cascade_tree,
            validate_levels,
        )
        from jamlab.theory.exact import exact_jump_R
        from jamlab.theory.jumps import jump_distribution
        from jamlab.theory.parisi import ParisiFunction

        validation.seed("--seed", seed)
        # the options of a Parisi function given by its formula, not by --q/--y levels
        shape = {"--amplitude": amplitude, "--y0": y0, "--q-max": q_max, "--k": k}
        for name, value in shape.items():
            if value is not None and q is not None:
                raise ValueError(f"{name} applies to --linear and --power-law, not to --q/--y")
        if amplitude is not None and linear is not None:
            raise ValueError("--amplitude applies to --power-law, not to --linear")
        amplitude = 1.0 if amplitude is None else amplitude
        y0 = 0.0 if y0 is None else y0
        q_max = 1.0 if q_max is None else q_max
        # beyond MAX_LEVELS the sampler's constants overflow; the discretisation alone would take
        # memory and time without end
        k = validation.integer("--k", 16 if k is None else k, minimum=1, maximum=MAX_LEVELS)
        n = validation.integer("--n", n, minimum=1, maximum=100_000_000)
        check_outputs({"--out": out, "--csv": csv, "--tree": tree}, force=force,
                      figures=("--out", "--tree"))
        given = [x is not None for x in (q, linear, power_law)]
        if sum(given) != 1:
            raise ValueError("give exactly one of --q/--y, --linear, --power-law")
        if q is not None:
            if y is None:
                raise ValueError("--q needs --y")
            qa, ya = validate_levels(_floats(q, "q"), _floats(y, "y"))
            parisi = ParisiFunction.steps(qa, ya)
            label = f"k={qa.size} steps"
        else:
            if y is not None:
                raise ValueError("--y goes with --q only")
            if linear is not None:
                parisi = ParisiFunction.linear(linear, y0=y0, q_max=q_max)
                label = f"y = {linear:g} q + {y0:g}, q_max = {q_max:g}, k = {k}"
            else:
                parisi = ParisiFunction.power_law(power_law, amplitude, y0=y0, q_max=q_max)
                label = f"power law μ={power_law:g}, A={amplitude:g}, q_max={q_max:g}, k={k}"
            qa, ya = validate_levels(*parisi.discretise(k))
        r = sample_cascade_jumps(qa, ya, dgamma, n, seed)
        # before anything is written: a tree whose ground states are not settled is an error
        t = None if tree is None else sample_cascade_tree(qa, ya, dgamma, seed)
        printed = jump_distribution(parisi, dgamma)

        def exact(x: np.ndarray) -> np.ndarray:
            return exact_jump_R(qa, ya, dgamma, np.minimum(x, 0.0))

        theories = {"printed formula (paper)": lambda x: np.asarray(printed.R(x)),
                    f"exact recursion (k={qa.size})": exact}
        jump_histograms_figure(r, theories, out, title=f"{label}, δγ = {dgamma:g}")
        p, se = r.p_no_jump()
        typer.echo(f"levels: k={qa.size}  dgamma={dgamma:g}  n={n}  seed={seed}")
        typer.echo(f"p_no_jump sampled          {p:.5f} ± {se:.5f}")
        typer.echo(f"p_no_jump printed formula  {float(printed.p_no_jump):.5f}")
        typer.echo(f"p_no_jump exact recursion  {float(exact(np.array([0.0]))[0]):.5f}")
        typer.echo(f"mean states drawn/sample   {r.n_states.mean():.2f}")
        typer.echo(f"figure: {out}")
        if csv is not None:
            data = np.column_stack([r.dE, r.dU, r.dSigma, r.q_jump, r.n_states])
            atomic_write(csv, lambda tmp: np.savetxt(
                tmp, data, delimiter=",", header="dE,dU,dSigma,q_jump,n_states", comments="",
                fmt="%.17g"))
            typer.echo(f"samples: {csv}")
        if t is not None:
            cascade_tree_figure(t, tree)
            if t.truncated:
                typer.echo(f"jamlab: note: the tree stopped at {TREE_MAX_NODES} nodes: it holds "
                           f"the states within {t.complete_window:.3g} of the ground states, not "
                           f"{t.window:g} (the figure's title says so)", err=True)
            typer.echo(f"tree: {tree}")
