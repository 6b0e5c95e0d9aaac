"""Connections that never finish their headers are closed.

uvicorn waits for ever for the headers of a connection's first request: a client that
opens connections and sends nothing, or half a request line, holds them until the server
runs out of sockets. :class:`HeaderDeadline` is uvicorn's httptools protocol with one
deadline more: from a connection's start, and from the end of each response, the next
request's headers must be complete within ``PLOTGATE_HEADER_TIMEOUT_S``, or the connection
is closed. Bodies have their own deadline (``PLOTGATE_BODY_TIMEOUT_S``,
:mod:`plotgate.service.bodies`). ``plotgate serve`` uses it (``uvicorn.run(...,
http=HeaderDeadline)``, with uvloop's event loop); a server started with the bare
``uvicorn`` command does not.

httptools (llhttp, in C) rather than h11 (pure Python): measured with
``bench/bench_service.py``, the same app answers about a third more gate tests per second
on httptools and uvloop than on h11 and asyncio's loop.
"""

import asyncio

from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

from plotgate.service.config import get_settings

__all__ = ["HeaderDeadline"]


class HeaderDeadline(HttpToolsProtocol):
    """uvicorn's httptools protocol, closing a connection whose request headers are late."""

    _header_timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._arm()

    def on_headers_complete(self) -> None:
        self._disarm()  # the headers are in
        super().on_headers_complete()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing():
            self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm()
        super().connection_lost(exc)

    def _arm(self) -> None:
        self._disarm()
        self._header_timer = self.loop.call_later(get_settings().header_timeout_s, self._late)

    def _disarm(self) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
            self._header_timer = None

    def _late(self) -> None:
        """Close the connection unless a request (a pipelined one, say) is under way."""
        self._header_timer = None
        idle = self.cycle is None or self.cycle.response_complete
        if idle and not self.transport.is_closing():
            self.transport.close()
