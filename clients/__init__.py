"""plotgate clients: typed httpx client (sync and async), recordings reader, replay, CLI.

Imports only :mod:`plotgate.service.schemas` from the service side (pydantic, no FastAPI).
"""

from plotgate.clients.client import DEFAULT_TIMEOUT, DEFAULT_URL, AsyncClient, Client
from plotgate.clients.errors import (
    ClusterUnavailable,
    InvalidInputError,
    PlotgateClientError,
    ProblemError,
    RecordingUnavailable,
    ServerError,
    ServiceUnavailable,
    TransportError,
)

__all__ = [
    "DEFAULT_TIMEOUT",
    "DEFAULT_URL",
    "AsyncClient",
    "Client",
    "ClusterUnavailable",
    "InvalidInputError",
    "PlotgateClientError",
    "ProblemError",
    "RecordingUnavailable",
    "ServerError",
    "ServiceUnavailable",
    "TransportError",
]
