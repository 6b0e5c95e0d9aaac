"""The recording file: its name, its bytes on the OS, and whether it is still where it was.

A :class:`RecordingFile` is one unchunked MCAP file being written: opened with the file's
head (magic, header, schemas, channels, metadata) in one write, appended to with one
``writev`` per group commit, checked after each (``fstat``: still linked?), and closed
with ``DataEnd`` and a footer (:data:`~plotgate.service.recording.records.FILE_TAIL`).
"""

import contextlib
import os
import time
from datetime import UTC, datetime
from pathlib import Path

from plotgate.files import create_new
from plotgate.service.recording.records import FILE_TAIL

__all__ = ["FileLost", "FileMoved", "RecordingFile", "file_name"]

_IOV_MAX = 1024
"""Buffers per ``writev`` call (POSIX's IOV_MAX on Linux)."""


class FileLost(OSError):
    """The current file has no name left: everything written to it is gone."""


class FileMoved(Exception):
    """The current file is no longer at its path, but still exists elsewhere."""


def file_name(sequence: int) -> str:
    """``plotgate-<UTC time>-pid<pid>-<sequence>.mcap``: names sort by time, and the
    workers of one server never share one."""
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
    return f"plotgate-{stamp}-pid{os.getpid()}-{sequence:04d}.mcap"


class RecordingFile:
    """One file being written, through its descriptor (no Python buffer: what
    :meth:`write` returns from is with the OS).

    ``number`` is the recorder's count of files opened (the exchanges remember in which
    their request is); ``commits`` counts the group commits that reached it.
    """

    def __init__(self, path: Path, number: int, head: bytes) -> None:
        self.path = path
        self.number = number
        self.fd = create_new(path)  # O_EXCL|O_NOFOLLOW: a name planted in the folder is refused
        self.size = 0
        self.commits = 0
        self.opened_at = time.monotonic()
        try:
            self.write([head])
        except BaseException:  # a full disk: leave no headless file for the readers to skip
            self.remove()
            self.abandon()
            raise

    def write(self, buffers: list[bytes]) -> None:
        """Append ``buffers`` in one system call (one per :data:`_IOV_MAX` buffers). A
        failure part-way (disk full) is cut back off the file where the OS allows, so that
        it ends with a whole record."""
        start = self.size
        try:
            for i in range(0, len(buffers), _IOV_MAX):
                batch = buffers[i : i + _IOV_MAX]
                wanted = sum(map(len, batch))
                done = os.writev(self.fd, batch)
                if done < wanted:  # a short write: the rest, or the error that stopped it
                    rest = memoryview(b"".join(batch))[done:]
                    while rest:
                        rest = rest[os.write(self.fd, rest) :]
                self.size += wanted
        except OSError:
            with contextlib.suppress(OSError):
                os.ftruncate(self.fd, start)
                os.lseek(self.fd, start, os.SEEK_SET)
            self.size = start
            raise

    def check(self, moved: bool = False) -> None:
        """Raise :class:`FileLost` when the file has no name left (its folder or itself
        deleted); with ``moved``, :class:`FileMoved` when its name now leads elsewhere.

        Every commit checks for loss (one ``fstat``), which would take acknowledged records
        with it; the probe also for a move (one ``stat`` of the path more), which takes
        none: the records stay in the moved file, and the next ones go to a new file.
        """
        opened = os.fstat(self.fd)
        if opened.st_nlink == 0:
            raise FileLost(f"{self.path} was deleted (its folder removed?)")
        if moved and not self._named(opened):
            raise FileMoved

    def _named(self, opened: os.stat_result) -> bool:
        """The path still leads to the open file (``opened``, its fstat): not gone, not
        replaced, its folder not turned into a file (ENOTDIR) or unreadable."""
        try:
            named = os.stat(self.path)
        except OSError:
            return False
        return (named.st_dev, named.st_ino) == (opened.st_dev, opened.st_ino)

    def close(self) -> None:
        """Write ``DataEnd`` and the footer, and close: the file is complete."""
        try:
            self.write([FILE_TAIL])
        finally:
            self.abandon()

    def abandon(self) -> None:
        """Close without the footer (a failed or lost file)."""
        with contextlib.suppress(OSError):
            os.close(self.fd)

    def remove(self) -> None:
        """Remove the file, only while its name still leads to it: never someone else's."""
        with contextlib.suppress(OSError):
            if self._named(os.fstat(self.fd)):
                self.path.unlink()
