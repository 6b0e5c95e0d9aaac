"""Property-based fuzzing of every operation from the OpenAPI schema (Schemathesis).

Fixed seed (derandomized Hypothesis) and a bounded budget: ``MAX_EXAMPLES`` cases per
operation and mode. Every answer must be below 500, every 4xx a problem+json (a 422 or
413 naming the field or limit; Schemathesis also sends undeclared methods, answered 405
with ``Allow``), and every response valid against the OpenAPI schema (Schemathesis' own
checks).

Two exceptions, both deliberate:

* Schema-valid requests may still be refused (check ``positive_data_acceptance`` off):
  rules over several fields (exactly one of two alternatives, matching lengths, one
  dimension per request) and the mathematics (a geometry with no solution) cannot be
  written in JSON Schema, and answer 422 naming the field.
* Operations whose valid requests may ask for minutes of work within their limits
  (Monte Carlo runs, quadratures, studies: :data:`EXPENSIVE`) are fuzzed with invalid
  data only, so CI stays bounded; their valid paths are tested by their own tests.
"""

import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis import GenerationMode
from schemathesis.checks import positive_data_acceptance

from service.app import create_app
from service.config import Settings

MAX_EXAMPLES = 12
EXPENSIVE = {"/v1/gates/probability", "/v1/gates/probability/curve", "/v1/gates/analysis",
             "/v1/gates/design", "/v1/solves/study", "/v1/initiation/evaluate",
             "/v1/initiation/simulate", "/v1/identification/simulate"}

APP = create_app(Settings(record=False))
valid_and_invalid = schemathesis.openapi.from_asgi("/openapi.json", APP)
valid_and_invalid.config.generation.update(modes=[GenerationMode.POSITIVE,
                                                   GenerationMode.NEGATIVE])
invalid_only = schemathesis.openapi.from_asgi("/openapi.json", APP)
invalid_only.config.generation.update(modes=[GenerationMode.NEGATIVE])
BUDGET = settings(max_examples=MAX_EXAMPLES, deadline=None, derandomize=True,
                  suppress_health_check=list(HealthCheck))


def _check(case) -> None:
    response = case.call_and_validate(excluded_checks=[positive_data_acceptance])
    assert response.status_code < 500, response.text
    if 400 <= response.status_code < 500 and case.path.startswith("/v1/"):
        content_type = response.headers["content-type"]  # a list of values
        assert content_type[0].startswith("application/problem+json"), content_type
        problem = response.json()
        if response.status_code in (413, 422):  # a body problem names its field or limit
            assert problem["errors"] and all(e["field"] for e in problem["errors"]), problem


@valid_and_invalid.exclude(path=sorted(EXPENSIVE)).parametrize()
@BUDGET
def test_cheap_operations(case):
    _check(case)


@invalid_only.include(path=sorted(EXPENSIVE)).parametrize()
@BUDGET
def test_expensive_operations_with_invalid_data(case):
    _check(case)
