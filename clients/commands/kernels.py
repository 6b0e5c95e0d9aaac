"""The numerical kernels an in-process command loads before it runs, saying when they
compile."""

import argparse
import sys
from collections.abc import Callable


def load_kernels_first(args: argparse.Namespace) -> bool:
    """Load the kernels an in-process command needs before it runs (:func:`load_command_kernels`):
    ``call``'s operation's, every operation's for the commands that run several; none yet
    for ``replay``, which loads each operation's as it first meets it
    (:func:`kernels_as_met`), and none for ``serve``, which answers while its warm-up
    compiles them (:mod:`plotgate.service.warmup`)."""
    if args.command in ("replay", "serve"):
        return True
    if args.command == "call":
        from plotgate.service.registry import OPERATIONS

        return load_command_kernels("call", OPERATIONS[args.operation].module)
    return load_command_kernels(args.command)


class KernelsUnavailable(Exception):
    """An operation's kernels could be neither loaded nor compiled (already said)."""


def kernels_as_met(command: str) -> Callable[[str], None]:
    """What an in-process replay calls the first time it meets an operation: load that
    operation's kernels (:func:`load_command_kernels`), so a replay of gate tests starts without
    waiting for every operation's; raises :class:`KernelsUnavailable` when they fail."""

    def load(operation: str) -> None:
        from plotgate.service.registry import OPERATIONS

        if not load_command_kernels(command, OPERATIONS[operation].module, f" of {operation}"):
            raise KernelsUnavailable

    return load


def load_command_kernels(command: str, module: str | None = None, of: str = "") -> bool:
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
