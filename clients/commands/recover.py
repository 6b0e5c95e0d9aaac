"""``plotgate recover FILE``: a complete, indexed copy of a damaged file."""

import argparse
import sys
from pathlib import Path
from typing import Any

from plotgate.clients.commands.arguments import command_parser, exit_status
from plotgate.clients.commands.output import write


def add_command(sub: Any) -> None:
    rec = command_parser(
        sub,
        "recover",
        summary="a complete, indexed copy of a damaged file",
        description="Copies every intact record of an MCAP file (one a killed server left "
        "without summary and index, or one with damaged chunks: reading resumes at the next "
        "intact chunk) into a new file with summary and index, says what it dropped, and "
        "renames the original to <name>.partial so replaying the folder reads each exchange "
        "once. A file without the MCAP magic is refused and left as it is.",
        exits=exit_status(
            (0, "the copy is written"),
            (2, "a usage error, a missing file, or one refused (not MCAP, not a regular file)"),
        ),
    )
    rec.add_argument("path", type=Path, help="the MCAP file")
    rec.add_argument(
        "--out", type=Path, help="the copy (default <stem>.recovered.mcap beside PATH)"
    )
    rec.add_argument("--keep", action="store_true", help="do not rename the original")
    rec.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.recover import Refused, recover

    try:
        done = recover(args.path, args.out, keep=args.keep)
    except Refused as exc:
        print(f"plotgate recover: {exc}", file=sys.stderr)
        return 2
    write(done.text())
    return 0
