"""The wire's gates as core's gates: one conversion for every operation that takes a gate.

A wire gate (:data:`plotgate.service.schemas.gates.GateParameters`: the gate tests'
``Gate`` or the probabilities' ``GateRegion``) is chosen by ``kind`` and names its
parameters as core does (``v_min``, ``P_G``, ``K_R``, ``offset`` ...); it becomes the core
dataclass of that kind (:mod:`plotgate.core.gates`) with those fields. A gate test's
``tau`` is the interval between its marks, an argument of core's ``test``, not a field.
"""

import dataclasses
import functools

from plotgate import core
from plotgate.service.schemas.gates import GateParameters

__all__ = ["KINDS", "core_gate"]

KINDS: dict[str, type[core.Gate]] = {
    "ring": core.RingGate,
    "expanded": core.ExpandedGate,
    "combined": core.CombinedGate,
    "ellipse": core.EllipseGate,
    "rectangular": core.RectangularGate,
    "sector": core.SectorGate,
    "first_association": core.FirstAssociationGate,
}
"""Wire discriminator ``kind`` -> core gate kind."""


def core_gate(gate: GateParameters) -> core.Gate:
    """The core gate of a wire gate: its kind, with the fields both of them have."""
    fields = _shared_fields(type(gate), gate.kind)
    return KINDS[gate.kind](**{name: getattr(gate, name) for name in fields})


@functools.cache
def _shared_fields(wire: type[GateParameters], kind: str) -> tuple[str, ...]:
    """The fields of core's gate ``kind`` that the wire model also has (once per wire model
    and kind: this runs on every gate request)."""
    sent = wire.model_fields
    return tuple(f.name for f in dataclasses.fields(KINDS[kind]) if f.name in sent)
