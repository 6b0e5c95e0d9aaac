"""``plotgate inspect PATH...``: each file's state and time range, per-operation counts,
errors and latencies."""

import argparse
import json
from typing import Any

from plotgate.clients.commands.arguments import command_parser, exit_status, recording_filters
from plotgate.clients.commands.output import unreadable_exit, write


def add_command(sub: Any, filters: argparse.ArgumentParser) -> None:
    ins = command_parser(
        sub,
        "inspect",
        parents=(filters,),
        summary="each file's state and time range; per-operation counts, errors, latencies",
        description="Prints a line per file (its state, time range and damage, and the scene "
        "messages of a file plotgate view wrote), then a table per operation: requests, "
        "answers, errors, replays and latency percentiles in milliseconds.",
        exits=exit_status(
            (0, "every file read (damage inside a file is listed with its offset, not an error)"),
            (2, "a usage error, a missing or unreadable file, or no recording among the paths"),
        ),
    )
    ins.add_argument("--json", action="store_true", help="print JSON instead of a table")
    ins.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.inspect import format_inspection, inspect

    summary = inspect(args.paths, recording_filters(args))
    if write(json.dumps(summary, indent=2) if args.json else format_inspection(summary)):
        return unreadable_exit(
            "inspect",
            args.paths,
            summary["unreadable"],
            summary["skipped"],
            summary["recordings"],
        )
    return 0
