"""Whether a recording is still being written: its writer, a process on this host, has it
open.

The service names each file after the process writing it (``plotgate-<UTC time>-pid<pid>-
<n>.mcap``). A file without its footer whose writer still has it open is *open* (a live
server's current file); without a living writer it is *unfinished* (a killed server's).
The process is asked for by its pid; where ``/proc`` shows the process's open files, the
file must be among them (the same device and inode), so a pid reused by another program,
or a server that moved on to its next file, does not pass for the writer. A file named
otherwise, or copied from another host, has no writer here.
"""

import os
import re
from pathlib import Path

__all__ = ["writer_alive", "writer_pid"]

_PID = re.compile(r"-pid(\d{1,9})-")


def writer_pid(path: Path) -> int | None:
    """The pid the file's name says wrote it, if it says."""
    match = _PID.search(path.name)
    return int(match.group(1)) if match and int(match.group(1)) > 0 else None


def writer_alive(path: Path) -> bool:
    """Whether the process named by ``path`` runs on this host and (where ``/proc`` tells)
    has the file open."""
    pid = writer_pid(path)
    if pid is None:
        return False
    try:
        os.kill(pid, 0)  # signal 0: only asks whether the process exists
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's process: it exists
    try:
        target = os.stat(path)
    except OSError:
        return False  # gone
    descriptors = Path(f"/proc/{pid}/fd")
    try:
        links = os.listdir(descriptors)
    except OSError:
        return True  # no /proc, or not ours to look into: the process exists
    for fd in links:
        try:
            held = os.stat(descriptors / fd)
        except OSError:
            continue  # closed since the listing
        if (held.st_dev, held.st_ino) == (target.st_dev, target.st_ino):
            return True
    return False
