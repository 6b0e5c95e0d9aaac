"""Wire models shared by the service and its clients; imports pydantic only."""

from service.schemas.common import (
    MAX_DISTANCE,
    MAX_PLOTS,
    MIN_RANGE,
    CartesianPlot,
    FieldError,
    Plot,
    PolarPlot,
    Position,
    Problem,
    Schema,
)
from service.schemas.endpoints import ENDPOINTS, Endpoint
from service.schemas.gates import (
    CombinedGate,
    EllipseGate,
    ExpandedGate,
    FirstAssociationGate,
    Gate,
    GatePair,
    GatePairsRequest,
    GateResults,
    GateTestRequest,
    RectangularGate,
    RingGate,
    SectorGate,
)
from service.schemas.records import RequestRecord, ResponseRecord

__all__ = [
    "ENDPOINTS",
    "MAX_DISTANCE",
    "MAX_PLOTS",
    "MIN_RANGE",
    "CartesianPlot",
    "CombinedGate",
    "EllipseGate",
    "Endpoint",
    "ExpandedGate",
    "FieldError",
    "FirstAssociationGate",
    "Gate",
    "GatePair",
    "GatePairsRequest",
    "GateResults",
    "GateTestRequest",
    "Plot",
    "PolarPlot",
    "Position",
    "Problem",
    "RectangularGate",
    "RequestRecord",
    "ResponseRecord",
    "RingGate",
    "Schema",
    "SectorGate",
]
