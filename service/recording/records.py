"""The record format: the JSON messages of an exchange and the MCAP record bytes around them.

The recorder writes MCAP by hand, not with mcap's ``Writer``: on the event loop a message
record is a 31-byte header packed with :mod:`struct` in front of the message, and a group
commit hands the headers and messages to the OS in one ``writev`` (measured against
mcap's ``Writer``, chunked and unchunked, in bench/HISTORY.md, "Recording's write path").
The MCAP specification allows message records at the top level, between the file's
header, schemas and channels and its ``DataEnd``; every reader of this project, mcap's
and the TypeScript one of tests/interop read them. Chunks, compression and the index are
added off the loop when the file is compacted (:mod:`plotgate.service.recording.compaction`).
"""

import codecs
import json
import re
import struct
from collections.abc import Iterable, Mapping

from plotgate.service.bodies import is_strict_json, slices

__all__ = [
    "FILE_TAIL",
    "MAGIC",
    "MESSAGE_HEADER_BYTES",
    "file_head",
    "message_header",
    "request_record",
    "response_record",
]

MAGIC = b"\x89MCAP0\r\n"

_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE, _METADATA, _DATA_END = (
    0x01,
    0x02,
    0x03,
    0x04,
    0x05,
    0x0C,
    0x0F,
)

_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
MESSAGE_HEADER_BYTES = _MESSAGE_HEAD.size
"""A message record's bytes besides its message: opcode, length, channel, sequence, times."""

_MESSAGE_FIELDS = MESSAGE_HEADER_BYTES - 9  # channel id, sequence, log and publish times

FILE_TAIL = (
    struct.pack("<BQI", _DATA_END, 4, 0)  # no CRC of the data section: it is not computed
    + struct.pack("<BQQQI", _FOOTER, 20, 0, 0, 0)  # no summary: compaction writes one
    + MAGIC
)
"""What closes an unchunked file: ``DataEnd``, a footer without summary, the magic. A file
without it was not closed (its process was killed): readable all the same."""


def _string(text: str) -> bytes:
    data = text.encode()
    return struct.pack("<I", len(data)) + data


def _map(pairs: Mapping[str, str]) -> bytes:
    data = b"".join(_string(k) + _string(v) for k, v in sorted(pairs.items()))
    return struct.pack("<I", len(data)) + data


def _record(opcode: int, content: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(content)) + content


_JSON = ("jsonschema", "json")
"""The encodings of a plotgate channel's schema and messages."""


def file_head(
    channels: Iterable[tuple[str, str, bytes] | tuple[str, str, bytes, str]],
    metadata: Mapping[str, str],
) -> tuple[bytes, dict[str, int]]:
    """The bytes that start every file and each topic's channel id.

    ``channels`` are ``(topic, schema name, JSON schema)``: one schema (``jsonschema``
    encoding) and one channel (``json`` messages) each, ids from 1; a fourth item names
    another encoding, of both the schema and the messages (``protobuf``: replay's
    ``/replay/diff`` log). Then the ``plotgate`` metadata record. Built once per recorder:
    opening a file is one write of these bytes.
    """
    head = [MAGIC, _record(_HEADER, _string("") + _string("plotgate"))]
    ids: dict[str, int] = {}
    for number, (topic, schema_name, schema, *encoding) in enumerate(channels, start=1):
        schema_encoding, message_encoding = (encoding[0],) * 2 if encoding else _JSON
        head.append(
            _record(
                _SCHEMA,
                struct.pack("<H", number)
                + _string(schema_name)
                + _string(schema_encoding)
                + struct.pack("<I", len(schema))
                + schema,
            )
        )
        head.append(
            _record(
                _CHANNEL,
                struct.pack("<HH", number, number)
                + _string(topic)
                + _string(message_encoding)
                + _map({}),
            )
        )
        ids[topic] = number
    head.append(_record(_METADATA, _string("plotgate") + _map(metadata)))
    return b"".join(head), ids


def message_header(channel: int, sequence: int, log_time: int, size: int) -> bytes:
    """The bytes of a message record before its ``size`` bytes of message (publish time =
    log time)."""
    return _MESSAGE_HEAD.pack(
        _MESSAGE, _MESSAGE_FIELDS + size, channel, sequence & 0xFFFFFFFF, log_time, log_time
    )


def request_record(
    request_id: str,
    operation: str,
    body: bytes,
    strict_json: bool | None = None,
    replay_of: str | None = None,
) -> bytes:
    """The request message: strict-JSON bodies are embedded as they came, others as text.

    ``strict_json`` says which the body is when the caller knows (the service parsed it);
    by default the body is parsed here to find out. ``replay_of`` is, for a request sent by
    ``plotgate replay``, the request id of the exchange it replays. Built by one
    formatting of the whole message (no intermediate pieces: this runs for every request).
    """
    if strict_json is None:
        strict_json = is_strict_json(body)
    key, value = (b"body", body) if strict_json else (b"raw", _json_string(body))
    if replay_of is None:
        return b'{"request_id": %s, "operation": "%s", "%s": %s}' % (
            json.dumps(request_id).encode(),
            operation.encode(),
            key,
            value,
        )
    return b'{"request_id": %s, "operation": "%s", "replay_of": %s, "%s": %s}' % (
        json.dumps(request_id).encode(),
        operation.encode(),
        json.dumps(replay_of).encode(),
        key,
        value,
    )


_CONTROL = re.compile(rb"[\x00-\x1f]")


def _json_string(body: bytes) -> bytes:
    """``body`` as a JSON string (bytes that are not UTF-8 escaped as ``\\xNN``), built slice
    by slice so that no call holds the interpreter long. Printable ASCII, as large bodies
    mostly are, is escaped with byte replacements, without a round trip through Python
    text; anything else is decoded incrementally (a character cut by a slice's end is
    finished by the next) and escaped a character at a time, as a whole body would be."""
    if all(piece.isascii() and _CONTROL.search(piece) is None for piece in slices(body)):
        escaped = (p.replace(b"\\", b"\\\\").replace(b'"', b'\\"') for p in slices(body))
        return b"".join([b'"', *escaped, b'"'])
    decoder = codecs.getincrementaldecoder("utf-8")("backslashreplace")
    texts = [*(decoder.decode(piece) for piece in slices(body)), decoder.decode(b"", final=True)]
    return b"".join([b'"', *(json.dumps(text)[1:-1].encode() for text in texts), b'"'])


def response_record(
    request_id: str, operation: str, status: int, duration_s: float, content: bytes
) -> bytes:
    """The response message around an answer's JSON ``content`` (result or problem), built
    by one formatting of the whole message."""
    return b'{"request_id": %s, "operation": "%s", "status": %d, "duration_s": %r, "%s": %s}' % (
        json.dumps(request_id).encode(),
        operation.encode(),
        status,
        duration_s,
        b"result" if status < 400 else b"error",
        content,
    )
