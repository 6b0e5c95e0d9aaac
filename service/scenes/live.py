"""``plotgate serve --foxglove-port PORT``: the scenes of exchanges as they are answered, on
foxglove-sdk's WebSocket server (Foxglove's ``foxglove.websocket.v1`` protocol).

The answer never waits for the picture. The route hands each answered exchange's two
records to :meth:`LiveView.offer`, which appends them to a bounded queue (at most
:data:`QUEUE_EXCHANGES` exchanges and :data:`QUEUE_BYTES` bytes) or, when it is full,
counts the exchange dropped: a list append and two comparisons, on the event loop. A
thread forwards the queue in batches, every :data:`FORWARD_S`, through a pipe to a
publisher process, which parses the records, builds the scenes with the same builder as
``plotgate view`` (:func:`plotgate.service.scenes.scene_messages`) and logs them on
foxglove-sdk's channels. The SDK's server listens on loopback only; the port given is
:mod:`plotgate.service.scenes.live_gate`'s, which asks every client for the API's key
before it sends a byte, caps the clients connected, and keeps each client's backlog bounded
(dropping the oldest scene for a slow one, counted in ``/metrics``).

Decisions where the issue is silent:

- **A process, not a thread.** Building a scene holds the interpreter (the SDK's objects
  are built one by one: about 1 ms for a gate test of 100 plots); in a thread of the
  server's process it would take that time from the event loop. The publisher is spawned
  (not forked: a fork copies the server's locks and listening socket) and runs at a low
  CPU priority (:data:`NICENESS`), so on a busy machine it is the picture that falls
  behind, and what it cannot take is dropped at the queue and counted.
- **Records over** :data:`MAX_RECORD_BYTES` are not sent: a 64 MiB body is not drawn live
  (``plotgate view`` draws it, under the scene's caps); a Log message says so, and it
  counts as dropped (``reason="too_large"``).
- **One publisher per server**, its gate binding ``--foxglove-host`` (127.0.0.1 by
  default) and the port given; ``serve --workers N`` with N > 1 is refused with it (each
  worker would bind the port). With no key set, a host other than loopback needs
  ``--allow-unauthenticated`` (:func:`plotgate.service.access.binding_refusal`).
- **A publisher that fails** (the port taken, foxglove-sdk missing, the process killed)
  costs the live view, never an answer: the server logs it, goes on answering and
  recording, and counts every exchange after it as dropped (``reason="no_publisher"``).
"""

import asyncio
import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Callable, MutableSequence
from multiprocessing.connection import Connection
from typing import Any

from plotgate.service.access import Keys
from plotgate.service.scenes.live_gate import (
    CLIENTS,
    COUNTERS,
    DROPPED,
    REFUSED_FULL,
    REFUSED_KEY,
    Gate,
)

__all__ = [
    "FORWARD_S",
    "MAX_RECORD_BYTES",
    "QUEUE_BYTES",
    "QUEUE_EXCHANGES",
    "LiveView",
    "publish",
]

log = logging.getLogger("plotgate")

QUEUE_EXCHANGES = 4096
QUEUE_BYTES = 64 * 2**20
MAX_RECORD_BYTES = 2**20
FORWARD_S = 0.05
NICENESS = 10
"""The publisher's nice value: the server's answers first. At 19 a test on a loaded
machine (load average 15 on 2 cores) saw no scene within 60 s; at 10 the publisher's
share of a contended core is seven times larger, and still about a tenth of the server's."""
START_TIMEOUT_S = 60.0
"""Longest wait for the publisher to bind its port (it imports the service's scenes)."""

Offered = tuple[str, int, bytes, bytes]
"""(operation, arrival time in ns, request record, response record)."""


