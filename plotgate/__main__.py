"""``plotgate`` (the console script) and ``python -m plotgate``: the command line.

A Ctrl-C while the command loads its modules (a second or more on a loaded machine) ends
it like one while it runs, with one line and exit 130, not a traceback from an import.
"""

import sys

__all__ = ["main"]


def main() -> int:
    """Load :mod:`plotgate.clients.cli` and run it; its exit status."""
    try:
        from plotgate.clients.cli import main as run
    except KeyboardInterrupt:
        print("plotgate: interrupted", file=sys.stderr)
        return 130
    return run()


if __name__ == "__main__":
    sys.exit(main())
