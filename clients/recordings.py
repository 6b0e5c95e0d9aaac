"""Reading plotgate MCAP recordings, including files a killed server left without a footer.

Files are read with mcap's stream reader, not ``make_reader``: a file with no footer
cannot be indexed, so records are taken in order until the data ends (``EndOfFile``,
``struct.error``) or a chunk fails its CRC, and what was complete up to there is kept.
"""

import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.records import Channel, Footer, Message, Metadata
from mcap.stream_reader import CRCValidationError, StreamReader
from zstandard import ZstdError

__all__ = ["Exchange", "Recording", "read_recording", "recording_files"]


@dataclass
class Exchange:
    """One request and, if it was recorded, its response."""

    operation: str
    request_id: str
    request: dict[str, Any]
    response: dict[str, Any] | None = None
    log_time: int = 0

    @property
    def body(self) -> bytes:
        """The request body as it was sent."""
        if "body" in self.request:
            return json.dumps(self.request["body"]).encode()
        return str(self.request.get("raw", "")).encode()


@dataclass
class Recording:
    """What one file holds."""

    path: Path
    exchanges: list[Exchange] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    messages: int = 0
    complete: bool = False
    stopped_by: str | None = None
    """Why reading stopped early (truncated or corrupt file), None for a complete file."""


def recording_files(path: Path) -> list[Path]:
    """The MCAP files at ``path``: the file itself, or a folder's ``*.mcap`` in name order."""
    path = Path(path)
    if path.is_dir():
        return sorted(path.glob("*.mcap"))
    if not path.exists():
        raise FileNotFoundError(f"no such file or folder: {path}")
    return [path]


_DAMAGE = (McapError, struct.error, CRCValidationError, EOFError, ValueError, RuntimeError,
           ZstdError)
"""What reading a truncated or damaged file raises: an incomplete record, a chunk that
fails its CRC or does not decompress (lz4 raises RuntimeError, zstandard ZstdError)."""


def _records(path: Path, rec: Recording) -> Iterator[object]:
    with open(path, "rb") as stream:
        reader = StreamReader(stream, validate_crcs=True)
        try:
            yield from reader.records
        except _DAMAGE as exc:
            rec.stopped_by = f"{type(exc).__name__}: {exc}".strip(": ")


def read_recording(path: Path) -> Recording:
    """Read every complete exchange in one file, in the order the requests arrived."""
    rec = Recording(Path(path))
    channels: dict[int, str] = {}
    waiting: dict[tuple[str, str], list[Exchange]] = {}
    for record in _records(rec.path, rec):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
        elif isinstance(record, Metadata):
            rec.metadata[record.name] = dict(record.metadata)
        elif isinstance(record, Footer):
            rec.complete = True
        elif isinstance(record, Message):
            rec.messages += 1
            operation, _, kind = channels[record.channel_id].rpartition("/")
            data = json.loads(record.data)
            key = (operation, data["request_id"])
            if kind == "request":
                exchange = Exchange(operation, data["request_id"], data, log_time=record.log_time)
                waiting.setdefault(key, []).append(exchange)
                rec.exchanges.append(exchange)
            elif waiting.get(key):
                waiting[key].pop(0).response = data
    return rec
