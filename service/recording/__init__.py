"""The MCAP recorder, split by job.

- :mod:`~plotgate.service.recording.records`: the record format, the JSON messages of an
  exchange and the MCAP record bytes around them;
- :mod:`~plotgate.service.recording.files`: the file being written, its name, its bytes on
  the OS, and whether it is still where it was;
- :mod:`~plotgate.service.recording.compaction`: a closed file made an indexed, chunked,
  compressed MCAP off the event loop, swapped in atomically;
- :mod:`~plotgate.service.recording.recorder`: durability, the group commit, loss detection,
  the disk-full probe and the rewriting of lost records.

Files are named ``plotgate-<UTC time>-pid<pid>-<seq>.mcap``, so names sort by time and the
workers of one server never share a file. Two channels per operation, ``<op>/request`` and
``<op>/response``, whose JSON schemas are :class:`~plotgate.service.schemas.RequestRecord`
and :class:`~plotgate.service.schemas.ResponseRecord` with the operation's request, result
and problem models embedded (``jsonschema`` schema encoding, ``json`` messages), and a
``plotgate`` metadata record (versions, git commit, settings) at the start of every file.
"""

from plotgate.service.recording.recorder import (
    Exchange,
    Recorder,
    RecordingError,
    rotation_bytes,
)
from plotgate.service.recording.records import request_record, response_record

__all__ = [
    "Exchange",
    "Recorder",
    "RecordingError",
    "request_record",
    "response_record",
    "rotation_bytes",
]
