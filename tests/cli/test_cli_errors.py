"""The command line's contract: help works, user errors are one line with exit code 2."""

from cli_helpers import jamlab, one_line_error


def test_help_and_version():
    r = jamlab("--help")
    assert r.returncode == 0
    assert "Usage" in r.stdout
    r = jamlab("--version")
    assert r.returncode == 0
    assert r.stdout.strip().count(".") >= 2


def test_unknown_command_is_one_line_exit_2():
    one_line_error(jamlab("no-such-command"))
