"""Connections that never finish their headers are closed.

uvicorn waits for ever for the headers of a connection's first request: a client that
opens connections and sends nothing, or half a request line, holds them until the server
runs out of sockets. :class:`HeaderDeadline` is uvicorn's h11 protocol with one deadline
more: from a connection's start, and from the end of each response, the next request's
headers must be complete within ``PLOTGATE_HEADER_TIMEOUT_S``, or the connection is closed.
Bodies have their own deadline (``PLOTGATE_BODY_TIMEOUT_S``, :mod:`plotgate.service.bodies`).
``plotgate serve`` uses it (``uvicorn.run(..., http=HeaderDeadline)``); a server started
with the bare ``uvicorn`` command does not.
"""

import asyncio

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

from plotgate.service.config import get_settings

__all__ = ["HeaderDeadline"]


class HeaderDeadline(H11Protocol):
    """uvicorn's h11 protocol, closing a connection whose request headers are late."""

    _header_timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._arm()

    def handle_events(self) -> None:
        super().handle_events()
        if self.conn.their_state is not h11.IDLE and self._header_timer is not None:
            self._header_timer.cancel()  # the headers are in
            self._header_timer = None

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing():
            self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
        super().connection_lost(exc)

    def _arm(self) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
        self._header_timer = self.loop.call_later(get_settings().header_timeout_s, self._late)

    def _late(self) -> None:
        self._header_timer = None
        if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
            self.transport.close()
