"""``plotgate worker``: a Dask worker for Monte Carlo chunks."""

import argparse
import sys
from typing import Any

from plotgate.clients.commands.arguments import at_least, command_parser, exit_status


def add_command(sub: Any) -> None:
    wrk = command_parser(
        sub,
        "worker",
        summary="join a Dask scheduler as a worker for Monte Carlo chunks",
        description="Joins the Dask scheduler at ADDRESS (Dask: the plotgate[cluster] extra) "
        "and runs the chunks it is given until the scheduler goes away or SIGTERM/SIGINT.",
        exits=exit_status(
            (0, "the scheduler went away, or SIGTERM/SIGINT"),
            (2, "a usage error, Dask missing, or no scheduler answered within 10 s"),
        ),
    )
    wrk.add_argument("address", help="the scheduler, e.g. tcp://scheduler:8786")
    wrk.add_argument(
        "--nthreads", type=at_least(1), default=1, help="threads (default %(default)s)"
    )
    wrk.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from plotgate.service.cluster import ClusterUnavailable, run_worker

    try:
        run_worker(args.address, args.nthreads)
    except ClusterUnavailable as exc:
        print(f"plotgate worker: {exc}", file=sys.stderr)
        return 2
    print(f"plotgate worker: left {args.address}", file=sys.stderr)
    return 0
