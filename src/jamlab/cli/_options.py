"""Options shared by several commands."""

from __future__ import annotations

from typing import Annotated

import typer

Force = Annotated[
    bool,
    typer.Option("--force", help="Replace output files that exist already (never an input)."),
]
"""``--force``: :func:`jamlab.files.check_outputs` refuses an existing output file without it."""
