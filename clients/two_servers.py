"""``plotgate replay --calibrate OUT --server A --server B``: noise learned from the
disagreement of two known-good servers (Twitter's Diffy).

The recording is replayed against A, then against B. Every disagreement is gathered
(:class:`~plotgate.clients.calibrate.Noise`): recorded against A, recorded against B, and A
against B, exchange by exchange. A's answers wait for B's in a temporary file, one JSON line
each, so memory stays bounded however long the recording. A second ``--server`` is taken
only with ``--calibrate`` (:func:`check_servers`).
"""

import argparse
import json
import sys
import tempfile
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from plotgate.clients.calibrate import Noise
    from plotgate.clients.replay import ReplayReport

__all__ = ["MisalignedAnswers", "Servers", "check_servers", "gather_two"]


class Servers(argparse.Action):
    """``--server URL``, which may be given again: the first goes to ``server``, the later
    ones to ``more_servers`` (judged by :func:`check_servers`)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        if getattr(namespace, self.dest) is None:
            setattr(namespace, self.dest, values)
        else:
            namespace.more_servers = (*getattr(namespace, "more_servers", ()), values)


def check_servers(args: argparse.Namespace) -> int | None:
    """None when the ``--server`` options are right: one, or two with ``--calibrate``;
    else 2 after a one-line message on stderr."""
    more = getattr(args, "more_servers", ())
    if not more or (args.calibrate is not None and len(more) == 1):
        return None
    print(
        "plotgate replay: --server is given once, or twice with --calibrate (two known-good "
        "servers whose disagreement is the noise)",
        file=sys.stderr,
    )
    return 2


class MisalignedAnswers(Exception):
    """The two servers answered different exchanges (one set one aside as a fault)."""


def gather_two(
    servers: tuple[str, str],
    replay_once: Callable[..., "ReplayReport"],
    noise: "Noise",
    allow_empty: bool,
) -> "ReplayReport":
    """Replay against both ``servers`` gathering every disagreement into ``noise``; the
    first report whose exit code is 2, else B's.

    Raises :class:`MisalignedAnswers` when A and B compared different exchanges."""
    with tempfile.TemporaryFile("w+", encoding="utf-8") as answers:

        def from_a(operation: str, recorded: Any, replayed: Any) -> None:
            noise.add(operation, recorded, replayed)
            answers.write(json.dumps([operation, replayed]) + "\n")

        first = replay_once(server=servers[0], observe=from_a)
        noise.runs += 1
        if first.exit_code(allow_empty) == 2:
            return first
        answers.seek(0)

        def from_b(operation: str, recorded: Any, replayed: Any) -> None:
            noise.add(operation, recorded, replayed)
            line = answers.readline()
            if not line or json.loads(line)[0] != operation:
                raise MisalignedAnswers
            noise.add(operation, json.loads(line)[1], replayed)
            noise.exchanges -= 1  # one exchange, compared twice

        second = replay_once(server=servers[1], observe=from_b)
        noise.runs += 1
        if answers.readline():
            raise MisalignedAnswers
    return second
