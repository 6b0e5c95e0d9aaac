"""The ``plotgate`` command: serve, call, replay, recover, inspect, cat, plot, study, scenario.

``plotgate serve`` runs the service (flags override the ``PLOTGATE_*`` settings);
``plotgate call OPERATION [REQUEST.json]`` runs any operation (``solves.position``,
``gates.probability`` ...) on a JSON request, in-process or on a server, and prints the
answer; ``plotgate replay PATH...`` re-runs recorded sessions and exits 0 (unchanged), 1
(changed) or 2 (nothing comparable, unreadable input, usage or connection error);
``plotgate recover FILE`` writes a complete, indexed copy of every intact record of a
damaged file; ``plotgate inspect PATH...`` prints each file's state and time range and
per-operation counts and latencies; ``plotgate cat PATH...`` prints the exchanges as JSON
lines; ``plotgate plot {fig2,fig5,compare}`` draws Konovalov's gating-probability figures;
``plotgate study`` runs Fadeev et al.'s multistatic accuracy study (Fig. 3) and writes its table
and figure; ``plotgate scenario`` draws a simulated scenario and the tracks initiated in it
(Mu et al.'s figures).

No command ends in a traceback: a missing file, a usage or connection error is one line on
stderr and exit 2; a closed pipe (``| head``) ends the command quietly.
"""

import argparse
import json
import math
import os
import sys
from collections.abc import Callable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

from plotgate import __version__

if TYPE_CHECKING:
    from plotgate.clients.replay import ReplayReport

__all__ = ["main"]

_T = TypeVar("_T")

IN_PROCESS = frozenset({"serve", "call", "replay", "plot", "study", "scenario"})
"""The commands that run operations in this process (unless given ``--server``), and so
load the compiled kernels first."""

REPLAY_EXIT_CODES = """exit status:
  0  every exchange compared and unchanged
  1  something changed: an answer, a recorded failure that now succeeds or fails
     differently, or an exchange that did not answer within --timeout; or two
     records of one exchange (same id and time) that differ: a conflict
  2  nothing comparable (--allow-empty makes that 0), a file that cannot be read,
     no recording among the files, a FIFO, socket or device among the paths, a
     usage or connection error, no Dask scheduler (--dask, --local-workers) or a
     worker that cannot read the files (2 wins over 1)

skipped with a note, deciding no exit code when other files are recordings: files
that are empty or not MCAP at all.

not compared, counted apart with the reason: requests never answered, answers
whose request record is lost, bodies that timed out (408), replays whose original
was read before them, in-process requests over the work caps: the defaults and
PLOTGATE_LIMITS (--no-limits runs them)."""


def _write(text: str | bytes) -> bool:
    """Write a line to stdout; False (and stdout silenced) once the reader has gone (a
    closed pipe, as with ``| head``)."""
    try:
        if isinstance(text, bytes):
            sys.stdout.flush()
            sys.stdout.buffer.write(text + b"\n")
        else:
            sys.stdout.write(text + "\n")
        return True
    except BrokenPipeError:
        _silence_stdout()
        return False


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so the interpreter's last flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass  # not a real file (a test's capture): nothing left to flush


def _serve(args: argparse.Namespace) -> int:
    import uvicorn

    from plotgate.service.config import Settings
    from plotgate.service.connections import HeaderDeadline
    from plotgate.service.registry import check_limits

    overrides = {
        "PLOTGATE_HOST": args.host,
        "PLOTGATE_PORT": args.port,
        "PLOTGATE_WORKERS": args.workers,
        "PLOTGATE_LOG_DIR": args.log_dir,
        "PLOTGATE_RECORD": args.record,
        "PLOTGATE_FOXGLOVE_PORT": args.foxglove_port,
        "PLOTGATE_FOXGLOVE_HOST": args.foxglove_host,
    }
    os.environ.update({k: str(v) for k, v in overrides.items() if v is not None})
    try:  # settings the app would refuse at start: a usage error, not a bug
        settings = Settings()
        check_limits(settings.limits)
    except ValueError as exc:
        print(f"plotgate serve: the service's settings: {exc}", file=sys.stderr)
        return 2
    from plotgate.clients.ports import listen_refused

    refused = listen_refused(settings.host, settings.port)
    if refused:
        print(f"plotgate serve: {refused}", file=sys.stderr)
        return 2
    refused = _live_view_refused(settings)
    if refused:
        print(f"plotgate serve: --foxglove-port: {refused}", file=sys.stderr)
        return 2
    if settings.record:
        from plotgate.service.recording import Recorder, RecordingError

        try:  # here, since a failure in the app's start-up is a traceback and exit 3
            Recorder(settings.log_dir, ()).start()
        except RecordingError as exc:
            print(f"plotgate serve: {exc}", file=sys.stderr)
            return 2
    uvicorn.run(
        "plotgate.service.app:create_app",
        factory=True,
        host=settings.host,
        port=settings.port,
        workers=settings.workers,
        http=HeaderDeadline,
        loop="auto",
        log_level="info",
        access_log=settings.access_log,
        timeout_graceful_shutdown=settings.graceful_shutdown_s,
    )
    return 0


