"""Client exceptions, one base to catch them all::

PlotgateClientError
├── TransportError              the server could not be reached or did not answer in time
├── InvalidResponseError        an answer that is not the operation's: not JSON, cut short,
│   │                           the wrong schema, out of bounds, nested too deep
│   └── ResponseTooLarge        a body over the client's ``max_response_bytes``, not read on
└── ProblemError                the server answered with an RFC 9457 problem
    ├── InvalidInputError       400 / 422: the request named in ``problem.errors`` is wrong
    ├── ServiceUnavailable      503: the service cannot answer now; retry later
    │   ├── RecordingUnavailable  it could not record the exchange, so it refused it
    │   └── ClusterUnavailable    its Dask cluster cannot be had
    └── ServerError             any other status (500 is a bug in plotgate)

The clients retry a 503 and a failed connection before raising (see
:class:`plotgate.clients.Client`); the exception of the last attempt says how many there were.
An invalid or oversized answer is not retried: whatever sent it would send it again.
A non-2xx answer whose body is not a problem (a proxy's HTML 502, say) is the
:class:`ProblemError` of its status all the same, its problem made up from the status and the
start of the body.
"""

import httpx

from plotgate.service.schemas import Problem

__all__ = [
    "CLUSTER_UNAVAILABLE",
    "MESSAGE_CHARS",
    "RECORDING_UNAVAILABLE",
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
    "raise_for_problem",
]

RECORDING_UNAVAILABLE = "urn:plotgate:problem:recording-unavailable"
"""The problem ``type`` of a 503 whose exchange could not be recorded."""
CLUSTER_UNAVAILABLE = "urn:plotgate:problem:cluster-unavailable"
"""The problem ``type`` of a 503 whose Dask cluster could not be had."""
MESSAGE_CHARS = 2000
"""The longest part of a message taken from an answer (a problem's title, or its fields or
detail): a server, or a proxy, may send megabytes of them."""


class PlotgateClientError(Exception):
    """Base of every error the plotgate client raises."""


class TransportError(PlotgateClientError):
    """The request did not get an HTTP answer (connection refused, timeout, ...)."""


class InvalidResponseError(PlotgateClientError):
    """The service, or whatever answered in its place, sent an answer the client cannot take:
    ``reason`` says what was wrong with it. ``status`` is the answer's HTTP status, ``url``
    where it came from, ``request_id`` the call's id (the answer's ``X-Request-ID``, else the
    one the call sent) and ``attempts`` how many requests the call made."""

    def __init__(
        self, reason: str, status: int, url: str, request_id: str | None, attempts: int = 1
    ) -> None:
        self.reason = reason
        self.status = status
        self.url = url
        self.request_id = request_id
        self.attempts = attempts
        tries = f" (after {attempts} attempts)" if attempts > 1 else ""
        super().__init__(
            f"{status} from {url} (request {request_id}): invalid answer: {reason}{tries}"
        )


class ResponseTooLarge(InvalidResponseError):
    """The answer's body passed the client's ``max_response_bytes``; the client stopped
    reading it there and closed the connection."""


class ProblemError(PlotgateClientError):
    """The service answered with a problem body; ``attempts`` is how many requests it took
    (more than one when the client retried)."""

    def __init__(self, problem: Problem, url: str, attempts: int = 1) -> None:
        self.problem = problem
        self.url = url
        self.attempts = attempts
        tries = f" (after {attempts} attempts)" if attempts > 1 else ""
        super().__init__(
            f"{problem.status} {problem.title[:MESSAGE_CHARS]} from {url}"
            f" (request {problem.request_id}): {_what(problem)}{tries}"
        )


def _what(problem: Problem, shown: int = 5) -> str:
    """The first ``shown`` offending fields, else the detail, within :data:`MESSAGE_CHARS`:
    the whole problem stays on the exception, the message stays readable."""
    errors = problem.errors
    fields = ", ".join(f"{e.field}: {e.reason}" for e in errors[:shown])
    if len(errors) > shown:
        fields += f" (and {len(errors) - shown} more)"
    what = fields or problem.detail
    return what if len(what) <= MESSAGE_CHARS else what[:MESSAGE_CHARS] + "..."


class InvalidInputError(ProblemError):
    """The request was refused; ``problem.errors`` names each offending field."""


class ServiceUnavailable(ProblemError):
    """A 503: the service (or a proxy before it) cannot answer now; the same request may
    succeed later."""


class RecordingUnavailable(ServiceUnavailable):
    """The service could not record the exchange and so did not answer it."""


class ClusterUnavailable(ServiceUnavailable):
    """The service's Dask cluster could not be reached. (Work that did not finish on it in
    time is a 504 ``cluster-timeout``, a :class:`ServerError`, not retried.)"""


class ServerError(ProblemError):
    """Any other problem answer."""


def raise_for_problem(response: httpx.Response, attempts: int = 1) -> None:
    """Raise the :class:`ProblemError` subclass matching a non-2xx answer, the last of
    ``attempts`` requests."""
    if response.is_success:
        return
    try:
        problem = Problem.model_validate_json(response.content)
    except ValueError:
        problem = Problem(
            type="about:blank",
            title=response.reason_phrase,
            status=response.status_code,
            detail=response.text[:500],
            request_id=response.headers.get("x-request-id"),
        )
    url = str(response.request.url)
    if response.status_code in (400, 422):
        raise InvalidInputError(problem, url, attempts)
    if response.status_code == 503:
        unavailable = {
            RECORDING_UNAVAILABLE: RecordingUnavailable,
            CLUSTER_UNAVAILABLE: ClusterUnavailable,
        }.get(problem.type, ServiceUnavailable)
        raise unavailable(problem, url, attempts)
    raise ServerError(problem, url, attempts)
