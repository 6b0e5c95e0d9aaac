"""The pictures of the gate operations: plots colored by the gate's verdict, and the gate.

A gate is drawn about its first mark z1 as the region a second mark must fall in:

- ``ring``, ``combined``: two circles, radii ``v_min tau`` and ``v_max tau`` (the combined
  gate's first stage; its second, an ellipse per candidate, is in the verdict's color);
- ``expanded``, ``first_association``: a circle of radius ``v_max tau``;
- ``ellipse``: the ellipse ``nu^T S^-1 nu = threshold`` with ``S = 2 P1``, as if every
  candidate were measured as z1 is (each candidate's own ``S`` differs; the verdict's color
  is exact, the outline a guide);
- ``rectangular``: ``z1 +- k sqrt(2 P1_ii)`` along x and y, likewise;
- ``sector``: for a polar z1, its sensor's sector ``r1 +- K_R sqrt(2) sigma_r``,
  ``az1 +- K_az sqrt(2) sigma_az``; for a Cartesian z1, the ellipse of ``K_R`` sigmas.

The probability operations (probability, its curve, analysis, design) draw their mark,
its 1-sigma error ellipse and the region of the gate about it, labelled with the figure
they computed.
"""

import math
from typing import Any

import numpy as np

from plotgate.service.scenes.draw import MAX_MARKS, Canvas, colors
from plotgate.service.scenes.geometry import mark_position, plot_position, plot_positions

__all__ = ["analysis", "curve", "design", "pairs", "probability", "test"]

MAX_GATES = 50
"""Gate outlines drawn by one ``gates.pairs`` exchange (one per pair): more hide the plots."""


def _outline(canvas: Canvas, gate: dict[str, Any], first: dict[str, Any], threshold: Any) -> None:
    """The region of ``gate`` about the mark ``first`` (this module's docstring)."""
    kind, tau = gate.get("kind"), gate.get("tau")
    centre, cov = plot_position(first)
    if kind in ("ring", "combined", "expanded", "first_association") and tau is not None:
        canvas.circle(centre, float(gate["v_max"]) * float(tau), colors.GATE)
        if kind in ("ring", "combined"):
            canvas.circle(centre, float(gate.get("v_min", 0.0)) * float(tau), colors.GATE)
    elif kind == "ellipse" and threshold is not None:
        canvas.ellipse(centre, 2 * cov, colors.GATE, math.sqrt(float(threshold)))
    elif kind == "rectangular":
        k = float(gate.get("k", 3.0))
        half = k * np.sqrt(2 * np.diag(cov))
        corners = centre + half * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
        canvas.line(corners, colors.GATE, closed=True)
    elif kind == "sector" and first.get("frame") == "polar":
        dr = float(gate.get("K_R", 3.0)) * math.sqrt(2) * float(first["sigma_r"])
        daz = float(gate.get("K_az", 3.0)) * math.sqrt(2) * float(first["sigma_az_deg"])
        r, az = float(first["r"]), float(first["az_deg"])
        sensor = first.get("sensor") or (0.0, 0.0)
        canvas.sector(sensor, (max(r - dr, 0.0), r + dr), (az - daz, az + daz), colors.GATE)
    elif kind == "sector":
        canvas.ellipse(centre, 2 * cov, colors.GATE, float(gate.get("K_R", 3.0)))


def _flags(n: int, values: list[bool]) -> np.ndarray:
    """``values`` as ``n`` booleans, False where the list is short."""
    flags = np.zeros(n, dtype=bool)
    m = min(n, len(values))
    flags[:m] = np.asarray(values[:m], dtype=bool)
    return flags


def _verdicts(canvas: Canvas, positions: np.ndarray, inside: list[bool]) -> None:
    """Plots green inside the gate, red outside."""
    verdict = _flags(len(positions), inside)
    canvas.plots(positions[verdict], colors.INSIDE)
    canvas.plots(positions[~verdict], colors.OUTSIDE)


def test(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    first = request["first"]
    _outline(canvas, request["gate"], first, result.get("threshold"))
    canvas.plots(plot_position(first)[0], colors.MARK, size=1.5)
    candidates = plot_positions(request["candidates"][:MAX_MARKS])
    canvas.left_out += max(0, len(request["candidates"]) - MAX_MARKS)
    _verdicts(canvas, candidates, result["inside"])
    label = f"{result['kind']} gate: {result['count_inside']} of {len(request['candidates'])} in"
    canvas.text(plot_position(first)[0], label)


def pairs(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    pairs = request["pairs"][:MAX_MARKS]
    canvas.left_out += max(0, len(request["pairs"]) - MAX_MARKS)
    for pair in pairs[:MAX_GATES]:
        _outline(canvas, request["gate"], pair["first"], result.get("threshold"))
    firsts = plot_positions([p["first"] for p in pairs])
    seconds = plot_positions([p["second"] for p in pairs])
    inside = _flags(len(pairs), result["inside"])
    canvas.plots(firsts, colors.MARK)
    canvas.segments(firsts[inside], seconds[inside], colors.INSIDE)
    canvas.segments(firsts[~inside], seconds[~inside], colors.OUTSIDE)
    _verdicts(canvas, seconds, result["inside"])
    if len(firsts):
        canvas.text(firsts[0], f"{result['count_inside']} of {len(request['pairs'])} pairs in")


def _mark(canvas: Canvas, request: dict[str, Any], label: str) -> None:
    """A probability request's mark, its error ellipse, its gate's region, and ``label``."""
    centre, cov = mark_position(request["mark"])
    gate = dict(request["gate"], tau=request.get("tau"))
    first = dict(request["mark"], frame="polar")
    _outline(canvas, gate, first, None)
    canvas.plots(centre, colors.MARK, size=1.5)
    canvas.ellipse(centre, cov, colors.COVARIANCE)
    canvas.text(centre, label)


def probability(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    kind = "P(in gate | in region)" if result.get("conditional") else "P(in gate)"
    _mark(canvas, request, f"{kind} = {result['probability']:.4f}")


def curve(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    p = result["probability"]
    label = f"P against {result['against']}: {min(p):.4f} to {max(p):.4f}" if p else "no points"
    _mark(canvas, request, label)


def analysis(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    label = (
        f"area {result['area'] / 1e6:.3g} km^2, {result['cells']:.3g} cells, "
        f"false marks {result['false_marks']['mean']:.3g}"
    )
    _mark(canvas, request, label)


def design(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    label = f"{result['parameter']} = {result['value']:.4g}, capture {result['capture']:.3f}"
    _mark(canvas, request, label)
