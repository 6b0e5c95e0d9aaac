"""The command's help: plain text (no reStructuredText), the defaults shown, and quick,
since it imports nothing heavy (no numpy, httpx, mcap or pydantic models)."""

import argparse
import os
import re
import subprocess
import sys

import pytest

from plotgate.clients.cli import build_parser, main

COMMANDS = ["serve", "replay", "recover", "call", "worker", "inspect", "cat", "plot", "study"]


@pytest.mark.parametrize("argv", [[]] + [[command] for command in COMMANDS])
def test_help_is_plain_text(argv, capsys):
    assert main([*argv, "--help"]) == 0
    out = capsys.readouterr().out
    assert "``" not in out and ":mod:" not in out and ":class:" not in out


def test_replay_help_shows_its_defaults(capsys):
    assert main(["replay", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "relative float tolerance (default 1e-09)" in out
    assert "absolute float tolerance (default 1e-12)" in out
    assert "(default 60; 0: no limit)" in out


@pytest.mark.parametrize("flag", ["--rtol", "--atol", "--timeout"])
@pytest.mark.parametrize("value", ["nan", "inf", "-1", "x"])
def test_replay_refuses_tolerances_and_timeouts_that_are_not_finite_and_positive(
    flag, value, tmp_path, capsys
):
    assert main(["replay", str(tmp_path), flag, value]) == 2
    assert f"argument {flag}: must be a" in capsys.readouterr().err


def test_help_imports_nothing_heavy():
    code = (
        "import sys\n"
        "from plotgate.clients.cli import main\n"
        "assert main(['--help']) == 0\n"
        "heavy = ['numpy', 'httpx', 'mcap', 'pydantic', 'plotgate.service.schemas']\n"
        "print([m for m in heavy if m in sys.modules])\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1] == "[]"


def test_call_still_checks_and_lists_the_operations(capsys):
    assert main(["call", "gates.nothing"]) == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'gates.nothing'" in err and "'gates.test'" in err
    assert main(["call", "--help"]) == 0
    assert "solves.position" in capsys.readouterr().out


def _commands() -> dict[str, argparse.ArgumentParser]:
    [choices] = [a.choices for a in build_parser()._actions if isinstance(a.choices, dict)]
    return dict(choices)


def test_every_command_is_checked_here():
    assert set(_commands()) == {*COMMANDS, "view", "scenario"}


@pytest.mark.parametrize("command", sorted(_commands()))
def test_every_help_has_one_form(command, capsys):
    """A description, the exit statuses, defaults as "(default X)", no line over 100
    characters (issue 37)."""
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    description = out.split("\n\n")[1]
    assert not description.startswith(("positional arguments:", "options:")), out
    assert "\nexit status:\n  0  " in out
    assert "  2  " in out.split("\nexit status:\n")[1]
    assert max(map(len, out.splitlines())) <= 100
    for action in _commands()[command]._actions:
        text = (action.help or "").replace("%(default)", "")
        if action.default not in (None, False, argparse.SUPPRESS):
            assert "(default " in text, (action.dest, text)
        assert len(re.findall(r"\bdefault\b", text)) == text.count("(default "), text


def test_usage_lines_are_wrapped_at_a_terminals_width():
    done = subprocess.run(
        [sys.executable, "-m", "plotgate.clients.cli", "replay", "--help"],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "80"},
    )
    assert done.returncode == 0
    assert max(map(len, done.stdout.splitlines())) <= 80


@pytest.mark.parametrize("command", ["inspect", "cat", "replay", "view"])
def test_an_unknown_operation_is_refused_naming_the_operations(command, tmp_path, capsys):
    args = [command, str(tmp_path), "--operation", "gates.test,gates.tset"]
    assert main(args + (["-o", str(tmp_path / "v.mcap")] if command == "view" else [])) == 2
    err = capsys.readouterr().err
    assert "no operation 'gates.tset'" in err and "gates.probability" in err
