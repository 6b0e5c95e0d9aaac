"""What every command prints: lines on stdout that end quietly at a closed pipe, notes and
the exit status for files that could not be read, a JSON object read from a file."""

import json
import os
import sys
from pathlib import Path
from typing import Any


def write(text: str | bytes) -> bool:
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
        silence_stdout()
        return False


def silence_stdout() -> None:
    """Point stdout at /dev/null, so the interpreter's last flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass  # not a real file (a test's capture): nothing left to flush


def say_notes(command: str, notes: list[str]) -> None:
    """The first hundred notes on stderr, then how many more: a full disk could once
    leave thousands of empty files, each of which would be a line."""
    from plotgate.clients.recordings import MAX_LISTED

    for note in notes[:MAX_LISTED]:
        print(f"plotgate {command}: {note}", file=sys.stderr)
    if len(notes) > MAX_LISTED:
        print(f"plotgate {command}: ... and {len(notes) - MAX_LISTED} more", file=sys.stderr)


def unreadable_exit(
    command: str, paths: list[Path], unreadable: list[str], skipped: list[str], recordings: int
) -> int:
    """2, after saying why, when a file could not be read at all or none was a recording
    (naming the paths given); files skipped (empty, not MCAP) are noted and decide nothing
    when others are read."""
    say_notes(command, unreadable + skipped)
    if not recordings:
        named = ", ".join(map(str, paths))
        print(f"plotgate {command}: no MCAP recordings in {named}", file=sys.stderr)
    return 2 if unreadable or not recordings else 0


def json_object(path: str) -> dict[str, Any] | None:
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
