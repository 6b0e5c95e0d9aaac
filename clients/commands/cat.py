"""``plotgate cat PATH...``: the exchanges as JSON lines."""

import argparse
import sys
from typing import Any

from plotgate.clients.commands.arguments import command_parser, exit_status, recording_filters
from plotgate.clients.commands.output import unreadable_exit, write


def add_command(sub: Any, filters: argparse.ArgumentParser) -> None:
    cat = command_parser(
        sub,
        "cat",
        parents=(filters,),
        summary="print the exchanges as JSON lines",
        description="One JSON line per exchange: file, time, log_time, operation, "
        "request_id, replay_of, and the request and response records as recorded (response "
        "null when never answered). Damage goes to stderr with its offset.",
        exits=exit_status(
            (0, "every file read (damage inside a file is listed with its offset, not an error)"),
            (2, "a usage error, a missing or unreadable file, or no recording among the paths"),
        ),
    )
    cat.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.cat import lines
    from plotgate.clients.recordings import Reader

    reader = Reader(args.paths, recording_filters(args))
    for line in lines(reader):
        if not write(line):
            return 0
    for rec in reader.files:
        for damage in rec.damage:
            print(f"plotgate cat: {rec.path}: {damage}", file=sys.stderr)
        if rec.damage_count > len(rec.damage):
            print(
                f"plotgate cat: {rec.path}: ... and {rec.damage_count - len(rec.damage)} "
                "more damaged records",
                file=sys.stderr,
            )
    for conflict in reader.conflicts:
        print(f"plotgate cat: conflict: {conflict}", file=sys.stderr)
    if reader.conflict_count > len(reader.conflicts):
        more = reader.conflict_count - len(reader.conflicts)
        print(f"plotgate cat: ... and {more} more conflicts", file=sys.stderr)
    return unreadable_exit("cat", args.paths, reader.unreadable, reader.skipped, reader.recordings)