def _live_view_refused(settings: Any) -> str | None:
    """Why ``--foxglove-port`` cannot be served, checked before the server starts (a
    failure in the app's start-up is a traceback): foxglove-sdk missing, several workers
    (each would bind the port), the port not free."""
    import importlib.util
    import socket

    if settings.foxglove_port is None:
        return None
    if importlib.util.find_spec("foxglove") is None:
        return 'needs foxglove-sdk: pip install "plotgate[view]"'
    if settings.workers > 1:
        return "one live view per server: run it with --workers 1"
    try:
        with socket.create_server((settings.foxglove_host, settings.foxglove_port)):
            return None
    except OSError as exc:
        return (
            f"cannot listen on {settings.foxglove_host}:{settings.foxglove_port}: {exc.strerror}"
        )


def _at_least(minimum: int) -> Callable[[str], int]:
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


def _finite(what: str) -> Callable[[str], float]:
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


_seconds = _finite("a number of seconds")
_tolerance = _finite("a finite number")
"""Tolerances of replay's comparison: numpy.isclose warns on non-finite ones, and a NaN
tolerance would call every number changed."""


def _worker(args: argparse.Namespace) -> int:
    from plotgate.service.cluster import ClusterUnavailable, run_worker

    try:
        run_worker(args.address, args.nthreads)
    except ClusterUnavailable as exc:
        print(f"plotgate worker: {exc}", file=sys.stderr)
        return 2
    print(f"plotgate worker: left {args.address}", file=sys.stderr)
    return 0


def _call(args: argparse.Namespace) -> int:
    """Print the answer (exit 0) or the problem (exit 1) of one request."""
    if args.server is None and (args.retries is not None or args.backoff is not None):
        print("plotgate call: --retries and --backoff need --server", file=sys.stderr)
        return 2
    if args.server is not None and args.no_limits:
        print(
            "plotgate call: --no-limits is for in-process runs (a server applies its own caps)",
            file=sys.stderr,
        )
        return 2
    body = (
        sys.stdin.buffer.read() if args.request in (None, "-") else Path(args.request).read_bytes()
    )
    if args.server is not None:
        return _call_server(args, body)
    from plotgate.service.cluster import ClusterUnavailable
    from plotgate.service.registry import OPERATIONS, Outcome, execute, internal_error

    op = OPERATIONS[args.operation]
    try:
        caps = (_in_process_caps(args) or {}).get(op.name)
    except ValueError as exc:
        print(f"plotgate call: the service's settings: {exc}", file=sys.stderr)
        return 2

    def answer() -> Outcome:
        try:
            return execute(op, body, limits=caps)
        except Exception as exc:  # noqa: BLE001 - a bug: the server's 500, and what raised
            print(f"plotgate call: {type(exc).__name__}: {exc}", file=sys.stderr)
            return internal_error(op, None)

    try:
        outcome = _on_cluster(args, answer)
    except ClusterUnavailable as exc:
        print(f"plotgate call: {exc}", file=sys.stderr)
        return 2
    sys.stdout.write(json.dumps(json.loads(outcome.content), indent=2) + "\n")
    return 0 if outcome.status < 400 else 1


def _on_cluster(args: argparse.Namespace, work: Callable[[], _T]) -> _T:
    """``work()`` with its Monte Carlo chunks on the cluster of ``--dask`` or
    ``--local-workers`` (neither: in this process), the chunks done drawn as a bar when
    stderr is a terminal. A Ctrl-C with a cluster ends the command at once
    (:func:`_leave_the_cluster`).

    Raises
    ------
    ClusterUnavailable
        No cluster could be had (the caller ends with its message and exit 2).
    """
    from plotgate.service.cluster import cluster

    try:
        with cluster(args.dask, args.local_workers, progress=sys.stderr.isatty()):
            return work()
    except KeyboardInterrupt:
        if args.dask is None and args.local_workers is None:
            raise
        _leave_the_cluster()


