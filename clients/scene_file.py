"""An indexed, chunked, zstd-compressed MCAP written from raw bytes: ``plotgate view``'s
output.

mcap's ``Writer`` builds a ``Message`` object per message and writes its fields one by
one (about 30 us a message, three messages and more an exchange: the largest share of
``plotgate view`` after the drawing). Here, as the recorder writes its records
(:mod:`plotgate.service.recording.records`, which the clients do not import), a message
record is a header packed with :mod:`struct` in front of its bytes, appended to the chunk
being filled; a full chunk is compressed in one call (zstd, level 1: the chunk's bytes are
JSON and doubles written once, read back by a viewer) and followed by its message
indexes. The summary is mcap's ``Writer``'s: schemas, channels, statistics and chunk
indexes, each group found by a summary offset, and the footer's CRC of the summary.
``tests/clients/test_scene_file.py`` reads what this writes with mcap's readers, CRCs
checked, indexed and not.

Record layouts are those of the MCAP specification (https://mcap.dev/spec).
"""

import struct
import zlib
from array import array
from typing import BinaryIO

import zstandard

__all__ = ["COMPRESSION_LEVEL", "SceneFile"]

MAGIC = b"\x89MCAP0\r\n"
COMPRESSION_LEVEL = 1

_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
_CHUNK, _MESSAGE_INDEX, _CHUNK_INDEX, _STATISTICS = 0x06, 0x07, 0x08, 0x0B
_SUMMARY_OFFSET, _DATA_END = 0x0E, 0x0F

_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
"""Opcode, length, channel id, sequence, log time, publish time."""
_MESSAGE_FIELDS = _MESSAGE_HEAD.size - 9


def _string(text: str) -> bytes:
    data = text.encode()
    return struct.pack("<I", len(data)) + data


def _record(opcode: int, content: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(content)) + content


