"""The ``jamlab`` command line: a thin face over the library.

Each module in this package defines ``register(app)`` adding its commands; they are discovered
automatically so that command groups can grow independently. Errors a user can cause (bad
arguments, ``ValueError`` from the library, missing files) and errors of the environment
(``OSError``: a full disk, a read-only file system; ``MemoryError``: a size the machine cannot hold)
are printed as one line ``jamlab: error: ...`` on stderr with exit code 2 and no traceback.
"""

from __future__ import annotations

import errno
import functools
import importlib
import os
import pkgutil
import sys
from typing import Any

import typer

try:  # typer >= 0.20 vendors its own copy of click
    from typer._click.exceptions import NoArgsIsHelpError, UsageError
except ImportError:  # pragma: no cover - older typer on top of click
    from click.exceptions import NoArgsIsHelpError, UsageError

app = typer.Typer(
    name="jamlab",
    help="Static avalanches in jammed soft spheres and mean-field glasses.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG}


class UserError(Exception):
    """An error caused by the user's input; reported as one line with exit code 2."""


@app.callback(invoke_without_command=True)
def _root(
    ctx: typer.Context,
    version: bool = typer.Option(False, "--version", help="Print the jamlab version and exit."),
) -> None:
    if version:
        from jamlab import __version__

        typer.echo(__version__)
        raise typer.Exit(0)
    if ctx.invoked_subcommand is None:
        typer.echo(ctx.get_help())
        raise typer.Exit(0)


def _register_all() -> None:
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(app)


_register_all()


def fail(message: str) -> None:
    """Print ``jamlab: error: message`` and exit with code 2."""
    print(f"jamlab: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def flagged_note(path: os.PathLike | str) -> str | None:
    """``PATH is flagged ok=False by prepare (reason)`` when ``jamlab prepare`` flagged the
    configuration as failing its stopping rule (:func:`jamlab.spheres.io.failed_preparation`),
    else ``None``."""
    from jamlab.spheres.io import failed_preparation

    reason = failed_preparation(path)
    return None if reason is None else f"{path} is flagged ok=False by prepare ({reason})"


def warn_if_flagged(path: os.PathLike | str) -> None:
    """A ``jamlab: warning:`` line on stderr with :func:`flagged_note`, if there is one."""
    note = flagged_note(path)
    if note is not None:
        typer.echo(f"jamlab: warning: {note}", err=True)


@functools.cache
def _command() -> Any:
    """The click command of ``app``, built once per process (typer rebuilds it on every call)."""
    return typer.main.get_command(app)


def describe_os_error(exc: OSError) -> str:
    """One line for an ``OSError``: ``cannot write PATH: No space left on device``."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    where = f" {exc.filename}" if exc.filename else ""
    verb = "write" if exc.errno in _WRITE_ERRNOS else "access"
    return f"cannot {verb}{where}: {reason}".replace("\n", " ")


def interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` is, or was raised while handling, a ``KeyboardInterrupt``."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``jamlab`` command."""
    from jamlab import interrupts

    interrupts.install()  # Ctrl-C never inside numba's unpickling (a segmentation fault there)
    try:
        try:
            from jamlab.spheres import blas
            from jamlab.spheres.kernel_choice import environment_mode

            environment_mode()  # a bad JAMLAB_FORCE_KERNEL fails here, not inside a worker
            blas.environment_mode()  # and a bad JAMLAB_CHOLMOD_BLAS
            rv = _command().main(args=argv, prog_name="jamlab", standalone_mode=False)
        except Exception as exc:
            # Ctrl-C inside a compiled (numba) kernel surfaces as SystemError("... returned a
            # result with an exception set"), inside numba's compiler or cache as another error,
            # each chained to the KeyboardInterrupt: an abort, not a crash
            if interrupted(exc):
                raise KeyboardInterrupt from None
            raise
    except NoArgsIsHelpError as exc:
        print(exc.format_message())
        raise SystemExit(0) from None
    except UsageError as exc:
        # one line, no usage block and no traceback
        fail(exc.format_message().replace("\n", " "))
    except (typer.Abort, KeyboardInterrupt):
        print("jamlab: aborted", file=sys.stderr)
        raise SystemExit(130) from None
    except typer.Exit as exc:
        raise SystemExit(exc.exit_code) from None
    except (UserError, ValueError, FileNotFoundError, FileExistsError, PermissionError) as exc:
        fail(str(exc).replace("\n", " "))
    except OSError as exc:
        # the environment, not a bug: a full disk, a read-only file system, an I/O error
        fail(describe_os_error(exc))
    except MemoryError as exc:
        # a size the machine cannot hold (--n 1e14, --steps 1e11): one line, not a traceback
        detail = str(exc).split(";")[0].strip()
        fail(f"out of memory{': ' + detail if detail else ''} (a size too large for this "
             "machine?)")
    if rv == 130:  # typer's translation of a Ctrl-C (KeyboardInterrupt → exit code 130)
        print("jamlab: aborted", file=sys.stderr)
    raise SystemExit(rv if isinstance(rv, int) else 0)
