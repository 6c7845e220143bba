"""`python -m flexlift` is the `flexlift` command (issue 10)."""

import subprocess
import sys

from flexlift import __version__


def test_python_dash_m_flexlift_is_the_command():
    out = subprocess.run([sys.executable, "-m", "flexlift", "--version"], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == f"flexlift {__version__}"
    bad = subprocess.run([sys.executable, "-m", "flexlift", "loads", "no-such.yaml"],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


def test_help_is_terminal_text_not_rest(capsys):
    """--help prints the commands' descriptions without reST marks (``x``, :func:`x`)."""
    from flexlift.cli import COMMANDS, main

    for command in COMMANDS:
        try:
            assert main([command, "--help"]) == 0
        except SystemExit as stop:
            assert stop.code == 0
        out = capsys.readouterr().out
        assert "``" not in out and ":func:" not in out and ":mod:" not in out, command
