"""The one safe way to write a file: every writer of plotgate goes through here.

A writer that opens its output by name can be made to write somewhere else. A symlink
planted at the name sends the bytes to the file it points to. A FIFO or a device node
(``/dev/full``) at the name is written into, or replaced by a regular file. So every
file plotgate writes follows four rules:

- **An existing target that is not a regular file is refused** (:class:`NotRegularTarget`,
  an ``OSError`` naming it: the commands end with one line and exit 2). This covers a
  symlink (even to a regular file), a FIFO, a device node, a socket and a folder. The
  target is checked with ``lstat``, so a link is never followed.
- **Temporaries are created with O_CREAT|O_EXCL|O_NOFOLLOW** (:func:`tempfile.mkstemp`) in
  the target's folder. A planted name is never opened: ``mkstemp`` picks another name.
- **The finished file is renamed into place** (``os.replace``: atomic on one file
  system), and the target is checked again just before the rename.
- **fsync where the data must survive**: the file before the rename, the folder after.

:func:`create_new` is the recorder's open. It creates a file that must not exist yet,
with O_EXCL|O_NOFOLLOW, and adds no system call per write. :func:`open_regular` opens a
file to read it (compaction's source) without following a link or blocking on a FIFO.

Standard library only: the service, the clients and the compaction child (which imports
no plotgate module but this one) all use it.
"""

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

__all__ = [
    "NotRegularTarget",
    "atomic_write",
    "check_target",
    "create_new",
    "open_regular",
    "replace_into",
    "sync_folder",
    "temporary_beside",
    "write_bytes",
]

_KINDS = (
    (stat.S_ISLNK, "a symbolic link"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a folder"),
)


class NotRegularTarget(OSError):
    """The target exists and is not a regular file: nothing is written to it or over it."""

    def __init__(self, path: Path | str, kind: str) -> None:
        super().__init__(errno.EEXIST, f"exists and is {kind}, not a regular file: refused")
        self.filename = str(path)


def _kind(mode: int) -> str:
    for test, kind in _KINDS:
        if test(mode):
            return kind
    return "not a regular file"


def check_target(path: Path | str) -> None:
    """Raise :class:`NotRegularTarget` when ``path`` exists and is not a regular file
    (checked without following a link). A missing target is fine."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise NotRegularTarget(path, _kind(mode))


def create_new(path: Path | str, mode: int = 0o644) -> int:
    """Create ``path``, which must not exist, for writing: a descriptor opened with
    O_CREAT|O_EXCL|O_NOFOLLOW. Any existing entry is refused (``FileExistsError``)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    return os.open(path, flags, mode)


def open_regular(path: Path | str) -> BinaryIO:
    """Open ``path`` for reading only if it is a regular file. A link is not followed
    (``ELOOP``), a FIFO does not block, and anything else is :class:`NotRegularTarget`."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise NotRegularTarget(path, _kind(mode))
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def temporary_beside(target: Path | str, suffix: str = ".partial") -> tuple[int, Path]:
    """A new hidden temporary file in the target's folder (``mkstemp``: O_EXCL|O_NOFOLLOW,
    mode 0600): its descriptor and path. The name is ``.<target name>.<random><suffix>``."""
    target = Path(target)
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=target.parent)
    return fd, Path(name)


def replace_into(temporary: Path | str, target: Path | str, sync: bool = True) -> None:
    """Rename ``temporary`` over ``target`` atomically, after checking once more that the
    target is not a link, FIFO, device or folder; with ``sync``, the folder's entry is made
    durable. ``temporary`` is left in place when refused (its writer removes it)."""
    check_target(target)
    os.replace(temporary, target)
    if sync:
        sync_folder(Path(target).parent)


def sync_folder(folder: Path | str) -> None:
    """Make a rename in ``folder`` durable (its entry written), where the OS allows it."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):  # some file systems cannot sync a folder
            os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_write(target: Path | str, sync: bool = True, mode: int = 0o644) -> Iterator[BinaryIO]:
    """Write ``target`` whole or not at all: the ``with`` block writes a temporary beside
    it, which replaces the target when the block ends without an exception (synced first
    with ``sync``) and is removed otherwise. The target is refused up front when it is not
    a regular file. ``OSError`` raised here names the target, not the temporary."""
    target = Path(target)
    check_target(target)
    try:
        fd, temporary = temporary_beside(target)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(target)) from exc
    try:
        with os.fdopen(fd, "wb") as stream:
            os.fchmod(fd, mode)  # mkstemp's 0600 made the caller's
            yield stream
            stream.flush()
            if sync:
                os.fsync(stream.fileno())
        replace_into(temporary, target, sync)
    except NotRegularTarget:
        raise
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(target)) from exc
    finally:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


def write_bytes(target: Path | str, data: bytes, sync: bool = True) -> None:
    """Write ``data`` to ``target`` through :func:`atomic_write`."""
    with atomic_write(target, sync) as stream:
        stream.write(data)
