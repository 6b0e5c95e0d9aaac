"""The pictures of many ``gates.test`` exchanges at once, for ``plotgate view``: the same
bytes as :meth:`plotgate.service.scenes.Encoded.exchange` draws one at a time.

Drawn one at a time, an exchange of 100 candidates costs its values built as dicts (a
dict per plot), then a few dozen small numpy calls (its ellipse, crosses and points):
about ten times the time to read it. Here the records are parsed by msgspec straight into
Structs of the fields the picture uses (the candidates' covariances are skipped unparsed),
and the exchanges of a batch are drawn together: their gates' ``eigh`` in one call, every
cross of the batch in one array, every point encoded in one pass
(:func:`~plotgate.service.scenes.wire.point_fields`), then each exchange's message
assembled from its slices.

Only the common form is drawn here: a ``gates.test`` exchange answered (status < 400) with
its body, plots tagged ``cartesian`` or ``polar`` with finite positions, a cartesian first
mark with a 2x2 covariance, fewer candidates than the canvas's cap, and a gate drawn as
circles (``ring``, ``combined``, ``expanded``, ``first_association``) or an ellipse. Anything
else (another operation, a failed exchange, a record msgspec's Structs do not take, a
sector or rectangular gate, a value that is not finite) is :func:`fast` answering None,
and the caller draws it the usual way, one at a time: the picture of an unusual record is
never guessed. ``tests/service/scenes/test_batched.py`` holds the two to the same bytes.
"""

import math

import msgspec
import numpy as np

from plotgate.service.scenes.draw import (
    CROSS_FRACTION,
    FRAME,
    LINE_LIST,
    LINE_LOOP,
    LINE_PX,
    MAX_MARKS,
    MIN_EXTENT,
    TEXT_PX,
    UNIT_CIRCLE,
    colors,
)
from plotgate.service.scenes.wire import Line, point_fields, scene_update, split_points

__all__ = ["BATCH", "Plan", "draw_tests", "plan"]

BATCH = 64
"""Exchanges drawn together: enough to spread numpy's per-call cost, few enough to keep
the records of a batch small in memory."""

_CIRCLES = ("ring", "combined", "expanded", "first_association")


class _Cartesian(msgspec.Struct, tag_field="frame", tag="cartesian"):
    x: float
    y: float


class _Polar(msgspec.Struct, tag_field="frame", tag="polar"):
    r: float
    az_deg: float
    sensor: tuple[float, float] | None = None


class _First(msgspec.Struct, tag_field="frame", tag="cartesian"):
    x: float
    y: float
    covariance: tuple[tuple[float, float], tuple[float, float]]


class _Gate(msgspec.Struct):
    kind: str | None = None
    tau: float | None = None
    v_max: float | None = None
    v_min: float = 0.0


class _Body(msgspec.Struct):
    gate: _Gate
    first: _First
    candidates: list[_Cartesian | _Polar]


class _Request(msgspec.Struct):
    request_id: str
    body: _Body


class _Result(msgspec.Struct):
    kind: str
    count_inside: int
    inside: list[bool]
    threshold: float | None = None


class _Response(msgspec.Struct):
    status: int
    result: _Result


_REQUEST = msgspec.json.Decoder(_Request)
_RESPONSE = msgspec.json.Decoder(_Response)


class Plan(msgspec.Struct):
    """One exchange's picture before drawing: what :func:`draw_tests` needs."""

    request_id: str
    status: int
    log_time: int
    centre: tuple[float, float]
    outlines: list[tuple[np.ndarray, float]]
    """Each outline's covariance (2x2) and its number of sigmas."""
    candidates: np.ndarray
    inside: np.ndarray
    label: str


def _polar_xy(plot: _Polar) -> tuple[float, float]:
    """:func:`plotgate.service.scenes.geometry.plot_positions`'s polar position."""
    r, az = plot.r, math.radians(plot.az_deg)
    x0, y0 = plot.sensor or (0.0, 0.0)
    return x0 + r * math.sin(az), y0 + r * math.cos(az)


