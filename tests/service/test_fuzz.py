"""Property-based fuzzing of every operation from the OpenAPI schema (Schemathesis).

All three of Schemathesis' phases run on every operation, with positive and negative
data: *examples* sends each operation's OpenAPI example (its declaration's
``example_body``, :data:`plotgate.service.table.ENDPOINTS`), *coverage* the schema's
boundary values and violations around it, *fuzzing* Hypothesis-generated bodies. A
positive body is
first repaired (:func:`tests.service.valid_bodies.repaired`) to pass the rules over
several fields that JSON Schema cannot say (matching lengths, one dimension, exactly one
of two alternatives) and to fit the work caps below, so the valid paths of every
operation are fuzzed too; without it Schemathesis generated no valid ``solves.*``
request, and the expensive operations were fuzzed with invalid data only.

Every answer must be below 500, every 4xx a problem+json (a 422 naming fields of the
request, a 413 its limit; undeclared methods answer 405 with ``Allow``), and every
response valid against the OpenAPI schema: status code, content type and body
(Schemathesis' own checks). One check is off, ``positive_data_acceptance``: a
schema-valid request may still be refused by the mathematics (a geometry with no
solution), answered 422 naming the field. The last test holds that every operation
answered at least one 2xx.

Cost is bounded by work caps, as an operator sets them (``PLOTGATE_LIMITS``, here
:data:`CAPS`): a few Monte Carlo runs, samples and curve points, and an error ellipse of
axis ratio at most 3 for the unconditional gating probabilities; larger requests answer
422 naming the size. Fixed seed (derandomized Hypothesis); ``PLOTGATE_FUZZ_EXAMPLES``
Hypothesis examples per operation in the fuzzing phase (default 12; docs/reliability.md's longer
run uses 100); ``PLOTGATE_FUZZ_REPORT=file.json`` writes the answers per operation and
status there.
"""

import json
import os
from collections import Counter

import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis import GenerationMode
from schemathesis.checks import positive_data_acceptance

from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS
from tests.support.valid_bodies import repaired

MAX_EXAMPLES = int(os.environ.get("PLOTGATE_FUZZ_EXAMPLES", "12"))
CAPS = {
    "gates.probability": {"mark.axis_ratio": 3},
    "gates.probability_curve": {"mark.axis_ratio": 3, "values": 3},
    "gates.analysis": {"mark.axis_ratio": 3},
    "gates.design": {"mark.axis_ratio": 3},
    "solves.study": {"runs": 3, "sample_times": 6},
    "initiation.simulate": {"scenario.scans": 4},
    "initiation.evaluate": {"runs": 2, "scenario.scans": 4, "scenario.clutter": 20},
    "identification.simulate": {"runs": 100},
}
"""Work caps (PLOTGATE_LIMITS) that keep every valid request to a second or so."""

APP = create_app(Settings(record=False, limits=CAPS))
schema = schemathesis.openapi.from_asgi("/openapi.json", APP)
schema.config.generation.update(modes=[GenerationMode.POSITIVE, GenerationMode.NEGATIVE])
BUDGET = settings(
    max_examples=MAX_EXAMPLES,
    deadline=None,
    derandomize=True,
    suppress_health_check=list(HealthCheck),
)
OPERATION_OF = {op.path: op.name for op in OPERATIONS.values()}
ANSWERED: Counter[tuple[str, int]] = Counter()
"""(operation, status) -> answers, over the whole module."""


def _positive(case) -> bool:
    meta = case.meta
    return meta is not None and meta.generation.mode == GenerationMode.POSITIVE


@schema.parametrize()
@BUDGET
def test_operation(case):
    if (
        case.path in OPERATION_OF
        and case.method.upper() == "POST"
        and _positive(case)
        and isinstance(case.body, dict)
    ):
        case.body = repaired(case.path, case.body, CAPS.get(OPERATION_OF[case.path]))
    response = case.call_and_validate(excluded_checks=[positive_data_acceptance])
    if case.path in OPERATION_OF:
        ANSWERED[OPERATION_OF[case.path], response.status_code] += 1
    assert response.status_code < 500, response.text
    if 400 <= response.status_code < 500 and case.path.startswith("/v1/"):
        content_type = response.headers["content-type"]  # a list of values
        assert content_type[0].startswith("application/problem+json"), content_type
        problem = response.json()
        if response.status_code in (413, 422):  # a body problem names its field or limit
            assert problem["errors"] and all(e["field"] for e in problem["errors"]), problem
        if response.status_code == 422:  # fields of the request, never of the answer:
            # the model's, a key the body sent (an unknown one), the body itself, or a
            # declared work size over its cap (``passive_deg x active_deg``)
            sent = case.body if isinstance(case.body, dict) else {}
            op = OPERATIONS[OPERATION_OF[case.path]]
            fields = {*op.request.model_fields, *op.endpoint.work, *sent, "body"}
            tops = {e["field"].replace("[", ".").split(".")[0] for e in problem["errors"]}
            assert tops <= fields, problem


def test_every_operation_answered_a_valid_request():
    # runs after the fuzzing above (pytest keeps a module's order): every operation was
    # fuzzed, and valid requests reached every operation's handler
    report = os.environ.get("PLOTGATE_FUZZ_REPORT")
    if report:  # answers per operation and status, for docs/reliability.md's table
        tally: dict[str, dict[int, int]] = {}
        for (name, status), n in sorted(ANSWERED.items()):
            tally.setdefault(name, {})[status] = n
        with open(report, "w") as out:
            json.dump(tally, out, indent=1)
    fuzzed = {name for name, _ in ANSWERED}
    assert fuzzed == set(OPERATIONS), (
        f"not fuzzed (run the whole module): {sorted(set(OPERATIONS) - fuzzed)}"
    )
    valid = {name for (name, status), n in ANSWERED.items() if 200 <= status < 300 and n}
    assert valid == set(OPERATIONS), f"no 2xx answer: {sorted(set(OPERATIONS) - valid)}"
