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
its body, plots tagged ``cartesian`` or ``polar`` with finite positions (a cartesian first
mark with a 2x2 covariance, a polar one with its sigmas), fewer candidates than the
canvas's cap, and a gate drawn as circles (``ring``, ``combined``, ``expanded``,
``first_association``) or an ellipse. Anything else (another operation, a failed exchange,
a record msgspec's Structs do not take, a sector or rectangular gate, a value that is not
finite) is :func:`plan` answering None, and the caller draws it the usual way, one at a
time: the picture of an unusual record is never guessed.
``tests/service/scenes/test_batched.py`` holds the two to the same bytes.
"""

import itertools
import math
import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

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
from plotgate.service.scenes.geometry import mark_position
from plotgate.service.scenes.wire import Color, Line, point_fields, scene_update, split_points

__all__ = ["BATCH", "TESTS", "BatchDrawer", "Plan", "draw_tests", "plan"]

BATCH = 64
"""Exchanges drawn together: enough to spread numpy's per-call cost, few enough to keep
the records of a batch small in memory."""

_CIRCLES = ("ring", "combined", "expanded", "first_association")


class _Cartesian(msgspec.Struct, gc=False, tag_field="frame", tag="cartesian"):
    x: float
    y: float


class _Polar(msgspec.Struct, gc=False, tag_field="frame", tag="polar"):
    r: float
    az_deg: float
    sensor: tuple[float, float] | None = None


class _FirstCartesian(msgspec.Struct, gc=False, tag_field="frame", tag="cartesian"):
    x: float
    y: float
    covariance: tuple[tuple[float, float], tuple[float, float]]


class _FirstPolar(msgspec.Struct, gc=False, tag_field="frame", tag="polar"):
    r: float
    az_deg: float
    sigma_r: float
    sigma_az_deg: float
    sensor: tuple[float, float] | None = None


class _Gate(msgspec.Struct, gc=False):
    kind: str | None = None
    tau: float | None = None
    v_max: float | None = None
    v_min: float = 0.0


class _Body(msgspec.Struct, gc=False):
    gate: _Gate
    first: _FirstCartesian | _FirstPolar
    candidates: list[_Cartesian | _Polar]


class _Request(msgspec.Struct, gc=False):
    request_id: str
    body: _Body


class _Result(msgspec.Struct, gc=False):
    kind: str
    count_inside: int
    inside: list[bool]
    threshold: float | None = None


class _Response(msgspec.Struct, gc=False):
    status: int
    result: _Result


_REQUEST = msgspec.json.Decoder(_Request)
_RESPONSE = msgspec.json.Decoder(_Response)


class Plan(msgspec.Struct, gc=False):
    """One exchange's picture before drawing: what :func:`draw_tests` needs."""

    request_id: str
    status: int
    log_time: int
    centre: tuple[float, float]
    outlines: list[tuple[Any, float, float]]
    """Each outline's covariance (2x2: the first mark's, or a circle's ``radius^2 I``), its
    number of sigmas, and the factor on the covariance (2 for an ellipse gate's
    ``S = 2 P1``)."""
    xs: list[float]
    ys: list[float]
    """The candidates' positions."""
    inside: list[bool]
    """Each candidate's verdict (False where the answer's list is short)."""
    label: str


_X, _Y = operator.attrgetter("x"), operator.attrgetter("y")


def _polar_xy(plot: _Polar) -> tuple[float, float]:
    """:func:`plotgate.service.scenes.geometry.plot_positions`'s polar position."""
    r, az = plot.r, math.radians(plot.az_deg)
    x0, y0 = plot.sensor or (0.0, 0.0)
    return x0 + r * math.sin(az), y0 + r * math.cos(az)


def _positions(candidates: list[Any]) -> tuple[list[float], list[float]] | None:
    """The candidates' x and y (msgspec's floats are finite: JSON has no infinity), None
    when a polar one's is not finite."""
    try:
        return list(map(_X, candidates)), list(map(_Y, candidates))
    except AttributeError:  # a polar plot among them
        xy = [_polar_xy(c) if isinstance(c, _Polar) else (c.x, c.y) for c in candidates]
        xs, ys = [x for x, _ in xy], [y for _, y in xy]
        finite = all(map(math.isfinite, xs)) and all(map(math.isfinite, ys))
        return (xs, ys) if finite else None


