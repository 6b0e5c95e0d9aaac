"""Every gate kind, as one type: what gating probabilities, areas and design accept.

Each kind is a frozen dataclass of its parameters with its vectorized ``test``, its
``region`` (:class:`plotgate.core.gates.regions.StarRegion`) and ``contains``, the test
on a gating problem.
"""

from plotgate.core.gates.capture import CombinedGate, ExpandedGate, RingGate
from plotgate.core.gates.polar import FirstAssociationGate, SectorGate
from plotgate.core.gates.tracking import EllipseGate, RectangularGate

__all__ = ["Gate"]

Gate = (
    RingGate
    | CombinedGate
    | ExpandedGate
    | EllipseGate
    | RectangularGate
    | SectorGate
    | FirstAssociationGate
)
"""Any gate kind."""
