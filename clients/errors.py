"""Client exceptions, one base to catch them all::

PlotgateClientError
├── TransportError            the server could not be reached or did not answer in time
└── ProblemError              the server answered with an RFC 9457 problem
    ├── InvalidInputError     400 / 422: the request named in ``problem.errors`` is wrong
    ├── RecordingUnavailable  503: the server refused to answer unrecorded; retry later
    └── ServerError           any other status (500 is a bug in plotgate)
"""

import httpx

from plotgate.service.schemas import Problem

__all__ = [
    "InvalidInputError",
    "PlotgateClientError",
    "ProblemError",
    "RecordingUnavailable",
    "ServerError",
    "TransportError",
    "raise_for_problem",
]


class PlotgateClientError(Exception):
    """Base of every error the plotgate client raises."""


class TransportError(PlotgateClientError):
    """The request did not get an HTTP answer (connection refused, timeout, ...)."""


class ProblemError(PlotgateClientError):
    """The service answered with a problem body."""

    def __init__(self, problem: Problem, url: str) -> None:
        self.problem = problem
        self.url = url
        fields = ", ".join(f"{e.field}: {e.reason}" for e in problem.errors)
        super().__init__(
            f"{problem.status} {problem.title} from {url}"
            f" (request {problem.request_id}): {fields or problem.detail}"
        )


class InvalidInputError(ProblemError):
    """The request was refused; ``problem.errors`` names each offending field."""


class RecordingUnavailable(ProblemError):
    """The service could not record the exchange and so did not answer it."""


class ServerError(ProblemError):
    """Any other problem answer."""


def raise_for_problem(response: httpx.Response) -> None:
    """Raise the :class:`ProblemError` subclass matching a non-2xx answer."""
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
        raise InvalidInputError(problem, url)
    if response.status_code == 503:
        raise RecordingUnavailable(problem, url)
    raise ServerError(problem, url)
