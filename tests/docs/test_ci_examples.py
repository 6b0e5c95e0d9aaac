"""The CI job examples in ``docs/ci/`` (linked from docs/recording.md, "Replay in CI")
run commands that exist: every ``plotgate ...`` command in them parses with the real
``plotgate`` parser, with those flags and values (the command itself is not run: the
examples replay a folder of recordings of their own)."""

import shlex
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from plotgate.clients import cli
from plotgate.clients.commands import replay as replay_command

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "docs" / "ci").glob("*.yml"))


def _strings(node: Any) -> Iterator[str]:
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for value in node.values():
            yield from _strings(value)
    elif isinstance(node, list):
        for value in node:
            yield from _strings(value)


def _commands(path: Path) -> list[list[str]]:
    found = []
    for text in _strings(yaml.safe_load(path.read_text())):
        for line in text.splitlines():
            words = shlex.split(line.strip()) if "plotgate " in line else []
            if words and words[0] == "plotgate":
                found.append(words[1:])
    return found


def test_there_are_examples():
    assert {p.name for p in EXAMPLES} >= {"github-replay.yml", "gitlab-replay.yml"}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_every_plotgate_command_parses_with_the_real_parser(path, monkeypatch, capsys):
    commands = _commands(path)
    assert commands, f"{path.name} runs no plotgate command"
    parsed = []
    monkeypatch.setattr(replay_command, "run", lambda args: parsed.append(args) or 0)
    for argv in commands:
        assert cli.main(argv) == 0, (argv, capsys.readouterr().err)
    assert len(parsed) == len(commands)
