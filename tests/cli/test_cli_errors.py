"""The command line's contract: help works, user errors are one line with exit code 2."""

import subprocess
import sys


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "jamlab", *args], capture_output=True, text=True, timeout=120
    )


def test_help_and_version():
    r = run("--help")
    assert r.returncode == 0
    assert "Usage" in r.stdout
    r = run("--version")
    assert r.returncode == 0
    assert r.stdout.strip().count(".") >= 2


def test_unknown_command_is_one_line_exit_2():
    r = run("no-such-command")
    assert r.returncode == 2
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("jamlab: error:")
    assert "Traceback" not in r.stderr
