"""``plotgate view PATH... -o OUT``: recordings as a Foxglove scene."""

import argparse
import sys
from pathlib import Path
from typing import Any

from plotgate.clients.commands.arguments import command_parser, exit_status, recording_filters
from plotgate.clients.commands.output import unreadable_exit, write
from plotgate.install import install_hint


def add_command(sub: Any, filters: argparse.ArgumentParser) -> None:
    view = command_parser(
        sub,
        "view",
        parents=(filters,),
        summary="write recordings as a Foxglove scene (needs plotgate[view])",
        description="Writes one MCAP that Foxglove opens as a scene: the original request "
        "and response channels, and per exchange a foxglove.SceneUpdate on "
        "/scene/<operation> (plots, gates, tracks, platforms, solutions, bearings in the "
        "radar frame: x east, y north, in m), a foxglove.Log on /log for problems and the "
        "radar frame's foxglove.FrameTransform on /tf (docs/view.md; "
        "docs/foxglove_layout.json is a layout for it). Files are read as inspect reads them.",
        exits=exit_status(
            (0, "the scene file is written"),
            (
                2,
                "a usage error, a file that cannot be read, no recording among the paths, "
                "OUT cannot be written or is one of the inputs, or foxglove-sdk is missing",
            ),
        ),
    )
    view.add_argument("-o", "--out", type=Path, required=True, help="the MCAP file to write")
    view.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.clients.view import view

    try:  # the scene builder is the service's: imported here only (the layers' one direction)
        from plotgate.service.scenes import Encoded
    except ImportError as exc:
        print(
            f"plotgate view: needs foxglove-sdk ({exc.name} is missing): " + install_hint("view"),
            file=sys.stderr,
        )
        return 2
    try:
        report = view(args.paths, args.out, Encoded(), recording_filters(args))
    except ValueError as exc:
        print(f"plotgate view: {exc}", file=sys.stderr)
        return 2
    reader = report.reader
    assert reader is not None
    for rec in reader.files:
        if rec.damage_count:
            print(
                f"plotgate view: {rec.path}: {rec.damage_count} damaged records skipped "
                f"(first: {rec.damage[0]})",
                file=sys.stderr,
            )
    code = unreadable_exit(
        "view", args.paths, reader.unreadable, reader.skipped, reader.recordings
    )
    if report.written:
        write(report.text())
    return code