def plan(request: bytes, response: bytes, log_time: int) -> Plan | None:
    """The picture of a ``gates.test`` exchange of the common form (this module's
    docstring), None for anything else."""
    try:
        req, res = _REQUEST.decode(request), _RESPONSE.decode(response)
    except (msgspec.ValidationError, msgspec.DecodeError):
        return None
    body, result, gate = req.body, res.result, req.body.gate
    first, n = body.first, len(body.candidates)
    if res.status >= 400 or n >= MAX_MARKS:
        return None
    cov: Any
    if isinstance(first, _FirstCartesian):
        centre, cov = (first.x, first.y), first.covariance
    else:
        at, cov = mark_position(msgspec.structs.asdict(first))
        centre = (float(at[0]), float(at[1]))
        if not (np.isfinite(cov).all() and np.isfinite(at).all()):
            return None
    outlines: list[tuple[Any, float, float]] = []
    if gate.kind in _CIRCLES and gate.tau is not None:
        if gate.v_max is None:
            return None
        for speed in (gate.v_max, gate.v_min)[: 2 if gate.kind in ("ring", "combined") else 1]:
            radius = speed * gate.tau
            if math.isfinite(radius) and radius > 0:
                if radius > _LARGEST_RADIUS:  # its square overflows: the canvas cannot draw
                    return None
                square = radius**2
                outlines.append((((square, 0.0), (0.0, square)), 1.0, 1.0))
    elif gate.kind == "ellipse" and result.threshold is not None:
        if result.threshold < 0:
            return None
        outlines.append((cov, math.sqrt(result.threshold), 2.0))
    elif gate.kind in ("rectangular", "sector"):
        return None
    positions = _positions(body.candidates)
    if positions is None:
        return None
    inside = result.inside[:n]
    if len(inside) < n:
        inside += [False] * (n - len(inside))
    label = f"{result.kind} gate: {result.count_inside} of {n} in"
    return Plan(req.request_id, res.status, log_time, centre, outlines, *positions, inside, label)


_LARGEST_RADIUS = 1e154
"""Below the square root of the largest double: a circle's ``radius**2`` is finite."""


def _ellipses(plans: list[Plan]) -> list[list[np.ndarray]]:
    """Each plan's outlines as points (:meth:`~plotgate.service.scenes.draw.Canvas.ellipse`
    then :meth:`~plotgate.service.scenes.draw.Canvas.line`), every ``eigh`` of the batch in
    one call; an outline the canvas would not draw is left out."""
    outlines = [outline for p in plans for outline in p.outlines]
    if not outlines:
        return [[] for _ in plans]
    covs = np.array([cov for cov, _, _ in outlines], dtype=float).reshape(-1, 2, 2)
    covs *= np.array([factor for _, _, factor in outlines])[:, None, None]
    finite = np.isfinite(covs).all(axis=(1, 2))
    covs[~finite] = np.eye(2)  # not drawn (the canvas's check), kept out of eigh
    values, vectors = np.linalg.eigh(covs)
    ks = np.array([k for _, k, _ in outlines], dtype=float)
    drawable = (finite & (values.min(axis=1) >= 0) & np.isfinite(ks)).tolist()
    centres = np.array([p.centre for p in plans for _ in p.outlines], dtype=float)
    scaled = ks[:, None, None] * (UNIT_CIRCLE * np.sqrt(np.maximum(values, 0.0))[:, None, :])
    rims = centres[:, None, :] + scaled @ vectors.transpose(0, 2, 1)
    whole = np.isfinite(rims).all(axis=(1, 2)).tolist()
    out: list[list[np.ndarray]] = []
    i = 0
    for p in plans:
        lines = []
        for j in range(i, i + len(p.outlines)):
            xy = rims[j] if whole[j] else rims[j][np.isfinite(rims[j]).all(axis=1)]
            if drawable[j] and len(xy) >= 2:
                lines.append(xy)
        out.append(lines)
        i += len(p.outlines)
    return out


def _groups(values: np.ndarray, counts: np.ndarray, empty: float, reduce: Any) -> np.ndarray:
    """``reduce`` (``np.minimum`` or ``np.maximum``) over each of the consecutive groups of
    ``counts`` rows of ``values``; ``empty`` for a group of none."""
    out = np.full((len(counts), values.shape[1]), empty)
    if len(values):
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        some = counts > 0
        out[some] = reduce.reduceat(values, starts[some], axis=0)
    return out


