"""The live view's public port: an authenticated WebSocket proxy with bounded backlogs.

foxglove-sdk's server has no authentication and keeps its own backlog per client. So the
publisher (:mod:`plotgate.service.scenes.live`) binds the SDK's server on loopback, on a
port the system picks, and puts this gate on the port the operator gave. For each client
the gate:

1. reads the WebSocket handshake (at most :data:`HANDSHAKE_BYTES`, within
   :data:`HANDSHAKE_TIMEOUT_S`);
2. refuses with 503 (and counts ``full``) when ``max_clients`` others are connected
   (connections still in their handshake count; past twice the cap a connection is
   closed at once), and asks the API's own policy
   (:meth:`plotgate.service.access.Keys.allows`) for a key: the ``?key=`` of the URL, or
   the API's ``X-API-Key`` / ``Authorization: Bearer`` headers. Without one it answers 401
   (and counts ``key``). Nothing of the live view is sent before that answer, not even the
   server's name: the SDK is not contacted;
3. opens its own connection to the SDK, forwarding the handshake without the key and
   without ``Sec-WebSocket-Extensions`` (no compression is negotiated, so messages stay
   whole frames the gate can drop), and relays the frames both ways.

**Slow clients.** What the SDK sends a client waits in that client's backlog, at most
:data:`BACKLOG_MESSAGES` messages and :data:`BACKLOG_BYTES` bytes (one message over the
byte bound still passes alone). Past either bound the oldest scene (a Message Data frame,
the protocol's opcode 1) is dropped and counted; control messages (advertisements, server
info, pings) are never dropped, and a client whose backlog is all control messages is
disconnected. The gate reads the SDK as fast as it sends, so the SDK's own backlog stays
empty, and memory is bounded by ``max_clients`` times the backlog.

Counters (clients connected, refusals by reason, messages dropped) live in a shared array
the server's process reads for ``/metrics``.
"""

import asyncio
import contextlib
import struct
from collections import deque
from collections.abc import MutableSequence
from urllib.parse import parse_qs, urlsplit

from plotgate.service.access import QUERY_KEY, Keys

__all__ = [
    "BACKLOG_BYTES",
    "BACKLOG_MESSAGES",
    "CLIENTS",
    "COUNTERS",
    "DROPPED",
    "HANDSHAKE_BYTES",
    "HANDSHAKE_TIMEOUT_S",
    "REFUSED_FULL",
    "REFUSED_KEY",
    "Backlog",
    "Gate",
    "SlowClient",
]

HANDSHAKE_BYTES = 16 * 2**10
HANDSHAKE_TIMEOUT_S = 10.0
BACKLOG_MESSAGES = 256
BACKLOG_BYTES = 256 * 2**10
"""Per client: 64 clients hold at most 16 MiB of backlog, 300 at most 75 MiB."""
READ_BYTES = 64 * 2**10
MESSAGE_DATA = 0x01
"""The first byte of a binary frame carrying a channel's message (foxglove.websocket.v1)."""

CLIENTS, REFUSED_KEY, REFUSED_FULL, DROPPED = range(4)
COUNTERS = 4
"""The shared counters: clients connected, refused without a key, refused over the cap,
messages dropped for slow clients."""

_DROPPED_HEADERS = ("authorization", "x-api-key", "sec-websocket-extensions")


class SlowClient(Exception):
    """A client's backlog is full of messages that cannot be dropped."""


class Backlog:
    """A client's messages not yet sent: bounded, dropping the oldest scene."""

    def __init__(self) -> None:
        self.items: deque[tuple[bytes, bool]] = deque()
        self.bytes = 0
        self.ready = asyncio.Event()

    def put(self, frame: bytes, droppable: bool) -> int:
        """Queue ``frame``; the number of older scenes dropped to stay in bounds."""
        self.items.append((frame, droppable))
        self.bytes += len(frame)
        dropped = 0
        while len(self.items) > BACKLOG_MESSAGES or (
            self.bytes > BACKLOG_BYTES and len(self.items) > 1
        ):
            oldest = next((i for i, (_, d) in enumerate(self.items) if d), None)
            if oldest is None:
                raise SlowClient
            self.bytes -= len(self.items[oldest][0])
            del self.items[oldest]
            dropped += 1
        self.ready.set()
        return dropped

    async def get(self) -> bytes:
        """The oldest frame, once there is one."""
        while not self.items:
            self.ready.clear()
            await self.ready.wait()
        frame, _ = self.items.popleft()
        self.bytes -= len(frame)
        return frame


