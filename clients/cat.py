"""``plotgate cat``: the exchanges of recordings as JSON lines, one per exchange.

Each line is ``{"file", "time", "log_time", "operation", "request_id", "replay_of",
"request", "response"}``: the request and response records exactly as they are in the file
(``response`` null for a request never answered, ``request`` null for an answer whose
request record was lost to damage), ``time`` the request's arrival in ISO 8601 UTC and
``log_time`` the same in ns. Exchanges come in the order their answers were recorded, those
never answered last (:class:`plotgate.clients.recordings.Reader`).
"""

import json
from collections.abc import Iterator

from plotgate.clients.recordings import Exchange, Reader, iso_time

__all__ = ["exchange_line", "lines"]


def _record(data: bytes | None) -> bytes:
    """A record as one line: JSON text holds a raw newline only as whitespace between
    tokens (inside strings it is escaped), so it can become a space."""
    if data is None:
        return b"null"
    return data.replace(b"\r", b" ").replace(b"\n", b" ")


def exchange_line(exchange: Exchange) -> bytes:
    """One exchange as a JSON line (no newline)."""
    head = {
        "file": exchange.file,
        "time": iso_time(exchange.log_time),
        "log_time": exchange.log_time,
        "operation": exchange.operation,
        "request_id": exchange.request_id,
        "replay_of": exchange.replay_of,
    }
    return b'%s, "request": %s, "response": %s}' % (
        json.dumps(head).encode()[:-1],
        _record(exchange.request_bytes),
        _record(exchange.response_bytes),
    )


def lines(reader: Reader) -> Iterator[bytes]:
    """Every exchange ``reader`` gives, as JSON lines."""
    return map(exchange_line, reader)
