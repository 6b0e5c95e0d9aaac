"""Arguments several commands share: argparse types, the recording filters, the operation
names, and where a command computes (--server, --dask, --local-workers)."""

import argparse
import math
import textwrap
from collections.abc import Callable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any


def at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``minimum``."""

    def integer(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {text!r}")
        return value

    return integer


def finite(what: str) -> Callable[[str], float]:
    """An argparse type: a finite number >= 0, ``what`` naming it in the refusal."""

    def number(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = -1.0
        if not 0 <= value < math.inf:
            raise argparse.ArgumentTypeError(f"must be {what} >= 0, got {text!r}")
        return value

    return number


seconds = finite("a number of seconds")
tolerance = finite("a finite number")
"""Tolerances of replay's comparison: numpy.isclose warns on non-finite ones, and a NaN
tolerance would call every number changed."""


def at_least_two(text: str) -> int:
    value = int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"must be at least 2, got {value}")
    return value


def parse_time(text: str) -> int:
    """A time on the command line (ISO 8601, UTC unless it says; or Unix seconds) as ns."""
    try:
        return round(float(text) * 1e9)
    except ValueError:
        pass
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"not a time: {text!r} (ISO 8601 such as 2024-05-01T12:00:00Z, or Unix seconds)"
        ) from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return round(when.timestamp() * 1e9)


class OperationNames:
    """The operation names ``call`` takes, read from the wire schemas only when argparse
    asks (to check or show ``call``'s argument): importing the schemas' pydantic models
    costs more than the rest of ``plotgate --help``."""

    def _names(self) -> list[str]:
        from plotgate.service.table import ENDPOINTS

        return sorted(ENDPOINTS)

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())


def add_where(
    command: Any,
    server_help: str,
    dask_help: str = "in-process, with the Monte Carlo chunks on this Dask scheduler",
    workers_help: str = "in-process, with the Monte Carlo chunks on a local Dask cluster of "
    "N worker processes (started and stopped by the command)",
    server_action: type[argparse.Action] | str = "store",
) -> None:
    """Where a command computes: ``--server URL``, or in-process with its chunks on
    ``--dask ADDRESS`` or ``--local-workers N`` (or in this process); one of the three.
    ``server_action`` takes ``--server`` (replay's may be given twice)."""
    where = command.add_mutually_exclusive_group()
    where.add_argument("--server", action=server_action, help=server_help)
    where.add_argument("--dask", metavar="ADDRESS", help=dask_help)
    where.add_argument("--local-workers", type=at_least(1), metavar="N", help=workers_help)


def operations(text: str) -> str:
    """An argparse type: operation names, comma-separated, each one of this build's (a typo
    would otherwise filter everything out and pass as an empty recording)."""
    known = list(OperationNames())
    unknown = [op.strip() for op in text.split(",") if op.strip() and op.strip() not in known]
    if unknown:
        raise argparse.ArgumentTypeError(
            f"no operation {', '.join(map(repr, unknown))}; the operations: {', '.join(known)}"
        )
    return text


def filter_parser() -> argparse.ArgumentParser:
    """The parent parser of the commands that read recordings: PATH..., --operation,
    --since, --until."""
    filters = argparse.ArgumentParser(add_help=False)
    filters.add_argument(
        "paths",
        nargs="+",
        type=Path,
        metavar="PATH",
        help="MCAP files or folders of them (requests and responses are "
        "paired across all of them)",
    )
    filters.add_argument(
        "--operation",
        action="append",
        type=operations,
        metavar="OP",
        help="only this operation (repeat, or comma-separate, for several)",
    )
    filters.add_argument(
        "--since",
        type=parse_time,
        metavar="TIME",
        help="only requests from this time on (ISO 8601, UTC unless it says; or Unix seconds)",
    )
    filters.add_argument(
        "--until",
        type=parse_time,
        metavar="TIME",
        help="only requests before this time (as --since)",
    )
    return filters


def recording_filters(args: argparse.Namespace):
    from plotgate.clients.recordings import Filters

    operations = frozenset(
        op.strip() for ops in args.operation or () for op in ops.split(",") if op.strip()
    )
    return Filters(operations, args.since, args.until)


HELP_WIDTH = 79
"""Columns of a command's description and exit statuses (argparse wraps the options' help
to the terminal, 80 columns when there is none)."""

USAGE_ERROR = (2, "a usage error (argparse's message)")


def exit_status(*codes: tuple[int, str], note: str = "") -> str:
    """A command's ``exit status:`` section: each code and its meaning on wrapped lines,
    then ``note`` as a paragraph."""
    lines = ["exit status:"]
    for code, meaning in codes:
        lines += textwrap.wrap(
            meaning, HELP_WIDTH, initial_indent=f"  {code}  ", subsequent_indent="     "
        )
    if note:
        lines += ["", *textwrap.wrap(note, HELP_WIDTH)]
    return "\n".join(lines)


def command_parser(
    sub: Any,
    name: str,
    *,
    summary: str,
    description: str,
    exits: str,
    parents: tuple[argparse.ArgumentParser, ...] = (),
) -> argparse.ArgumentParser:
    """A command's parser in the one form of plotgate's help: ``summary`` in the list of
    commands, ``description`` (paragraphs separated by blank lines) wrapped, then its
    exit statuses (:func:`exit_status`)."""
    paragraphs = (
        textwrap.fill(" ".join(p.split()), HELP_WIDTH) for p in description.split("\n\n")
    )
    return sub.add_parser(
        name,
        parents=list(parents),
        help=summary,
        description="\n\n".join(paragraphs),
        epilog=exits,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