def plan(request: bytes, response: bytes, log_time: int) -> Plan | None:
    """The picture of a ``gates.test`` exchange of the common form (this module's
    docstring), None for anything else."""
    try:
        req, res = _REQUEST.decode(request), _RESPONSE.decode(response)
    except (msgspec.ValidationError, msgspec.DecodeError):
        return None
    body, result, gate = req.body, res.result, req.body.gate
    first = body.first
    if res.status >= 400 or len(body.candidates) >= MAX_MARKS:
        return None
    cov = np.array(first.covariance, dtype=float)
    if not (np.isfinite(cov).all() and math.isfinite(first.x) and math.isfinite(first.y)):
        return None
    outlines: list[tuple[np.ndarray, float]] = []
    if gate.kind in _CIRCLES and gate.tau is not None:
        if gate.v_max is None:
            return None
        for speed in (gate.v_max, gate.v_min)[: 2 if gate.kind in ("ring", "combined") else 1]:
            radius = speed * gate.tau
            if np.isfinite(radius) and radius > 0:
                outlines.append((np.eye(2) * radius**2, 1.0))
    elif gate.kind == "ellipse" and result.threshold is not None:
        if result.threshold < 0:
            return None
        outlines.append((2 * cov, math.sqrt(result.threshold)))
    elif gate.kind in ("rectangular", "sector"):
        return None
    candidates = np.array(
        [(c.x, c.y) if type(c) is _Cartesian else _polar_xy(c) for c in body.candidates],
        dtype=float,
    ).reshape(-1, 2)
    if not np.isfinite(candidates).all():
        return None
    inside = np.zeros(len(candidates), dtype=bool)
    m = min(len(candidates), len(result.inside))
    inside[:m] = result.inside[:m]
    label = f"{result.kind} gate: {result.count_inside} of {len(body.candidates)} in"
    return Plan(
        req.request_id,
        res.status,
        log_time,
        (first.x, first.y),
        outlines,
        candidates,
        inside,
        label,
    )


def _ellipses(plans: list[Plan]) -> list[list[np.ndarray]]:
    """Each plan's outlines as points (:meth:`~plotgate.service.scenes.draw.Canvas.ellipse`),
    every ``eigh`` of the batch in one call; an outline it would not draw is left out."""
    covs = [cov for p in plans for cov, _ in p.outlines]
    if not covs:
        return [[] for _ in plans]
    values, vectors = np.linalg.eigh(np.array(covs))
    roots = np.sqrt(np.maximum(values, 0.0))
    out: list[list[np.ndarray]] = []
    i = 0
    for p in plans:
        drawn = []
        for _, k in p.outlines:
            if values[i].min() >= 0 and np.isfinite(k):
                xy = np.asarray(p.centre) + k * (UNIT_CIRCLE * roots[i]) @ vectors[i].T
                drawn.append(xy[np.isfinite(xy).all(axis=1)])
            i += 1
        out.append([xy for xy in drawn if len(xy) >= 2])
    return out


def draw_tests(plans: list[Plan], entity_id: str, operation: str) -> list[bytes]:
    """The ``SceneUpdate`` bytes of each plan (one entity ``entity_id``), the same as the
    canvas's (:func:`plotgate.service.scenes.gates.test` then
    :meth:`~plotgate.service.scenes.draw.Canvas.encoded`)."""
    outlines = _ellipses(plans)
    marks, arms, groups = [], [], []
    for p, lines in zip(plans, outlines, strict=True):
        centre = np.asarray([p.centre])
        extent = max(
            float(np.ptp(np.concatenate([*lines, p.candidates, centre]), axis=0).max()), MIN_EXTENT
        )
        arm = CROSS_FRACTION * extent
        kept = [
            (xy, color, size)
            for xy, color, size in (
                (centre, colors.MARK, arm * 1.5),
                (p.candidates[p.inside], colors.INSIDE, arm),
                (p.candidates[~p.inside], colors.OUTSIDE, arm),
            )
            if len(xy)
        ]
        groups.append([(len(xy), color) for xy, color, _ in kept])
        marks += [xy for xy, _, _ in kept]
        arms += [np.full(len(xy), size) for xy, _, size in kept]
    crosses = _crosses(np.concatenate(marks), np.concatenate(arms))
    pieces: list[np.ndarray] = []
    plan_lines: list[list[Line]] = []
    at = 0
    for lines, kept_groups in zip(outlines, groups, strict=True):
        drawn: list[Line] = [(LINE_LOOP, xy, colors.GATE) for xy in lines]
        for n, color in kept_groups:
            drawn.append((LINE_LIST, crosses[at : at + 4 * n], color))
            at += 4 * n
        pieces += [xy for _, xy, _ in drawn]
        plan_lines.append(drawn)
    coords = np.zeros((sum(len(xy) for xy in pieces), 3), dtype="<f8")
    coords[:, :2] = np.concatenate(pieces)
    points = split_points(*point_fields(coords), [len(xy) for xy in pieces])
    out, first = [], 0
    for p, drawn in zip(plans, plan_lines, strict=True):
        metadata = {"request_id": p.request_id, "status": str(p.status), "operation": operation}
        text = (p.centre[0], p.centre[1], p.label[:200], colors.TEXT)
        out.append(
            scene_update(
                FRAME,
                entity_id,
                p.log_time,
                metadata,
                drawn,
                [text],
                LINE_PX,
                TEXT_PX,
                points[first : first + len(drawn)],
            )
        )
        first += len(drawn)
    return out


def _crosses(xy: np.ndarray, arms: np.ndarray) -> np.ndarray:
    """:func:`plotgate.service.scenes.draw._crosses` of many marks, each its own arm."""
    out = np.repeat(xy, 4, axis=0)
    arm = np.repeat(arms, 4)
    out[0::4, 0] -= arm[0::4]
    out[1::4, 0] += arm[1::4]
    out[2::4, 1] -= arm[2::4]
    out[3::4, 1] += arm[3::4]
    return out