class SceneFile:
    """Write an MCAP to ``stream``: :meth:`schema` and :meth:`channel` (ids from 1, in the
    chunk being filled and again in the summary), :meth:`message`, then :meth:`finish`.
    A chunk is closed once it holds ``chunk_bytes``."""

    def __init__(self, stream: BinaryIO, library: str, chunk_bytes: int) -> None:
        self._stream = stream
        self._chunk_bytes = chunk_bytes
        self._compressor = zstandard.ZstdCompressor(level=COMPRESSION_LEVEL)
        self._schemas: list[bytes] = []
        self._channels: list[bytes] = []
        self._chunk_indexes: list[bytes] = []
        self._counts: dict[int, int] = {}
        self._first: int | None = None
        self._last = 0
        self._chunks = 0
        self._messages = 0
        self._reset()
        head = MAGIC + _record(_HEADER, _string("") + _string(library))
        self._stream.write(head)
        self._offset = len(head)

    def _reset(self) -> None:
        self._pieces: list[bytes] = []
        self._size = 0
        self._index: dict[int, array[int]] = {}
        self._chunk_first: int | None = None
        self._chunk_last = 0
        self._chunk_messages = 0

    def _add(self, record: bytes) -> None:
        self._pieces.append(record)
        self._size += len(record)

    def schema(self, name: str, encoding: str, data: bytes) -> int:
        """Declare a schema: its id."""
        number = len(self._schemas) + 1
        record = _record(
            _SCHEMA,
            struct.pack("<H", number)
            + _string(name)
            + _string(encoding)
            + struct.pack("<I", len(data))
            + data,
        )
        self._schemas.append(record)
        self._add(record)
        return number

    def channel(self, topic: str, message_encoding: str, schema_id: int) -> int:
        """Declare a channel (no metadata): its id."""
        number = len(self._channels) + 1
        content = struct.pack("<HH", number, schema_id) + _string(topic)
        record = _record(_CHANNEL, content + _string(message_encoding) + struct.pack("<I", 0))
        self._channels.append(record)
        self._add(record)
        return number

    def message(self, channel: int, log_time: int, data: bytes) -> None:
        """A message at ``log_time`` (its publish time too; sequence 0)."""
        index = self._index.get(channel)
        if index is None:
            index = self._index[channel] = array("Q")
        index.append(log_time)
        index.append(self._size)
        self._pieces.append(
            _MESSAGE_HEAD.pack(
                _MESSAGE, _MESSAGE_FIELDS + len(data), channel, 0, log_time, log_time
            )
        )
        self._pieces.append(data)
        self._size += _MESSAGE_HEAD.size + len(data)
        self._counts[channel] = self._counts.get(channel, 0) + 1
        self._chunk_messages += 1
        if self._chunk_first is None or log_time < self._chunk_first:
            self._chunk_first = log_time
        if log_time > self._chunk_last:
            self._chunk_last = log_time
        if self._size >= self._chunk_bytes:
            self._close_chunk()

    def _close_chunk(self) -> None:
        """Write the chunk being filled, compressed, and its message indexes."""
        if self._chunk_messages == 0:
            return
        records = b"".join(self._pieces)
        compressed = self._compressor.compress(records)
        first, last = self._chunk_first or 0, self._chunk_last
        chunk = _record(
            _CHUNK,
            struct.pack("<QQQI", first, last, len(records), zlib.crc32(records))
            + _string("zstd")
            + struct.pack("<Q", len(compressed))
            + compressed,
        )
        start = self._offset
        indexes, offsets = [], []
        at = start + len(chunk)
        for channel, entries in self._index.items():
            body = entries.tobytes()
            record = _record(_MESSAGE_INDEX, struct.pack("<HI", channel, len(body)) + body)
            offsets.append(struct.pack("<HQ", channel, at))
            indexes.append(record)
            at += len(record)
        index_bytes = b"".join(indexes)
        offset_map = b"".join(offsets)
        self._chunk_indexes.append(
            _record(
                _CHUNK_INDEX,
                struct.pack("<QQQQI", first, last, start, len(chunk), len(offset_map))
                + offset_map
                + struct.pack("<Q", len(index_bytes))
                + _string("zstd")
                + struct.pack("<QQ", len(compressed), len(records)),
            )
        )
        self._stream.write(chunk)
        self._stream.write(index_bytes)
        self._offset = at
        self._first = first if self._first is None else min(self._first, first)
        self._last = max(self._last, last)
        self._chunks += 1
        self._messages += self._chunk_messages
        self._reset()

    def finish(self) -> None:
        """Close the last chunk; write the data end, the summary, the footer and the magic
        (the stream is left open)."""
        self._close_chunk()
        data_end = _record(_DATA_END, struct.pack("<I", 0))  # no CRC of the data section
        self._stream.write(data_end)
        summary_start = self._offset + len(data_end)
        counts = b"".join(struct.pack("<HQ", c, n) for c, n in sorted(self._counts.items()))
        statistics = _record(
            _STATISTICS,
            struct.pack(
                "<QHIIIIQQ",
                self._messages,
                len(self._schemas),
                len(self._channels),
                0,
                0,
                self._chunks,
                self._first or 0,
                self._last,
            )
            + struct.pack("<I", len(counts))
            + counts,
        )
        groups = [
            (_SCHEMA, b"".join(self._schemas)),
            (_CHANNEL, b"".join(self._channels)),
            (_STATISTICS, statistics),
            (_CHUNK_INDEX, b"".join(self._chunk_indexes)),
        ]
        summary, offsets, at = [], [], summary_start
        for opcode, group in groups:
            summary.append(group)
            offsets.append(_record(_SUMMARY_OFFSET, struct.pack("<BQQ", opcode, at, len(group))))
            at += len(group)
        data = b"".join(summary + offsets)
        footer_head = struct.pack("<BQQQ", _FOOTER, 20, summary_start, at)
        crc = zlib.crc32(footer_head, zlib.crc32(data))
        self._stream.write(data + footer_head + struct.pack("<I", crc) + MAGIC)
