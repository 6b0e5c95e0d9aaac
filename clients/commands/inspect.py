"""``plotgate inspect PATH...``: each file's state and time range, per-operation counts,
errors and latencies."""

import argparse
import json
from typing import Any

from plotgate.clients.commands.arguments import recording_filters
from plotgate.clients.commands.output import unreadable_exit, write


def add_command(sub: Any, filters: argparse.ArgumentParser) -> None:
    ins = sub.add_parser(
        "inspect",
        parents=[filters],
        help="each file's state and time range; per-operation counts, errors, latencies",
        description="Exit 0, or 2 when a file is not a recording at all (damage inside a "
        "file is listed with its offset, not an error).",
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
