"""The table of operations: every capability's declarations, in one place, by name.

The HTTP routes, the OpenAPI document, the recorder, replay, ``view`` and the clients all
read this table; no other module keys on an operation's name. Importing it imports the
wire schemas (pydantic) and nothing else of ours: each operation's handler, field map and
scene drawer are named by :class:`~plotgate.service.schemas.Reference` and imported when
first used, so ``plotgate call`` and the clients start without core, FastAPI or
foxglove-sdk. Adding an operation is one declaration in its capability's module
(``docs/architecture.md``).
"""

from collections.abc import Mapping

from plotgate.service.capabilities import gates, identification, initiation, solves
from plotgate.service.schemas.endpoints import Endpoint

__all__ = ["CAPABILITIES", "ENDPOINTS", "work_caps"]

CAPABILITIES = (gates, solves, initiation, identification)
"""The capabilities' declaration modules, in the order of the OpenAPI document."""

ENDPOINTS: dict[str, Endpoint] = {
    e.name: e for capability in CAPABILITIES for e in capability.OPERATIONS
}
"""Every operation's declaration, by name (e.g. ``gates.test``)."""


def work_caps(operator: Mapping[str, Mapping[str, int]]) -> dict[str, dict[str, int]]:
    """The caps a server applies: every operation's defaults (:attr:`Endpoint.caps`) with
    the operator's (``PLOTGATE_LIMITS``) laid over them, size by size.

    An operator's cap wins whether it is lower or higher than the default: raising one
    trades the memory budget for larger requests, knowingly. Entries naming no operation
    are kept as they are, for :func:`plotgate.service.registry.check_limits` to refuse.
    """
    caps = {name: dict(e.caps) for name, e in ENDPOINTS.items() if e.caps}
    for name, sizes in operator.items():
        caps[name] = {**caps.get(name, {}), **sizes}
    return caps
