"""The wire contract of every operation: name, path, request and response models.

Clients read this table to call the service without importing it; the registry
(:mod:`service.registry`) binds each endpoint to its handler.
"""

from dataclasses import dataclass

from pydantic import BaseModel

from service.schemas.gates import GatePairsRequest, GateResults, GateTestRequest

__all__ = ["ENDPOINTS", "Endpoint"]


@dataclass(frozen=True)
class Endpoint:
    """One operation as seen from the wire."""

    name: str
    path: str
    summary: str
    request: type[BaseModel]
    response: type[BaseModel]

    @property
    def tag(self) -> str:
        return self.name.split(".")[0]


ENDPOINTS: dict[str, Endpoint] = {
    e.name: e
    for e in (
        Endpoint(
            "gates.test", "/v1/gates/test", "Test one first plot against many candidate plots",
            GateTestRequest, GateResults,
        ),
        Endpoint(
            "gates.pairs", "/v1/gates/pairs", "Test many independent (first, second) plot pairs",
            GatePairsRequest, GateResults,
        ),
    )
}
