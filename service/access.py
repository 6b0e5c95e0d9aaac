"""Who may connect: the one authentication policy of every listener.

The HTTP API (:class:`plotgate.service.guards.Auth`) and the live view's gate
(:mod:`plotgate.service.scenes.live_gate`) both hold a :class:`Keys` made from the same
settings (``PLOTGATE_API_KEY``, ``PLOTGATE_BEARER_TOKEN``) by :meth:`Keys.from_settings`,
and both ask :meth:`Keys.allows`. A listener added later does the same. Nothing is sent
before it answers yes.

A key is accepted as an ``X-API-Key`` header, as an ``Authorization: Bearer`` token, or,
where the listener allows it (a WebSocket, whose browser clients cannot set headers), as
``?key=`` in the URL. Every comparison is made in constant time (``hmac.compare_digest``).

Binding: a listener on an address other than loopback with no keys set answers anyone.
That takes an explicit ``PLOTGATE_ALLOW_UNAUTHENTICATED`` (``serve --allow-unauthenticated``)
and warns (:func:`binding_refusal`).

Standard library only, so the live view's publisher process imports it cheaply.
"""

import hmac
import ipaddress
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["QUERY_KEY", "Keys", "binding_refusal", "loopback"]

QUERY_KEY = "key"
"""The URL query parameter that carries a key where headers cannot (``ws://host:port/?key=``)."""


@dataclass(frozen=True)
class Keys:
    """The secrets a client must show: an API key, a bearer token, both, or none (then
    every client is let in)."""

    api_key: bytes | None = None
    bearer_token: bytes | None = None

    @classmethod
    def from_settings(cls, settings: Any) -> "Keys":
        """The keys of ``settings`` (a :class:`plotgate.service.config.Settings`)."""
        api_key, bearer = settings.api_key, settings.bearer_token
        return cls(
            api_key.get_secret_value().encode() if api_key else None,
            bearer.get_secret_value().encode() if bearer else None,
        )

    @property
    def required(self) -> bool:
        """Some key is set: a client without one is refused."""
        return self.api_key is not None or self.bearer_token is not None

    def allows(self, headers: Mapping[str, str], query_key: str | None = None) -> bool:
        """The client showed a key: ``headers`` (lower-case names) hold an ``x-api-key``
        equal to the API key or an ``authorization: Bearer`` equal to the token, or
        ``query_key`` (from the URL, where the listener takes it) equals either. True
        whenever no key is set."""
        if not self.required:
            return True
        given_key = headers.get("x-api-key")
        if given_key is not None and _equal(given_key, self.api_key):
            return True
        scheme, _, token = (headers.get("authorization") or "").partition(" ")
        if scheme.lower() == "bearer" and _equal(token.strip(), self.bearer_token):
            return True
        return query_key is not None and (
            _equal(query_key, self.api_key) | _equal(query_key, self.bearer_token)
        )

    def ways(self) -> list[str]:
        """How a client may show a key, for refusals."""
        return [
            way
            for way, on in (
                ("an X-API-Key header", self.api_key),
                ("an Authorization: Bearer token", self.bearer_token),
            )
            if on
        ]


def _equal(given: str, secret: bytes | None) -> bool:
    if secret is None:
        return False
    try:
        return hmac.compare_digest(given.encode("latin-1"), secret)
    except UnicodeEncodeError:
        return False


def loopback(host: str) -> bool:
    """``host`` is a loopback address (127.0.0.0/8, ::1) or ``localhost``."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False  # a name: it may resolve to any interface


def binding_refusal(
    listener: str, host: str, keys: Keys, allow_unauthenticated: bool
) -> tuple[str | None, str | None]:
    """``(refusal, warning)`` for ``listener`` bound to ``host``: a refusal when the address
    is not loopback, no key is set and no one allowed it; a warning when it was allowed."""
    if keys.required or loopback(host):
        return None, None
    what = f"{listener} on {host} without PLOTGATE_API_KEY or PLOTGATE_BEARER_TOKEN"
    if not allow_unauthenticated:
        return (
            f"{what} would answer anyone: set a key, or pass --allow-unauthenticated "
            "(PLOTGATE_ALLOW_UNAUTHENTICATED=true)",
            None,
        )
    return None, f"{what}: anyone who reaches it can use it (--allow-unauthenticated)"
