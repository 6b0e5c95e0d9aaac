"""``plotgate replay PATH...``: re-run recorded sessions and compare the answers."""

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from plotgate.clients.commands.arguments import (
    add_where,
    at_least,
    command_parser,
    exit_status,
    recording_filters,
    seconds,
    tolerance,
)
from plotgate.clients.commands.kernels import kernels_as_met
from plotgate.clients.commands.output import write
from plotgate.clients.commands.where import in_process_caps, leave_the_cluster
from plotgate.clients.replay_gate import add_gate_arguments
from plotgate.clients.two_servers import Servers, check_servers

if TYPE_CHECKING:
    from plotgate.clients.replay import ReplayReport


REPLAY_EXIT_CODES = exit_status(
    (0, "every exchange compared and unchanged"),
    (
        1,
        "something changed: an answer, a recorded failure that now succeeds or fails "
        "differently, or an exchange that did not answer within --timeout; or two records of "
        "one exchange (same id and time) that differ: a conflict",
    ),
    (
        2,
        "nothing comparable (--allow-empty makes that 0), a file that cannot be read, no "
        "recording among the files, a FIFO, socket or device among the paths, a usage or "
        "connection error, no Dask scheduler (--dask, --local-workers) or a worker that "
        "cannot read the files (2 wins over 1)",
    ),
    note="Skipped with a note, deciding no exit code when other files are recordings: files "
    "that are empty or not MCAP at all. Not compared, counted apart with the reason: requests "
    "never answered, answers whose request record is lost, bodies that timed out (408), "
    "replays whose original was read before them, in-process requests over the work caps: "
    "the defaults and PLOTGATE_LIMITS (--no-limits runs them).",
)


def add_command(sub: Any, filters: argparse.ArgumentParser) -> None:
    rep = command_parser(
        sub,
        "replay",
        parents=(filters,),
        summary="re-run recorded requests and compare the answers",
        description="Re-runs every recorded exchange (in-process through this build, or on "
        "a live server with --server, each request under a new id marked as a replay of its "
        "original) and compares the answers field by field, numbers within --rtol and "
        "--atol as numpy.isclose does: |recorded - replayed| <= atol + rtol |replayed|.",
        exits=REPLAY_EXIT_CODES,
    )
    add_where(
        rep,
        "replay against this live server URL (default in-process); with --calibrate, "
        "twice: two known-good servers",
        "in-process on the workers of this Dask scheduler, files and chunk ranges "
        "spread over them (the recording folder at the same path on every worker); the "
        "report and exit status are the serial run's",
        "as --dask, on a local Dask cluster of N worker processes (started and stopped "
        "by the command)",
        server_action=Servers,
    )
    rep.add_argument(
        "--rtol",
        type=tolerance,
        default=1e-9,
        help="relative float tolerance (default %(default)g)",
    )
    rep.add_argument(
        "--atol",
        type=tolerance,
        default=1e-12,
        help="absolute float tolerance (default %(default)g)",
    )
    rep.add_argument(
        "--timeout",
        type=seconds,
        default=60.0,
        metavar="S",
        help="time each exchange may take, s (default %(default)g; 0: no limit)",
    )
    rep.add_argument(
        "--no-limits",
        action="store_true",
        help="in-process: run requests over the service's work caps (its defaults and "
        "PLOTGATE_LIMITS) too",
    )
    rep.add_argument(
        "--allow-empty",
        action="store_true",
        help="exit 0, not 2, when there is nothing to compare",
    )
    rep.add_argument(
        "--part-bytes",
        type=at_least(1),
        metavar="N",
        help="with --dask/--local-workers: bytes of chunks per task when a large file is "
        "cut into chunk ranges (default 8 MiB)",
    )
    rep.add_argument("--out", type=Path, help="write the replayed session to this MCAP file")
    rep.add_argument("--report", type=Path, help="write the report as JSON here")
    add_gate_arguments(rep)
    rep.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from functools import partial

    from plotgate.clients.replay import replay
    from plotgate.clients.replay_gate import calibrate, finish, prepare
    from plotgate.files import check_target, write_bytes

    if check_servers(args) is not None:
        return 2
    if args.report:
        check_target(args.report)  # a link, FIFO or device: refused before the replay

    try:
        limits = in_process_caps(args)
    except ValueError as exc:
        print(f"plotgate replay: the service's settings: {exc}", file=sys.stderr)
        return 2
    gate = prepare(args)
    if isinstance(gate, int):
        return gate
    rules = gate.rules
    once = partial(
        replay,
        args.paths,
        server=args.server,
        rtol=args.rtol,
        atol=args.atol,
        out=args.out,
        progress=None,
        filters=recording_filters(args),
        timeout=args.timeout or None,
        limits=limits,
        load=kernels_as_met("replay"),
        rules=rules,
        cases=args.junit is not None,
        pace=gate.pace,
    )
    if args.calibrate is not None:
        return calibrate(args, once)
    if args.dask is not None or args.local_workers is not None:
        fleet = _replay_on_cluster(args, limits, rules)
        if fleet is None:
            return 2
        report = fleet
    else:
        report = once()
    code = report.exit_code(args.allow_empty)
    gated = finish(args, report, code)
    if args.report:
        write_bytes(args.report, json.dumps(report.to_json(), indent=2, default=str).encode())
    text = report.text()
    if code == 2 and report.skipped and not (report.unreadable or report.recordings):
        text += "\nno MCAP recording among the paths given (exit 2)"
    elif code == 2 and not report.unreadable:
        text += (
            "\nnothing was compared (exit 2): wrong path or filters? --allow-empty "
            "passes a run with nothing to compare"
        )
    write(text)
    return gated


def _replay_on_cluster(
    args: argparse.Namespace, limits: dict[str, dict[str, int]] | None, rules: Any = None
) -> "ReplayReport | None":
    """``replay --dask/--local-workers``: the report, or None after saying on stderr why
    there is none (no cluster, a worker that cannot read the folder, --out). A Ctrl-C ends
    it as it ends ``call`` with a cluster (:func:`leave_the_cluster`)."""
    from plotgate.clients.fleet import Judging, WorkerCannotRead, fleet_replay
    from plotgate.clients.parts import PART_BYTES
    from plotgate.service.cluster import ClusterUnavailable

    if args.out is not None:
        print(
            "plotgate replay: --out writes one session file, which many workers cannot; "
            "replay without --dask/--local-workers to write it",
            file=sys.stderr,
        )
        return None
    judging = Judging(
        args.rtol,
        args.atol,
        args.timeout or None,
        limits,
        recording_filters(args),
        rules,
        args.junit is not None,
    )
    try:
        return fleet_replay(
            args.paths,
            judging,
            address=args.dask,
            local_workers=args.local_workers,
            progress=sys.stderr.isatty(),
            part_bytes=args.part_bytes or PART_BYTES,
        )
    except WorkerCannotRead as exc:
        print(f"plotgate replay: {exc.filename}: {exc.strerror}", file=sys.stderr)
    except ClusterUnavailable as exc:
        print(f"plotgate replay: {exc}", file=sys.stderr)
    except KeyboardInterrupt:
        leave_the_cluster()
    return None
