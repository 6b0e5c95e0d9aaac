"""``plotgate serve``: the HTTP service, recording to MCAP."""

import argparse
import os
import sys
from typing import Any

from plotgate.clients import listen
from plotgate.clients.commands.arguments import command_parser, exit_status
from plotgate.clients.ports import listen_refused


def add_command(sub: Any) -> None:
    serve = command_parser(
        sub,
        "serve",
        summary="run the HTTP service, recording to MCAP",
        description="Runs the HTTP service (uvicorn) until Ctrl-C or SIGTERM, recording every "
        "exchange to MCAP files in --log-dir. Each option overrides its PLOTGATE_* setting "
        "(docs/configuration.md); the interactive API is at /docs.",
        exits=exit_status(
            (0, "the server stopped (Ctrl-C or SIGTERM)"),
            (
                2,
                "a usage error, settings the service refuses, a recording folder it cannot "
                "write, a port it cannot listen on, or a live view it cannot start",
            ),
        ),
    )
    serve.add_argument("--host", help="listen address (default 127.0.0.1; PLOTGATE_HOST)")
    serve.add_argument(
        "--port", type=int, help="TCP port to listen on (default 8000; PLOTGATE_PORT)"
    )
    serve.add_argument(
        "--workers", type=int, help="worker processes (default 1; PLOTGATE_WORKERS)"
    )
    serve.add_argument(
        "--log-dir", help="recordings folder (default ./recordings; PLOTGATE_LOG_DIR)"
    )
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
        "protocol on this TCP port (default off; PLOTGATE_FOXGLOVE_PORT; needs "
        "plotgate[view]; docs/view.md)",
    )
    serve.add_argument(
        "--foxglove-host",
        metavar="HOST",
        help="address of the live view (default 127.0.0.1; PLOTGATE_FOXGLOVE_HOST)",
    )
    listen.add_arguments(serve)
    serve.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
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
        **listen.overrides(args),
    }
    os.environ.update({k: str(v) for k, v in overrides.items() if v is not None})
    try:  # settings the app would refuse at start: a usage error, not a bug
        settings = Settings()
        check_limits(settings.limits)
    except ValueError as exc:
        print(f"plotgate serve: the service's settings: {exc}", file=sys.stderr)
        return 2
    if listen.refused(settings):
        return 2
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

    from plotgate.install import install_hint

    if settings.foxglove_port is None:
        return None
    if importlib.util.find_spec("foxglove") is None:
        return f"needs foxglove-sdk: {install_hint('view')}"
    if settings.workers > 1:
        return "one live view per server: run it with --workers 1"
    try:
        with socket.create_server((settings.foxglove_host, settings.foxglove_port)):
            return None
    except OSError as exc:
        return (
            f"cannot listen on {settings.foxglove_host}:{settings.foxglove_port}: {exc.strerror}"
        )
