"""``plotgate call OPERATION [REQUEST.json]``: one operation on a JSON request, in-process
or on a server."""

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from plotgate.clients.commands.arguments import (
    OperationNames,
    add_where,
    at_least,
    command_parser,
    exit_status,
    seconds,
)
from plotgate.clients.commands.where import in_process_caps, on_cluster


def add_command(sub: Any) -> None:
    call = command_parser(
        sub,
        "call",
        summary="run one operation on a JSON request and print the answer",
        description="Runs in-process through this build's registry (what the server would "
        "answer, its work caps included: --no-limits lifts them), or on a live server with "
        "--server (a 503 or a failed connection tried again, --retries times). The Monte "
        "Carlo chunks of initiation.evaluate, solves.study and identification.simulate, and "
        "the points of an unconditional gates.probability_curve, go to a Dask cluster with "
        "--dask or --local-workers, with the same numbers. The answer is printed as indented "
        "JSON (--compact: one line).",
        exits=exit_status(
            (0, "an answer"),
            (1, "a problem (the request's, printed as problem+json)"),
            (
                2,
                "a usage error, the cluster cannot be had, or no usable answer came from the "
                "server (unreachable, not the operation's answer, over 128 MiB)",
            ),
        ),
    )
    call.add_argument(
        "operation",
        choices=OperationNames(),
        metavar="OPERATION",
        help="operation name: %(choices)s",
    )
    call.add_argument("request", nargs="?", help="JSON request file (default stdin)")
    add_where(call, "a live server URL (default in-process)")
    call.add_argument(
        "--retries",
        type=at_least(0),
        metavar="N",
        help="with --server: tries again after a 503 or a failed connection, up to N times "
        "(default 3; 0: never)",
    )
    call.add_argument(
        "--backoff",
        type=seconds,
        metavar="S",
        help="with --server: the longest wait before the first retry in s, doubled for each "
        "one after it, at least the 503's Retry-After, at most 30 s (default 0.5)",
    )
    call.add_argument(
        "--no-limits",
        action="store_true",
        help="in-process: run a request over the service's work caps (the defaults that "
        "keep a request under the server's memory budget, and PLOTGATE_LIMITS) too",
    )
    call.add_argument(
        "--compact", action="store_true", help="print the JSON on one line, not indented"
    )
    call.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
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
        caps = (in_process_caps(args) or {}).get(op.name)
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
        outcome = on_cluster(args, answer)
    except ClusterUnavailable as exc:
        print(f"plotgate call: {exc}", file=sys.stderr)
        return 2
    _print_json(json.loads(outcome.content), args.compact)
    return 0 if outcome.status < 400 else 1


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
        _print_json(problem, args.compact)
        return 1
    except PlotgateClientError as exc:
        print(f"plotgate call: {exc}", file=sys.stderr)
        return 2
    _print_json(json.loads(answer.content), args.compact)
    return 0


def _print_json(value: Any, compact: bool) -> None:
    """An answer or problem on stdout: indented, or on one line without spaces
    (``--compact``, as the docs show answers)."""
    if compact:
        text = json.dumps(value, separators=(",", ":"))
    else:
        text = json.dumps(value, indent=2)
    sys.stdout.write(text + "\n")