class Gate:
    """The proxy in front of the SDK's server on ``127.0.0.1:upstream_port``."""

    def __init__(
        self, keys: Keys, upstream_port: int, max_clients: int, counters: MutableSequence[int]
    ) -> None:
        self.keys = keys
        self.upstream_port = upstream_port
        self.max_clients = max_clients
        self.counters = counters

    async def serve(self, host: str, port: int) -> asyncio.Server:
        """Listen on ``host:port`` (0: a free port)."""
        return await asyncio.start_server(self._client, host, port, limit=HANDSHAKE_BYTES)

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self.counters[CLIENTS] >= 2 * self.max_clients:  # a flood: not even an answer
            self.counters[REFUSED_FULL] += 1
            writer.close()
            return
        self.counters[CLIENTS] += 1
        try:
            await self._admit(reader, writer)
        except (OSError, EOFError, ValueError, asyncio.IncompleteReadError, SlowClient):
            pass
        finally:
            self.counters[CLIENTS] -= 1
            writer.close()

    async def _admit(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), HANDSHAKE_TIMEOUT_S)
        except (TimeoutError, asyncio.LimitOverrunError, asyncio.IncompleteReadError):
            await _refuse(writer, "400 Bad Request", "no WebSocket handshake")
            return
        if self.counters[CLIENTS] > self.max_clients:  # this one included
            self.counters[REFUSED_FULL] += 1
            await _refuse(writer, "503 Service Unavailable", "too many live view clients")
            return
        request_line, headers, lines = _parse(head)
        target = request_line.split(" ")[1] if request_line.count(" ") >= 2 else "/"
        query_key = parse_qs(urlsplit(target).query).get(QUERY_KEY, [None])[0]
        if not self.keys.allows(headers, query_key):
            self.counters[REFUSED_KEY] += 1
            ways = " or ".join([f"?{QUERY_KEY}= in the URL", *self.keys.ways()])
            await _refuse(writer, "401 Unauthorized", f"the live view needs a key: {ways}")
            return
        upstream_reader, upstream = await asyncio.open_connection(
            "127.0.0.1", self.upstream_port, limit=HANDSHAKE_BYTES
        )
        try:
            path = urlsplit(target).path or "/"
            upstream.write(_handshake(request_line.replace(target, path, 1), lines))
            await self._relay(reader, writer, upstream_reader, upstream)
        finally:
            upstream.close()

    async def _relay(
        self,
        reader: asyncio.StreamReader,
        writer: asyncio.StreamWriter,
        upstream_reader: asyncio.StreamReader,
        upstream: asyncio.StreamWriter,
    ) -> None:
        answer = await upstream_reader.readuntil(b"\r\n\r\n")
        writer.write(answer)
        if b" 101 " not in answer.split(b"\r\n", 1)[0]:
            await writer.drain()
            return
        backlog = Backlog()
        tasks = [
            asyncio.ensure_future(_copy(reader, upstream)),
            asyncio.ensure_future(self._frames(upstream_reader, backlog)),
            asyncio.ensure_future(_send(backlog, writer)),
        ]
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

    async def _frames(self, upstream: asyncio.StreamReader, backlog: Backlog) -> None:
        """Read the SDK's frames into ``backlog``, a fragmented message as one item."""
        parts: list[bytes] = []
        droppable = False
        while True:
            frame, opcode, fin, first = await _frame(upstream)
            if opcode >= 0x8:  # a control frame: ping, pong, close
                backlog.put(frame, False)
                continue
            if opcode != 0x0:  # a message starts
                parts, droppable = [], opcode == 0x2 and first == MESSAGE_DATA
            parts.append(frame)
            if fin:
                self.counters[DROPPED] += backlog.put(b"".join(parts), droppable)
                parts = []


async def _frame(reader: asyncio.StreamReader) -> tuple[bytes, int, bool, int]:
    """One WebSocket frame (RFC 6455 section 5.2): its bytes, opcode, FIN and the first
    payload byte (-1 when empty or masked)."""
    head = await reader.readexactly(2)
    length = head[1] & 0x7F
    extended = b""
    if length == 126:
        extended = await reader.readexactly(2)
        (length,) = struct.unpack("!H", extended)
    elif length == 127:
        extended = await reader.readexactly(8)
        (length,) = struct.unpack("!Q", extended)
    mask = await reader.readexactly(4) if head[1] & 0x80 else b""
    payload = await reader.readexactly(length)
    first = payload[0] if payload and not mask else -1
    return head + extended + mask + payload, head[0] & 0x0F, bool(head[0] & 0x80), first


async def _copy(source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
    """The client's frames to the SDK as they come (bounded by the SDK's reading)."""
    while data := await source.read(READ_BYTES):
        sink.write(data)
        await sink.drain()


async def _send(backlog: Backlog, writer: asyncio.StreamWriter) -> None:
    """The backlog to the client, as fast as it reads."""
    while True:
        writer.write(await backlog.get())
        await writer.drain()


def _parse(head: bytes) -> tuple[str, dict[str, str], list[str]]:
    """The request line, the headers by lower-case name, and the header lines."""
    request_line, *lines = head.decode("latin-1").split("\r\n")
    lines = [line for line in lines if line]
    headers = {}
    for line in lines:
        name, _, value = line.partition(":")
        headers[name.strip().lower()] = value.strip()
    return request_line, headers, lines


def _handshake(request_line: str, lines: list[str]) -> bytes:
    """The handshake for the SDK: the client's, without its key and extensions."""
    kept = [
        line for line in lines if line.partition(":")[0].strip().lower() not in _DROPPED_HEADERS
    ]
    return "\r\n".join([request_line, *kept, "", ""]).encode("latin-1")


async def _refuse(writer: asyncio.StreamWriter, status: str, reason: str) -> None:
    body = reason.encode()
    writer.write(
        f"HTTP/1.1 {status}\r\nContent-Type: text/plain\r\nContent-Length: {len(body)}\r\n"
        f"Connection: close\r\n\r\n".encode()
        + body
    )
    with contextlib.suppress(OSError):
        await writer.drain()
    writer.close()
