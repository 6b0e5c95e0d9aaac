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
import sys

from plotgate import __version__
from plotgate.clients.commands import (
    call,
    cat,
    inspect,
    plot,
    recover,
    replay,
    scenario,
    serve,
    study,
    view,
    worker,
)
from plotgate.clients.commands.arguments import filter_parser
from plotgate.clients.commands.kernels import KernelsUnavailable, load_kernels_first
from plotgate.clients.commands.output import silence_stdout

__all__ = ["build_parser", "main"]

IN_PROCESS = frozenset({"serve", "call", "replay", "plot", "study", "scenario"})
"""The commands that run operations in this process (unless given ``--server``), and so
load the compiled kernels first."""

DESCRIPTION = (
    "Radar track initiation and target localization as a service, every exchange recorded "
    "to MCAP and replayable as a regression gate."
)
EPILOG = "Each command's options and exit status: plotgate COMMAND --help."


def build_parser() -> argparse.ArgumentParser:
    """The ``plotgate`` parser: each command's module adds its own subparser, in the order
    ``plotgate --help`` lists them."""
    parser = argparse.ArgumentParser(prog="plotgate", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"plotgate {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    filters = filter_parser()
    serve.add_command(sub)
    replay.add_command(sub, filters)
    view.add_command(sub, filters)
    recover.add_command(sub)
    call.add_command(sub)
    worker.add_command(sub)
    inspect.add_command(sub, filters)
    cat.add_command(sub, filters)
    plot.add_command(sub)
    study.add_command(sub)
    scenario.add_command(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``plotgate`` console script: its exit status (a usage error is
    2, after argparse's message)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else 2
    try:
        in_process = args.command in IN_PROCESS and getattr(args, "server", None) is None
        if in_process and not load_kernels_first(args):
            return 2
        code = args.func(args)
        sys.stdout.flush()
        return code
    except KernelsUnavailable:  # said by load_command_kernels
        return 2
    except BrokenPipeError:
        silence_stdout()
        return 0
    except KeyboardInterrupt:
        print("plotgate: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the last word: one line, never a traceback
        print(f"plotgate {args.command}: {_one_line(exc)}", file=sys.stderr)
        return 2


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


if __name__ == "__main__":
    sys.exit(main())
