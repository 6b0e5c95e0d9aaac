"""An answer that fails its own validation is a bug (500), never bad input naming the
answer's fields (it used to be a 422 naming ``probability`` and ``error``)."""

import math

import pytest

from plotgate.service.operations.answers import checked
from plotgate.service.registry import OPERATIONS
from plotgate.service.schemas import GateProbabilityRequest, GateProbabilityResult
from plotgate.service.table import ENDPOINTS

EXAMPLES = {name: e.example for name, e in ENDPOINTS.items()}


def test_an_invalid_answer_is_a_runtime_error_not_a_validation_error():
    @checked
    def broken(request: GateProbabilityRequest) -> GateProbabilityResult:
        return GateProbabilityResult(conditional=True, probability=math.nan, error=0.0)

    request = GateProbabilityRequest.model_validate(EXAMPLES["gates.probability"])
    with pytest.raises(RuntimeError, match="broken built an invalid answer") as info:
        broken(request)
    assert "probability" in str(info.value)


@pytest.mark.parametrize("name", sorted(OPERATIONS))
def test_every_handler_is_checked(name):
    assert hasattr(OPERATIONS[name].handler, "__wrapped__"), name
