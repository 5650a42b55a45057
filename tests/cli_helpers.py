"""Running the ``jamlab`` command in a subprocess, and its one-line error contract."""

from __future__ import annotations

import subprocess
import sys


def jamlab(*args: object, cwd=None, env=None, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run ``python -m jamlab ARGS`` (arguments converted with ``str``) and capture its output."""
    return subprocess.run(
        [sys.executable, "-m", "jamlab", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        env=env,
    )


def one_line_error(result: subprocess.CompletedProcess) -> str:
    """Assert a user error: exit code 2, one non-empty stderr line ``jamlab: error: …``, no
    traceback; return that line."""
    assert result.returncode == 2, (result.returncode, result.stdout, result.stderr)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("jamlab: error:") and "Traceback" not in result.stderr
    return lines[0]