def _leave_the_cluster() -> NoReturn:
    """Exit 130 at once after a Ctrl-C with a cluster, which :func:`cluster` has abandoned:
    the interpreter's own exit would wait for Dask's threads and worker processes to wind
    down (seconds, with warnings), where ending this process ends the workers with it
    (they watch their parent). Nothing of this command is left to write: stdout and stderr
    are flushed first."""
    print("plotgate: interrupted", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def _call_server(args: argparse.Namespace, body: bytes) -> int:
    """``plotgate call --server``: the answer (exit 0) or the problem (exit 1), the one the
    server sent or, for an error body that is not one (a proxy's HTML 502), the one the
    client makes of its status and text; exit 2, with a message, when no usable answer came
    (unreachable, or an answer that is not the operation's: not JSON, the wrong schema, over
    the client's size cap)."""
    from plotgate.clients.client import (
        DEFAULT_BACKOFF,
        DEFAULT_RETRIES,
        SLOW_TIMEOUT,
        Client,
        parse_answer,
    )
    from plotgate.clients.errors import PlotgateClientError, ProblemError

    retries = DEFAULT_RETRIES if args.retries is None else args.retries
    backoff = DEFAULT_BACKOFF if args.backoff is None else args.backoff
    try:
        with Client(args.server, timeout=SLOW_TIMEOUT, retries=retries, backoff=backoff) as client:
            answer = client.send(args.operation, body)
        parse_answer(args.operation, answer)
    except ProblemError as exc:
        if answer.status_code == 503 and retries:
            print(f"plotgate call: still 503 after {retries + 1} attempts", file=sys.stderr)
        problem = exc.problem.model_dump(mode="json", exclude_none=True)
        sys.stdout.write(json.dumps(problem, indent=2) + "\n")
        return 1
    except PlotgateClientError as exc:
        print(f"plotgate call: {exc}", file=sys.stderr)
        return 2
    sys.stdout.write(json.dumps(json.loads(answer.content), indent=2) + "\n")
    return 0


def _filters(args: argparse.Namespace):
    from plotgate.clients.recordings import Filters

    operations = frozenset(
        op.strip() for ops in args.operation or () for op in ops.split(",") if op.strip()
    )
    return Filters(operations, args.since, args.until)


def _in_process_caps(args: argparse.Namespace) -> dict[str, dict[str, int]] | None:
    """The work caps an in-process run applies: the server's (the defaults with
    PLOTGATE_LIMITS over them), so it answers what the server would; None with
    ``--no-limits`` or ``--server`` (the server applies its own). Raises ValueError for
    PLOTGATE_LIMITS the server would refuse to start with."""
    if args.no_limits or args.server is not None:
        return None
    from plotgate.service.config import Settings
    from plotgate.service.registry import check_limits

    limits = Settings().limits
    check_limits(limits)
    return limits


def _replay(args: argparse.Namespace) -> int:
    from plotgate.clients.replay import replay

    try:
        limits = _in_process_caps(args)
    except ValueError as exc:
        print(f"plotgate replay: the service's settings: {exc}", file=sys.stderr)
        return 2
    if args.dask is not None or args.local_workers is not None:
        fleet = _replay_on_cluster(args, limits)
        if fleet is None:
            return 2
        report = fleet
    else:
        report = replay(
            args.paths,
            server=args.server,
            rtol=args.rtol,
            atol=args.atol,
            out=args.out,
            progress=None,
            filters=_filters(args),
            timeout=args.timeout or None,
            limits=limits,
            load=_kernels_as_met("replay"),
        )
    code = report.exit_code(args.allow_empty)
    if args.report:
        Path(args.report).write_text(json.dumps(report.to_json(), indent=2, default=str))
    text = report.text()
    if code == 2 and report.skipped and not (report.unreadable or report.recordings):
        text += "\nno MCAP recording among the paths given (exit 2)"
    elif code == 2 and not report.unreadable:
        text += (
            "\nnothing was compared (exit 2): wrong path or filters? --allow-empty "
            "passes a run with nothing to compare"
        )
    _write(text)
    return code


def _replay_on_cluster(
    args: argparse.Namespace, limits: dict[str, dict[str, int]] | None
) -> "ReplayReport | None":
    """``replay --dask/--local-workers``: the report, or None after saying on stderr why
    there is none (no cluster, a worker that cannot read the folder, --out). A Ctrl-C ends
    it as it ends ``call`` with a cluster (:func:`_leave_the_cluster`)."""
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
    judging = Judging(args.rtol, args.atol, args.timeout or None, limits, _filters(args))
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
        _leave_the_cluster()
    return None


def _recover(args: argparse.Namespace) -> int:
    from plotgate.clients.recover import Refused, recover

    try:
        done = recover(args.path, args.out, keep=args.keep)
    except Refused as exc:
        print(f"plotgate recover: {exc}", file=sys.stderr)
        return 2
    _write(done.text())
    return 0


def _notes(command: str, notes: list[str]) -> None:
    """The first hundred notes on stderr, then how many more: a full disk could once
    leave thousands of empty files, each of which would be a line."""
    from plotgate.clients.recordings import MAX_LISTED

    for note in notes[:MAX_LISTED]:
        print(f"plotgate {command}: {note}", file=sys.stderr)
    if len(notes) > MAX_LISTED:
        print(f"plotgate {command}: ... and {len(notes) - MAX_LISTED} more", file=sys.stderr)


def _unreadable(
    command: str, paths: list[Path], unreadable: list[str], skipped: list[str], recordings: int
) -> int:
    """2, after saying why, when a file could not be read at all or none was a recording
    (naming the paths given); files skipped (empty, not MCAP) are noted and decide nothing
    when others are read."""
    _notes(command, unreadable + skipped)
    if not recordings:
        named = ", ".join(map(str, paths))
        print(f"plotgate {command}: no MCAP recordings in {named}", file=sys.stderr)
    return 2 if unreadable or not recordings else 0


def _inspect(args: argparse.Namespace) -> int:
    from plotgate.clients.inspect import format_inspection, inspect

    summary = inspect(args.paths, _filters(args))
    if _write(json.dumps(summary, indent=2) if args.json else format_inspection(summary)):
        return _unreadable(
            "inspect",
            args.paths,
            summary["unreadable"],
            summary["skipped"],
            summary["recordings"],
        )
    return 0


def _cat(args: argparse.Namespace) -> int:
    from plotgate.clients.cat import lines
    from plotgate.clients.recordings import Reader

    reader = Reader(args.paths, _filters(args))
    for line in lines(reader):
        if not _write(line):
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
    return _unreadable("cat", args.paths, reader.unreadable, reader.skipped, reader.recordings)


def _plot(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.plots import MissingMatplotlib, Setup, plot
    from plotgate.service.cluster import ClusterUnavailable

    setup = Setup(
        tau=args.tau,
        v_min=args.v_min,
        v_max=args.v_max,
        course_deg=args.course_deg,
        az_deg=args.az_deg,
    )
    try:
        out = _on_cluster(
            args,
            lambda: plot(
                args.figure, args.out, server=args.server, setup=setup, points=args.points
            ),
        )
    except (MissingMatplotlib, PlotgateClientError, ClusterUnavailable) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    print(out)
    return 0


def _study(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.plots import MissingMatplotlib, matplotlib_classes
    from plotgate.clients.study import DEFAULT_REQUEST, NOT_MET, checks, draw, run_study, table
    from plotgate.service.cluster import ClusterUnavailable

    request = dict(DEFAULT_REQUEST) if args.request is None else _json_object(args.request)
    if request is None:
        return 2
    for key, value in (("runs", args.runs), ("seed", args.seed)):
        if value is not None:
            request[key] = value
    if args.no_tracks:
        request["tracks"] = False
    try:
        if args.png is not None:
            matplotlib_classes()  # fail before computing for minutes
        answer = _on_cluster(args, lambda: run_study(request, server=args.server))
    except (MissingMatplotlib, PlotgateClientError, ClusterUnavailable) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    args.table.parent.mkdir(parents=True, exist_ok=True)
    args.table.write_text(table(answer))
    written = [args.table]
    if args.png is not None:
        written.append(draw(answer, args.png))
    verdicts = checks(answer)
    for check in verdicts:
        print(f"{check.verdict}: {check.requirement}: {check.result}")
    print(
        f"NOT MET only for a shortfall beyond the Monte Carlo noise of {answer['runs']} runs "
        "(more than 2 standard errors; at the worst of n samples, the allowance noise alone "
        "passes 39 times in 40); within noise: more runs (--runs) decide"
    )
    print("wrote " + ", ".join(str(p) for p in written))
    return 1 if any(c.verdict == NOT_MET for c in verdicts) else 0


def _json_object(path: str) -> dict[str, Any] | None:
    """The JSON object in the file at ``path``, or None after saying on stderr why not
    (a missing file goes to :func:`main`'s one line)."""
    try:
        value = json.loads(Path(path).read_bytes())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        print(f"plotgate: {path}: not JSON ({exc})", file=sys.stderr)
        return None
    if not isinstance(value, dict):
        print(f"plotgate: {path}: not a JSON object", file=sys.stderr)
        return None
    return value


def _scenario(args: argparse.Namespace) -> int:
    from plotgate.clients.errors import PlotgateClientError
    from plotgate.clients.plots import MissingMatplotlib
    from plotgate.clients.scenario_plot import default_settings, scenario_figure, simulate_request

    config = default_settings(args.mode, args.v_max)
    if args.config is not None:
        given = _json_object(args.config)
        if given is None:
            return 2
        config = given
    request = simulate_request(args.clutter, args.scans, args.seed)
    try:
        out = scenario_figure(request, config, args.out, server=args.server)
    except (MissingMatplotlib, PlotgateClientError) as exc:
        print(f"plotgate: {exc}", file=sys.stderr)
        return 2
    print(out)
    return 0


def _time(text: str) -> int:
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


def _at_least_two(text: str) -> int:
    value = int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"must be at least 2, got {value}")
    return value


DESCRIPTION = (
    "Radar track initiation and target localization as a service, every exchange recorded "
    "to MCAP and replayable as a regression gate."
)
EPILOG = "Each command's options and exit status: plotgate COMMAND --help."


class _OperationNames:
    """The operation names ``call`` takes, read from the wire schemas only when argparse
    asks (to check or show ``call``'s argument): importing the schemas' pydantic models
    costs more than the rest of ``plotgate --help``."""

    def _names(self) -> list[str]:
        from plotgate.service.schemas import ENDPOINTS

        return sorted(ENDPOINTS)

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())


def _add_replay(sub: Any, filters: argparse.ArgumentParser) -> None:
    rep = sub.add_parser(
        "replay",
        parents=[filters],
        help="re-run recorded requests and compare the answers",
        description="Re-runs every recorded exchange (in-process through this build, or on "
        "a live server with --server, each request under a new id marked as a replay of its "
        "original) and compares the answers field by field, numbers within --rtol and "
        "--atol as numpy.isclose does: |recorded - replayed| <= atol + rtol |replayed|.",
        epilog=REPLAY_EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_where(
        rep,
        "replay against this live server URL (default in-process)",
        "in-process on the workers of this Dask scheduler, files and chunk ranges "
        "spread over them (the recording folder at the same path on every worker); the "
        "report and exit status are the serial run's",
        "as --dask, on a local Dask cluster of N worker processes (started and stopped "
        "by the command)",
    )
    rep.add_argument(
        "--rtol",
        type=_tolerance,
        default=1e-9,
        help="relative float tolerance (default %(default)g)",
    )
    rep.add_argument(
        "--atol",
        type=_tolerance,
        default=1e-12,
        help="absolute float tolerance (default %(default)g)",
    )
    rep.add_argument(
        "--timeout",
        type=_seconds,
        default=60.0,
        metavar="S",
        help="seconds each exchange may take (default %(default)g; 0: no limit)",
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
        type=_at_least(1),
        metavar="N",
        help="with --dask/--local-workers: bytes of chunks per task when a large file is "
        "cut into chunk ranges (default 8 MiB)",
    )
    rep.add_argument("--out", type=Path, help="write the replayed session to this MCAP file")
    rep.add_argument("--report", type=Path, help="write the report as JSON here")
    rep.set_defaults(func=_replay)


def _add_view(sub: Any, filters: argparse.ArgumentParser) -> None:
    view = sub.add_parser(
        "view",
        parents=[filters],
        help="write recordings as a Foxglove scene (needs plotgate[view])",
        description="Writes one MCAP that Foxglove opens as a scene: the original request "
        "and response channels, and per exchange a foxglove.SceneUpdate on "
        "/scene/<operation> (plots, gates, tracks, platforms, solutions, bearings in the "
        "radar frame: x east, y north, m), a foxglove.Log on /log for problems and the "
        "radar frame's foxglove.FrameTransform on /tf (docs/view.md; docs/foxglove_layout.json "
        "is a layout for it). Files are read as inspect reads them. Exit 0; 2 when a file "
        "cannot be read, none is a recording, OUT cannot be written or is one of the inputs, "
        "or foxglove-sdk is missing.",
    )
    view.add_argument("-o", "--out", type=Path, required=True, help="the MCAP file to write")
    view.set_defaults(func=_view)


def _view(args: argparse.Namespace) -> int:
    from plotgate.clients.view import view

    try:  # the scene builder is the service's: imported here only (the layers' one direction)
        from plotgate.service.scenes import Encoded
    except ImportError as exc:
        print(
            f"plotgate view: needs foxglove-sdk ({exc.name} is missing): "
            'pip install "plotgate[view]"',
            file=sys.stderr,
        )
        return 2
    try:
        report = view(args.paths, args.out, Encoded(), _filters(args))
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
    code = _unreadable("view", args.paths, reader.unreadable, reader.skipped, reader.recordings)
    if report.written:
        _write(report.text())
    return code


def _add_where(
    command: Any,
    server_help: str,
    dask_help: str = "in-process, with the Monte Carlo chunks on this Dask scheduler",
    workers_help: str = "in-process, with the Monte Carlo chunks on a local Dask cluster of "
    "N worker processes (started and stopped by the command)",
) -> None:
    """Where a command computes: ``--server URL``, or in-process with its chunks on
    ``--dask ADDRESS`` or ``--local-workers N`` (or in this process); one of the three."""
    where = command.add_mutually_exclusive_group()
    where.add_argument("--server", help=server_help)
    where.add_argument("--dask", metavar="ADDRESS", help=dask_help)
    where.add_argument("--local-workers", type=_at_least(1), metavar="N", help=workers_help)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="plotgate", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"plotgate {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="run the HTTP service, recording to MCAP")
    serve.add_argument("--host", help="listen address (PLOTGATE_HOST, default 127.0.0.1)")
    serve.add_argument("--port", type=int, help="port (PLOTGATE_PORT, default 8000)")
    serve.add_argument("--workers", type=int, help="worker processes (PLOTGATE_WORKERS)")
    serve.add_argument("--log-dir", help="recordings folder (PLOTGATE_LOG_DIR, ./recordings)")
    serve.add_argument(
        "--no-record",
        dest="record",
        action="store_const",
        const=False,
        help="do not record (PLOTGATE_RECORD=false)",
    )
    serve.add_argument(
        "--foxglove-port",
        type=int,
        metavar="PORT",
        help="publish every answered exchange's scene live over Foxglove's WebSocket "
        "protocol on this port (PLOTGATE_FOXGLOVE_PORT; off by default; needs "
        "plotgate[view]; docs/view.md)",
    )
    serve.add_argument(
        "--foxglove-host",
        metavar="HOST",
        help="address of the live view (PLOTGATE_FOXGLOVE_HOST, default 127.0.0.1)",
    )
    serve.set_defaults(func=_serve)

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
        metavar="OP",
        help="only this operation (repeat, or comma-separate, for several)",
    )
    filters.add_argument(
        "--since",
        type=_time,
        metavar="TIME",
        help="only requests from this time on (ISO 8601, UTC unless it says; or Unix seconds)",
    )
    filters.add_argument(
        "--until", type=_time, metavar="TIME", help="only requests before this time (as --since)"
    )

    _add_replay(sub, filters)
    _add_view(sub, filters)

    rec = sub.add_parser(
        "recover",
        help="a complete, indexed copy of a damaged file",
        description="Copies every intact record of an MCAP file (one a "
        "killed server left without summary and index, or one with damaged "
        "chunks: reading resumes at the next intact chunk) into a new file "
        "with summary and index, says what it dropped, and renames the "
        "original to <name>.partial so replaying the folder reads each "
        "exchange once. A file without the MCAP magic is refused (exit 2) "
        "and left as it is.",
    )
    rec.add_argument("path", type=Path, help="the MCAP file")
    rec.add_argument("--out", type=Path, help="the copy (default <stem>.recovered.mcap)")
    rec.add_argument("--keep", action="store_true", help="do not rename the original")
    rec.set_defaults(func=_recover)

    call = sub.add_parser(
        "call",
        help="run one operation on a JSON request and print the answer",
        description="Runs in-process through this build's registry (what the server would "
        "answer, its work caps included: --no-limits lifts them), or on a live server with "
        "--server (a 503 or a failed connection tried again, "
        "--retries times). The Monte Carlo chunks of initiation.evaluate, solves.study and "
        "identification.simulate, and the points of an unconditional "
        "gates.probability_curve, go to a Dask "
        "cluster with --dask or --local-workers, with the same numbers. Exit 0 on an answer, "
        "1 on a problem, 2 when the cluster cannot be had or no usable answer came from the "
        "server (unreachable, not the operation's answer, over 128 MiB).",
    )
    call.add_argument(
        "operation",
        choices=_OperationNames(),
        metavar="OPERATION",
        help="operation name: %(choices)s",
    )
    call.add_argument("request", nargs="?", help="JSON request file (default: stdin)")
    _add_where(call, "a live server URL (default in-process)")
    call.add_argument(
        "--retries",
        type=_at_least(0),
        metavar="N",
        help="with --server: tries again after a 503 or a failed connection, up to N times "
        "(default 3; 0: never)",
    )
    call.add_argument(
        "--backoff",
        type=_seconds,
        metavar="S",
        help="with --server: the longest wait before the first retry, doubled for each one "
        "after it, at least the 503's Retry-After, at most 30 (default 0.5)",
    )
    call.add_argument(
        "--no-limits",
        action="store_true",
        help="in-process: run a request over the service's work caps (the defaults that "
        "keep a request under the server's memory budget, and PLOTGATE_LIMITS) too",
    )
    call.set_defaults(func=_call)

    wrk = sub.add_parser(
        "worker",
        help="join a Dask scheduler as a worker for Monte Carlo chunks",
        description='Joins the Dask scheduler at ADDRESS (pip install "plotgate[cluster]") '
        "and runs the chunks it is given until the scheduler goes away or SIGTERM/SIGINT "
        "(exit 0). Exit 2 when Dask is missing or no scheduler answers within 10 s.",
    )
    wrk.add_argument("address", help="the scheduler, e.g. tcp://scheduler:8786")
    wrk.add_argument("--nthreads", type=_at_least(1), default=1, help="threads (1)")
    wrk.set_defaults(func=_worker)

    ins = sub.add_parser(
        "inspect",
        parents=[filters],
        help="each file's state and time range; per-operation counts, errors, latencies",
        description="Exit 0, or 2 when a file is not a recording at all (damage inside a "
        "file is listed with its offset, not an error).",
    )
    ins.add_argument("--json", action="store_true", help="print JSON instead of a table")
    ins.set_defaults(func=_inspect)

    cat = sub.add_parser(
        "cat",
        parents=[filters],
        help="print the exchanges as JSON lines",
        description="One JSON line per exchange: file, time, log_time, operation, "
        "request_id, replay_of, and the request and response records as recorded (response "
        "null when never answered). Damage goes to stderr with its offset. Exit 0, or 2 when "
        "a file is not a recording at all.",
    )
    cat.set_defaults(func=_cat)

    from plotgate.clients.plots import DEFAULT_FILES, FIGURES

    plo = sub.add_parser(
        "plot",
        help="draw Konovalov's gating-probability figures (needs plotgate[plot])",
        description="fig2: ring gate, conditional probability against speed (20, 50 km) and "
        "range (200, 300 m/s) for three sensor errors (Konovalov, Fig. 2); fig5: the same for "
        "the combined gate, P_G 0.9 (Fig. 5); compare: unconditional probability against "
        "range for the ring, combined and expanded gates, whose points (seconds each) go to "
        "a Dask cluster with --dask or --local-workers (the conditional figures' curves cost "
        "milliseconds and stay in this process), with the same numbers.",
    )
    plo.add_argument("figure", choices=FIGURES, help="which figure")
    plo.add_argument(
        "--out", type=Path, help="PNG to write (default " + ", ".join(DEFAULT_FILES.values()) + ")"
    )
    _add_where(plo, "compute on this live server URL (default in-process)")
    plo.add_argument(
        "--course-deg",
        type=float,
        default=0.0,
        help="target course, degrees clockwise from north (default 0)",
    )
    plo.add_argument(
        "--az-deg",
        type=float,
        default=0.0,
        help="azimuth of the first mark, degrees (default 0: due north)",
    )
    plo.add_argument("--tau", type=float, default=5.0, help="interval between marks, s (5)")
    plo.add_argument("--v-min", type=float, default=100.0, help="gate's minimum speed (100)")
    plo.add_argument("--v-max", type=float, default=500.0, help="gate's maximum speed (500)")
    plo.add_argument(
        "--points",
        type=_at_least_two,
        help="values per curve (default 81 speeds, 96 ranges, 15 unconditional)",
    )
    plo.set_defaults(func=_plot)

    stu = sub.add_parser(
        "study",
        help="Fadeev et al.'s multistatic accuracy study: table and PNG (Fig. 3)",
        description="Monte Carlo of the multistatic solvers along a track (operation "
        "solves.study): curves 1-6 of Fadeev et al., Fig. 3 at every sample, checked against "
        "the CRLB. Default: the built-in scenario (one transmitter, three receivers at "
        "10 m/s, a target at 80 m/s crossing the baselines, 1000 runs: a few minutes); "
        "docs/examples/study_scenario.json is a quick one to start from. Each verdict "
        "carries its Monte Carlo standard error: NOT MET only for a shortfall beyond the "
        "noise (more than 2 standard errors; more at the worst of many samples), within "
        "noise when more runs would decide. The runs' solves go to a Dask cluster with --dask "
        "or --local-workers, with the same table. Exit 0, or 1 when a requirement is NOT MET "
        "(2: no cluster or no answer).",
    )
    stu.add_argument(
        "request", nargs="?", help="a JSON solves.study request (default: the built-in scenario)"
    )
    stu.add_argument("--runs", type=_at_least_two, help="Monte Carlo runs (override)")
    stu.add_argument("--seed", type=int, help="noise seed (override)")
    stu.add_argument(
        "--no-tracks",
        action="store_true",
        help="skip curve 3 and the full track (most of the cost)",
    )
    stu.add_argument(
        "--table",
        type=Path,
        default=Path("multistatic_accuracy.md"),
        help="markdown table to write (default multistatic_accuracy.md)",
    )
    stu.add_argument(
        "--png",
        type=Path,
        default=Path("multistatic_accuracy.png"),
        help="figure to write (default multistatic_accuracy.png; needs plotgate[plot])",
    )
    stu.add_argument(
        "--no-png", dest="png", action="store_const", const=None, help="write no figure"
    )
    _add_where(stu, "compute on this live server URL (default in-process)")
    stu.set_defaults(func=_study)

    sce = sub.add_parser(
        "scenario",
        help="draw a simulated scenario and its initiated tracks (Mu et al.)",
        description="Simulates Mu et al.'s scenario (5 ground targets at 25 m/s, P_D 0.8, "
        "Poisson clutter over a 15 km square) with initiation.simulate, initiates tracks "
        "with initiation.initiate scan by scan and draws the plots and the confirmed tracks as a "
        "PNG: true tracks green, false ones red dashed, missed targets grey dotted, the radar, "
        "the scan period and an inset zoomed on the targets.",
    )
    sce.add_argument("--clutter", type=float, default=250.0, help="clutter per scan (250)")
    sce.add_argument("--scans", type=int, default=4, help="number of scans (4)")
    sce.add_argument("--seed", type=int, default=3, help="simulation seed (3)")
    sce.add_argument(
        "--mode", choices=("cartesian", "polar"), default="polar", help="initiation method (polar)"
    )
    sce.add_argument("--v-max", type=float, default=30.0, help="largest speed, m/s (30)")
    sce.add_argument(
        "--config", help="a JSON file of initiation settings (overrides --mode and --v-max)"
    )
    sce.add_argument(
        "--out", type=Path, default=Path("scenario.png"), help="PNG to write (scenario.png)"
    )
    sce.add_argument("--server", help="compute on this live server URL (default in-process)")
    sce.set_defaults(func=_scenario)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``plotgate`` console script: its exit status (a usage error is
    2, after argparse's message)."""
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else 2
    try:
        in_process = args.command in IN_PROCESS and getattr(args, "server", None) is None
        if in_process and not _load_kernels_first(args):
            return 2
        code = args.func(args)
        sys.stdout.flush()
        return code
    except _KernelsUnavailable:  # said by _load_kernels
        return 2
    except BrokenPipeError:
        _silence_stdout()
        return 0
    except KeyboardInterrupt:
        print("plotgate: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the last word: one line, never a traceback
        print(f"plotgate {args.command}: {_one_line(exc)}", file=sys.stderr)
        return 2


def _load_kernels_first(args: argparse.Namespace) -> bool:
    """Load the kernels an in-process command needs before it runs (:func:`_load_kernels`):
    ``call``'s operation's, every operation's for the commands that run several; none yet
    for ``replay``, which loads each operation's as it first meets it
    (:func:`_kernels_as_met`), and none for ``serve``, which answers while its warm-up
    compiles them (:mod:`plotgate.service.warmup`)."""
    if args.command in ("replay", "serve"):
        return True
    if args.command == "call":
        from plotgate.service.registry import OPERATIONS

        return _load_kernels("call", OPERATIONS[args.operation].module)
    return _load_kernels(args.command)


class _KernelsUnavailable(Exception):
    """An operation's kernels could be neither loaded nor compiled (already said)."""


def _kernels_as_met(command: str) -> Callable[[str], None]:
    """What an in-process replay calls the first time it meets an operation: load that
    operation's kernels (:func:`_load_kernels`), so a replay of gate tests starts without
    waiting for every operation's; raises :class:`_KernelsUnavailable` when they fail."""

    def load(operation: str) -> None:
        from plotgate.service.registry import OPERATIONS

        if not _load_kernels(command, OPERATIONS[operation].module, f" of {operation}"):
            raise _KernelsUnavailable

    return load


def _load_kernels(command: str, module: str | None = None, of: str = "") -> bool:
    """Load the numerical kernels before a command runs operations in-process (those of
    ``module``, an operation's handler module, named by ``of`` in the messages; None:
    every operation's), saying on stderr when they compile (a first start: about a
    minute of silence otherwise), how long that took, and when a damaged cache was
    removed; False (after a message) when they can be neither loaded nor compiled and
    cached."""
    from plotgate.service.kernels import CacheRepairFailed, load_kernels

    def say(text: str) -> None:
        print(f"plotgate {command}: {text}", file=sys.stderr, flush=True)

    def repaired(exc: Exception, removed: int) -> None:
        say(
            f"numba's cache of the kernels was unreadable ({type(exc).__name__}: {exc}); "
            f"removed its {removed} files"
        )

    try:
        seconds = load_kernels(
            lambda: say(f"compiling numerical kernels{of} (first start only, a minute or two)..."),
            module=module,
            repaired=repaired,
        )
    except CacheRepairFailed as exc:
        say(
            f"cannot compile and cache the numerical kernels ({exc}): is numba's cache "
            "folder (NUMBA_CACHE_DIR, else __pycache__ beside the sources) full or read-only?"
        )
        return False
    if seconds is not None:
        say(f"kernels{of} ready in {seconds:.0f} s (cached: later starts take a few seconds)")
    return True


def _one_line(exc: Exception) -> str:
    """What went wrong, in one line: a missing file, an unreachable server, or a bug."""
    import httpx

    from plotgate.clients.errors import TransportError

    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror}"
    if isinstance(exc, FileNotFoundError | TransportError):
        return str(exc)
    if isinstance(exc, httpx.TransportError):
        try:
            where = str(exc.request.url)
        except RuntimeError:
            where = "the server"
        return f"cannot reach {where}: {exc}"
    return f"internal error (a bug in plotgate, please report it): {type(exc).__name__}: {exc}"


if __name__ == "__main__":
    sys.exit(main())
