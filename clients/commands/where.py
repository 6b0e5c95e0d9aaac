"""Where a command computes: in this process, its Monte Carlo chunks on a Dask cluster,
and the work caps an in-process run applies."""

import argparse
import os
import sys
from collections.abc import Callable
from typing import NoReturn, TypeVar

_T = TypeVar("_T")


def on_cluster(args: argparse.Namespace, work: Callable[[], _T]) -> _T:
    """``work()`` with its Monte Carlo chunks on the cluster of ``--dask`` or
    ``--local-workers`` (neither: in this process), the chunks done drawn as a bar when
    stderr is a terminal. A Ctrl-C with a cluster ends the command at once
    (:func:`leave_the_cluster`).

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
        leave_the_cluster()


def leave_the_cluster() -> NoReturn:
    """Exit 130 at once after a Ctrl-C with a cluster, which :func:`cluster` has abandoned:
    the interpreter's own exit would wait for Dask's threads and worker processes to wind
    down (seconds, with warnings), where ending this process ends the workers with it
    (they watch their parent). Nothing of this command is left to write: stdout and stderr
    are flushed first."""
    print("plotgate: interrupted", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def in_process_caps(args: argparse.Namespace) -> dict[str, dict[str, int]] | None:
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
