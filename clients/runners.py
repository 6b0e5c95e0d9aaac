"""Run one operation's requests (plain JSON dicts) in-process or through a client.

The figure and study commands build their requests as dicts and answer them either
through this build's operation registry (imported lazily, as replay does, so ``import
clients`` never pulls in core) or against a live server through :class:`plotgate.clients.Client`.
"""

import json
from collections.abc import Callable
from typing import Any

__all__ = ["Runner", "http_runner", "in_process_runner"]

Runner = Callable[[dict[str, Any]], dict[str, Any]]
"""Runs one request (a JSON dict) and returns its answer (a JSON dict)."""


def in_process_runner(operation: str) -> Runner:
    """Run requests through this build's operation registry, as the server would."""
    from plotgate.clients.errors import InvalidInputError, ServerError
    from plotgate.service.registry import OPERATIONS, execute
    from plotgate.service.schemas import Problem

    op = OPERATIONS[operation]

    def run(body: dict[str, Any]) -> dict[str, Any]:
        outcome = execute(op, json.dumps(body).encode())
        if outcome.status >= 400:
            problem = Problem.model_validate_json(outcome.content)
            error = InvalidInputError if outcome.status in (400, 422) else ServerError
            raise error(problem, f"in-process {op.path}")
        return outcome.json()

    return run


def http_runner(client: Any, operation: str) -> Runner:
    """Run requests through a :class:`plotgate.clients.Client` (validated against the wire
    model)."""
    from plotgate.service.table import ENDPOINTS

    model = ENDPOINTS[operation].request

    def run(body: dict[str, Any]) -> dict[str, Any]:
        return client.call(operation, model.model_validate(body)).model_dump(mode="json")

    return run
