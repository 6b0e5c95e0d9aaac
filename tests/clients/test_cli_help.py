"""The command's help: plain text (no reStructuredText), the defaults shown, and quick,
since it imports nothing heavy (no numpy, httpx, mcap or pydantic models)."""

import subprocess
import sys

import pytest

from plotgate.clients.cli import main

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
