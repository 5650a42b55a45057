"""Running the ``jamlab`` command in a subprocess or in this process, and its one-line error
contract."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import time
from pathlib import Path


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


def run_in_process(args: list) -> int:
    """Run ``jamlab ARGS`` in this process (arguments converted with ``str``; output left to
    ``capsys``) and return its exit code."""
    import pytest

    from jamlab.cli import main

    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    return int(exc.value.code)


def error_line(capsys) -> str:
    """Assert that the command just run in this process wrote exactly one non-empty stderr line
    ``jamlab: error: …``; return it."""
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("jamlab: error:"), err
    return lines[0]


def digest(path) -> str:
    """The sha256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def one_line_error(result: subprocess.CompletedProcess) -> str:
    """Assert a user error: exit code 2, one non-empty stderr line ``jamlab: error: …``, no
    traceback; return that line."""
    assert result.returncode == 2, (result.returncode, result.stdout, result.stderr)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("jamlab: error:") and "Traceback" not in result.stderr
    return lines[0]


def wait_for_file(proc: subprocess.Popen, path: Path, poll: float) -> None:
    """Poll every ``poll`` s until ``path`` exists or ``proc`` has exited."""
    while not path.exists() and proc.poll() is None:
        time.sleep(poll)


def shear_loop_seconds(packing: Path, args: tuple[str, ...], out: Path, poll: float) -> float:
    """Run ``jamlab shear PACKING ARGS --out OUT`` to its end (exit 0 asserted) and return the
    wall time from the trace's first appearance (its first checkpoint) to the end: the stepping
    loop, without Python's start-up, to aim SIGKILLs at."""
    proc = subprocess.Popen([sys.executable, "-m", "jamlab", "shear", str(packing), *args,
                             "--out", str(out)], stdout=subprocess.DEVNULL)  # fmt: skip
    wait_for_file(proc, out, poll)
    start = time.perf_counter()
    assert proc.wait() == 0
    return time.perf_counter() - start