class LiveView:
    """The server's side: the bounded queue, the forwarding thread and the publisher
    process. ``published`` counts the exchanges handed to the publisher, ``dropped`` those
    that were not, by reason; the gate's counters are read through :attr:`clients`,
    :attr:`refused` and :attr:`client_dropped`."""

    def __init__(
        self, host: str, port: int, keys: Keys | None = None, max_clients: int = 64
    ) -> None:
        self.host, self.port = host, port
        self.keys = keys or Keys()
        self.max_clients = max_clients
        self._counters: MutableSequence[int] = [0] * COUNTERS
        self.published = 0
        self.dropped = {"queue_full": 0, "too_large": 0, "no_publisher": 0}
        self._queue: list[Offered] = []
        self._queued_bytes = 0
        self._wake = threading.Event()
        self._stopping = False
        self._conn: Connection | None = None
        self._process: Any = None
        self._thread: threading.Thread | None = None

    def start(self) -> "LiveView":
        """Spawn the publisher and wait until it serves (``RuntimeError`` saying why not)."""
        context = multiprocessing.get_context("spawn")
        ours, theirs = context.Pipe()
        self._counters = context.RawArray("q", COUNTERS)
        self._process = context.Process(
            target=publish,
            args=(theirs, self.host, self.port, self.keys, self.max_clients, self._counters),
            name="plotgate-foxglove",
            daemon=True,
        )
        self._process.start()
        theirs.close()
        if not ours.poll(START_TIMEOUT_S):
            self._process.kill()
            raise RuntimeError(f"the Foxglove publisher did not start in {START_TIMEOUT_S:.0f} s")
        status, detail = ours.recv()
        if status != "serving":
            self._process.join(5)
            raise RuntimeError(f"the Foxglove publisher cannot serve: {detail}")
        self.port = detail
        self._conn = ours
        self._thread = threading.Thread(
            target=self._forward, name="plotgate-foxglove-forward", daemon=True
        )
        self._thread.start()
        return self

    @property
    def clients(self) -> int:
        """Live view clients connected now."""
        return int(self._counters[CLIENTS])

    @property
    def refused(self) -> dict[str, int]:
        """Clients refused: without a key, or over the cap."""
        return {"key": self._counters[REFUSED_KEY], "full": self._counters[REFUSED_FULL]}

    @property
    def client_dropped(self) -> int:
        """Scenes dropped from slow clients' backlogs."""
        return int(self._counters[DROPPED])

    def offer(self, operation: str, log_time: int, request: bytes, response: bytes) -> None:
        """Queue an answered exchange for the picture, or count it dropped (never waits)."""
        size = len(request) + len(response)
        if self._conn is None:
            self.dropped["no_publisher"] += 1
        elif len(request) > MAX_RECORD_BYTES or len(response) > MAX_RECORD_BYTES:
            self.dropped["too_large"] += 1
            if len(self._queue) < QUEUE_EXCHANGES:  # said in a Log message
                self._queue.append((operation, log_time, b"", b""))
        elif len(self._queue) >= QUEUE_EXCHANGES or self._queued_bytes + size > QUEUE_BYTES:
            self.dropped["queue_full"] += 1
        else:
            # list.append is atomic under the interpreter's lock; the thread swaps the list
            self._queue.append((operation, log_time, request, response))
            self._queued_bytes += size

    def _forward(self) -> None:
        """Send the queue to the publisher in batches until :meth:`close`."""
        while not self._stopping:
            self._wake.wait(FORWARD_S)
            batch, self._queue, self._queued_bytes = self._queue, [], 0
            if not batch or self._conn is None:
                continue
            try:
                self._conn.send(batch)
                self.published += sum(1 for _, _, request, _ in batch if request)
            except (OSError, ValueError) as exc:  # the publisher died: the view is lost
                log.error("the Foxglove publisher is gone (%s); the live view stops", exc)
                self.dropped["no_publisher"] += len(batch)
                self._conn = None

    def close(self) -> None:
        """Stop forwarding, then the publisher (its server closes its connections)."""
        self._stopping = True
        self._wake.set()
        if self._thread is not None:
            self._thread.join(5)
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        if self._process is not None:
            self._process.join(5)
            if self._process.is_alive():
                self._process.kill()
                self._process.join(5)


def publish(
    conn: Connection,
    host: str,
    port: int,
    keys: Keys,
    max_clients: int,
    counters: MutableSequence[int],
) -> None:
    """The publisher process: the SDK's server on loopback, the gate on ``host:port``, then
    draw every batch received until the pipe closes. Reports ``("serving", port)`` or
    ``("failed", why)`` first."""
    os.nice(NICENESS)
    try:
        import foxglove

        from plotgate.service.scenes.channels import LiveChannels

        server = foxglove.start_server(name="plotgate", host="127.0.0.1", port=0)
        channels = LiveChannels()
        gate = Gate(keys, server.port, max_clients, counters)
        loop, bound = _start_gate(gate, host, port)
    except Exception as exc:  # noqa: BLE001 - said to the server, which goes on without us
        conn.send(("failed", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("serving", bound))
    try:
        _draw_until_closed(conn, channels.log_exchange)
    finally:
        loop.call_soon_threadsafe(loop.stop)
        server.stop()


def _start_gate(gate: Gate, host: str, port: int) -> tuple[asyncio.AbstractEventLoop, int]:
    """Run ``gate`` on its own loop in a thread; the loop and the port it bound
    (``OSError`` when it cannot listen)."""
    loop = asyncio.new_event_loop()
    server = loop.run_until_complete(gate.serve(host, port))
    thread = threading.Thread(target=loop.run_forever, name="plotgate-live-gate", daemon=True)
    thread.start()
    return loop, int(server.sockets[0].getsockname()[1])


def _draw_until_closed(conn: Connection, draw: Callable[[Offered], None]) -> None:
    while True:
        try:
            batch = conn.recv()
        except (EOFError, OSError):
            return
        started = time.monotonic()
        for offered in batch:
            draw(offered)
        log.debug("drew %d exchanges in %.3f s", len(batch), time.monotonic() - started)
