"""The pictures of passive/active identification: bearings from the radar at the origin
(degrees clockwise from north), drawn :data:`BEARING_M` long.

- ``identification.pair``: each passive (ESM) bearing magenta, each active (radar) bearing
  cyan, and the verdict; the mean active bearing green when identified, red when not;
- ``identification.picture``: each passive track's and active track's mean bearing,
  labelled ``P<i>`` and ``A<j>``, and each identified pair's mean active bearing in green,
  labelled ``P<i>=A<j>``;
- ``identification.simulate`` returns rates, not geometry: the radar labelled with the
  rate identified (and its standard error).
"""

from typing import Any

import numpy as np

from plotgate.service.scenes.draw import Canvas, as_points, colors

__all__ = ["BEARING_M", "pair", "picture", "simulate"]

BEARING_M = 50_000.0
"""Length of a bearing line, m (bearings carry no range)."""
ORIGIN = (0.0, 0.0)


def _end(bearing_deg: float, length: float = BEARING_M) -> list[float]:
    az = np.radians(bearing_deg)
    return [length * float(np.sin(az)), length * float(np.cos(az))]


def _mean_bearing(bearings_deg: list[float]) -> float:
    """The circular mean of bearings, degrees (359 and 1 average to 0, not 180)."""
    az = np.radians(np.asarray(bearings_deg, dtype=float))
    return float(np.degrees(np.arctan2(np.sin(az).mean(), np.cos(az).mean())))


def pair(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    canvas.plots(as_points(ORIGIN), colors.TRANSMITTER, size=2.0)
    canvas.bearings(ORIGIN, request["passive_bearings_deg"], BEARING_M, colors.PASSIVE)
    canvas.bearings(ORIGIN, request["active_bearings_deg"], 0.8 * BEARING_M, colors.ACTIVE)
    mean = _mean_bearing(request["active_bearings_deg"])
    verdict = colors.INSIDE if result["identified"] else colors.OUTSIDE
    canvas.bearings(ORIGIN, [mean], 1.1 * BEARING_M, verdict)
    word = "identified" if result["identified"] else "not identified"
    canvas.text(_end(mean, 1.1 * BEARING_M), f"{word} (n {result['n']}, m {result['m']})", verdict)


def picture(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    canvas.plots(as_points(ORIGIN), colors.TRANSMITTER, size=2.0)
    passive = [_mean_bearing(b) for b in request["passive_deg"]]
    active = [_mean_bearing(b) for b in request["active_deg"]]
    canvas.bearings(ORIGIN, passive, BEARING_M, colors.PASSIVE)
    canvas.bearings(ORIGIN, active, 0.8 * BEARING_M, colors.ACTIVE)
    for i, az in enumerate(passive):
        canvas.text(_end(az), f"P{i}", colors.PASSIVE)
    for j, az in enumerate(active):
        canvas.text(_end(az, 0.8 * BEARING_M), f"A{j}", colors.ACTIVE)
    for i, j in result["pairs"]:
        if 0 <= j < len(active):
            canvas.bearings(ORIGIN, [active[j]], 1.1 * BEARING_M, colors.INSIDE)
            canvas.text(_end(active[j], 1.1 * BEARING_M), f"P{i}=A{j}", colors.INSIDE)


def simulate(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    canvas.plots(as_points(ORIGIN), colors.TRANSMITTER, size=2.0)
    canvas.text(
        ORIGIN,
        f"{result['runs']} runs: identified {result['identified']:.3f} "
        f"+- {result['standard_error']:.3f}",
    )