def draw_tests(plans: list[Plan], entity_id: str, operation: str) -> list[bytes]:
    """The ``SceneUpdate`` bytes of each plan (one entity ``entity_id``), the same as the
    canvas's (:func:`plotgate.service.scenes.gates.test` then
    :meth:`~plotgate.service.scenes.draw.Canvas.encoded`)."""
    outlines = _ellipses(plans)
    n = len(plans)
    centres = np.array([p.centre for p in plans], dtype=float)
    counts = np.array([len(p.xs) for p in plans])
    candidates = np.empty((int(counts.sum()), 2))
    candidates[:, 0] = list(itertools.chain.from_iterable(p.xs for p in plans))
    candidates[:, 1] = list(itertools.chain.from_iterable(p.ys for p in plans))
    inside = np.array(list(itertools.chain.from_iterable(p.inside for p in plans)), dtype=bool)
    # the picture's extent: the span of its outlines, candidates and first mark (the label
    # is at the mark)
    rims = [xy for lines in outlines for xy in lines]
    rim = np.concatenate(rims) if rims else np.zeros((0, 2))
    rim_counts = np.array([sum(len(xy) for xy in lines) for lines in outlines])
    low = np.minimum(
        np.minimum(_groups(candidates, counts, np.inf, np.minimum), centres),
        _groups(rim, rim_counts, np.inf, np.minimum),
    )
    high = np.maximum(
        np.maximum(_groups(candidates, counts, -np.inf, np.maximum), centres),
        _groups(rim, rim_counts, -np.inf, np.maximum),
    )
    arm = CROSS_FRACTION * np.maximum((high - low).max(axis=1), MIN_EXTENT)
    # the crosses, plan by plan: its first mark, its candidates inside, then outside
    owner = np.repeat(np.arange(n), counts)
    keys = np.concatenate([3 * np.arange(n), 3 * owner + 2 - inside.astype(int)])
    order = np.argsort(keys, kind="stable")
    marks = np.concatenate([centres, candidates])[order]
    arms = np.concatenate([arm * 1.5, arm[owner]])[order]
    crosses = _crosses(marks, arms)
    per_group = np.bincount(keys, minlength=3 * n).reshape(n, 3).tolist()
    at = 0
    pieces: list[np.ndarray] = []
    line_sizes: list[int] = []
    kinds: list[list[tuple[int, Color]]] = []
    for i, lines in enumerate(outlines):
        pieces += lines
        marked = 4 * sum(per_group[i])
        pieces.append(crosses[at : at + marked])
        at += marked
        plan_kinds = [(LINE_LOOP, colors.GATE)] * len(lines)
        line_sizes += [len(xy) for xy in lines]
        for count, color in zip(per_group[i], _MARK_COLORS, strict=True):
            if count:
                plan_kinds.append((LINE_LIST, color))
                line_sizes.append(4 * count)
        kinds.append(plan_kinds)
    coords = np.zeros((sum(line_sizes), 3), dtype="<f8")
    coords[:, :2] = np.concatenate(pieces)
    points = split_points(*point_fields(coords), line_sizes)
    out, first = [], 0
    for p, plan_kinds in zip(plans, kinds, strict=True):
        metadata = {"request_id": p.request_id, "status": str(p.status), "operation": operation}
        text = (p.centre[0], p.centre[1], p.label[:200], colors.TEXT)
        drawn: list[Line] = [(kind, _NO_POINTS, color) for kind, color in plan_kinds]
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


_MARK_COLORS = (colors.MARK, colors.INSIDE, colors.OUTSIDE)
_NO_POINTS = np.zeros((0, 2))
"""A line's points once they are encoded (:func:`scene_update` is handed their bytes)."""


def _crosses(xy: np.ndarray, arms: np.ndarray) -> np.ndarray:
    """:func:`plotgate.service.scenes.draw._crosses` of many marks, each its own arm."""
    out = np.repeat(xy, 4, axis=0)
    arm = np.repeat(arms, 4)
    out[0::4, 0] -= arm[0::4]
    out[1::4, 0] += arm[1::4]
    out[2::4, 1] -= arm[2::4]
    out[3::4, 1] += arm[3::4]
    return out


@dataclass(frozen=True)
class BatchDrawer:
    """How ``view`` draws many exchanges of one operation at once (an operation's
    declaration names one, :attr:`plotgate.service.schemas.Endpoint.batch_drawer`)."""

    plan: Callable[[bytes, bytes, int], Plan | None]
    """An exchange's request and response bytes and log time -> its picture before
    drawing, None for a form the batch does not draw (the caller draws that one alone)."""
    draw: Callable[[list[Plan], str, str], list[bytes]]
    """The plans, the entity id and the operation -> each plan's ``SceneUpdate`` bytes."""


TESTS = BatchDrawer(plan, draw_tests)
"""The ``gates.test`` exchanges' batch drawing."""
