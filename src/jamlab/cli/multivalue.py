"""Options that take several space-separated values (``--phi 0.75 0.8``, ``--dgamma 1e-2 1e-3``).

click options take one value each, so the command line is rewritten before click parses it:
``--phi a b c`` becomes ``--phi a --phi b --phi c``. Values run until the next option (a token
starting with ``-`` that is not a negative number), ``--`` or a ``*.toml`` file name (the study
file of ``jamlab run`` may follow the values). An option given with no value at all is refused
(``ValueError`` naming it: a one-line error of the command) instead of the command silently
using its default, or click taking the next option as its value.
"""

from __future__ import annotations

import re
from typing import Any

from typer.core import TyperCommand

__all__ = ["expand_multi_values", "multi_value_command"]

_NUMBER = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)


def expand_multi_values(args: list[str], options: tuple[str, ...]) -> list[str]:
    """``args`` with every option of ``options`` repeated once per value (module docstring);
    ``ValueError`` for an option of ``options`` given without a value."""
    out: list[str] = []
    current: str | None = None
    values = 0

    def close() -> None:
        if current is not None and values == 0:
            raise ValueError(f"option {current} requires a value")

    for token in args:
        if token in options:
            close()
            current, values = token, 0
        elif current is not None and (not token.startswith("-") or _NUMBER.match(token)):
            if token.endswith(".toml"):
                close()
                current = None
                out.append(token)
            else:
                out.extend([current, token])
                values += 1
        else:
            if token == "--" or token.startswith("-"):
                close()
                current = None
            out.append(token)
    close()
    return out


def multi_value_command(options: tuple[str, ...]) -> type[TyperCommand]:
    """A typer command class whose ``options`` accept several space-separated values."""

    class MultiValueCommand(TyperCommand):
        def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
            return super().parse_args(ctx, expand_multi_values(list(args), options))

    return MultiValueCommand
