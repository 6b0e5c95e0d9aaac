"""plotgate clients: typed httpx client (sync and async), recordings reader, replay, CLI.

Imports only :mod:`plotgate.service.schemas` from the service side (pydantic, no FastAPI),
and only when a name below is first used.
"""

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from plotgate.clients.client import (
        DEFAULT_MAX_RESPONSE_BYTES,
        DEFAULT_TIMEOUT,
        DEFAULT_URL,
        AsyncClient,
        Client,
        parse_answer,
    )
    from plotgate.clients.errors import (
        ClusterUnavailable,
        InvalidInputError,
        InvalidResponseError,
        PlotgateClientError,
        ProblemError,
        RecordingUnavailable,
        ResponseTooLarge,
        ServerError,
        ServiceUnavailable,
        TransportError,
    )

__all__ = [
    "DEFAULT_MAX_RESPONSE_BYTES",
    "DEFAULT_TIMEOUT",
    "DEFAULT_URL",
    "AsyncClient",
    "Client",
    "ClusterUnavailable",
    "InvalidInputError",
    "InvalidResponseError",
    "PlotgateClientError",
    "ProblemError",
    "RecordingUnavailable",
    "ResponseTooLarge",
    "ServerError",
    "ServiceUnavailable",
    "TransportError",
    "parse_answer",
]

_FROM_CLIENT = frozenset(
    [
        "DEFAULT_MAX_RESPONSE_BYTES",
        "DEFAULT_TIMEOUT",
        "DEFAULT_URL",
        "AsyncClient",
        "Client",
        "parse_answer",
    ]
)
"""The names from :mod:`plotgate.clients.client`; the others are from ``errors``."""


def __getattr__(name: str) -> Any:
    """The names above, imported when first used (PEP 562): the ``plotgate`` command imports
    this package, and httpx and the wire schemas would cost it a third of a second before
    ``--help`` could answer."""
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module = "client" if name in _FROM_CLIENT else "errors"
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value
