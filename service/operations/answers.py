"""An answer that fails its own validation is a bug (a 500), never bad input (a 422).

The registry validates the request before a handler runs and reports a pydantic
``ValidationError`` as bad input naming its fields. One raised while the handler builds
its answer (a non-finite number in a response model) would then be reported as a 422
naming fields of the *answer* (``probability``, ``z[0][0]``) as if the caller had sent
them. :func:`checked` turns it into the ``RuntimeError`` it is, which the route answers
with 500 and logs.
"""

import functools
from collections.abc import Callable
from typing import TypeVar

from pydantic import BaseModel, ValidationError

__all__ = ["checked"]

Req = TypeVar("Req", bound=BaseModel)
Res = TypeVar("Res", bound=BaseModel)


def checked(handler: Callable[[Req], Res]) -> Callable[[Req], Res]:
    """The handler, with a ``ValidationError`` of its answer raised as a RuntimeError."""

    @functools.wraps(handler)
    def run(request: Req) -> Res:
        try:
            return handler(request)
        except ValidationError as exc:
            raise RuntimeError(f"{handler.__name__} built an invalid answer: {exc}") from None

    return run
