"""The docs' tables say every default the wire schemas apply (issue 37: a combined gate
without ``P_G`` used 0.9 unsaid)."""

import re
import typing
from pathlib import Path

import pytest

from plotgate.service.schemas import gates

ROOT = Path(__file__).resolve().parents[2]
GATES = {
    typing.get_args(model.model_fields["kind"].annotation)[0]: model
    for model in (
        gates.RingGate,
        gates.ExpandedGate,
        gates.CombinedGate,
        gates.EllipseGate,
        gates.RectangularGate,
        gates.SectorGate,
        gates.FirstAssociationGate,
    )
}


def _rows(page: Path) -> dict[str, str]:
    """The gates table's parameter cell of each kind."""
    rows = re.findall(r"^\| `(\w+)` \| ([^|]*) \|", page.read_text(), re.M)
    return {kind: cell for kind, cell in rows if kind in GATES}


@pytest.mark.parametrize("kind", sorted(GATES))
def test_the_gates_table_gives_every_default(kind):
    cell = _rows(ROOT / "docs/gates.md")[kind]
    for name, field in GATES[kind].model_fields.items():
        if name == "kind":
            continue
        if field.is_required():
            assert f"`{name}`" in cell, (kind, name)
        else:
            assert f"`{name}` (default {field.default:g})" in cell, (kind, name, cell)
