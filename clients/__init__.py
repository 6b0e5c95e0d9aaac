"""plotgate clients: typed httpx client (sync and async), recordings reader, replay, CLI.

Imports only :mod:`plotgate.service.schemas` from the service side (pydantic, no FastAPI).
"""

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
