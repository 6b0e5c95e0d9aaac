"""A canvas that collects an exchange's geometry and becomes one Foxglove scene entity.

Everything is drawn in the radar frame (:data:`FRAME`): x east, y north, metres, z = 0 for
2D operations (the project's frame, DESIGN section 2), with foxglove-sdk's schema classes.
Lines are a fixed width on screen (scale invariant), so a 50 km picture and a 50 m one both
read. A plot is a cross whose arm is :data:`CROSS_FRACTION` of the picture's extent: a
point primitive does not exist in ``foxglove.SceneEntity``, and a sphere of fixed metres
vanishes when zoomed out. Labels are screen-sized text facing the camera.

The canvas caps what one exchange may draw (:data:`MAX_MARKS` crosses, :data:`MAX_LINES`
line primitives, :data:`MAX_POINTS` points in all): a recorded body can hold 100,000 pairs,
and the scene of one exchange must stay bounded in memory and time. What is left out is
counted (:attr:`Canvas.left_out`) and said in the exchange's Log message.
"""

from dataclasses import dataclass, field
from typing import Any

import foxglove.messages as fm
import numpy as np

from plotgate.service.scenes.wire import Color, Line, Text, scene_update

__all__ = [
    "CROSS_FRACTION",
    "FRAME",
    "MAX_LINES",
    "MAX_MARKS",
    "MAX_POINTS",
    "Canvas",
    "Color",
    "colors",
    "timestamp",
]

FRAME = "radar"
CROSS_FRACTION = 0.006
MAX_MARKS = 10_000
MAX_LINES = 2_000
MAX_POINTS = 200_000
ELLIPSE_SEGMENTS = 48
LINE_PX = 1.5
TEXT_PX = 14.0
MIN_EXTENT = 500.0

_ANGLES = np.linspace(0.0, 2 * np.pi, ELLIPSE_SEGMENTS, endpoint=False)
UNIT_CIRCLE = np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=1)
"""An ellipse's points on the unit circle, computed once (every gate draws one)."""

LINE_STRIP, LINE_LOOP, LINE_LIST = 0, 1, 2
"""Foxglove's ``LinePrimitive.Type`` numbers."""
_LINE_TYPES = {
    LINE_STRIP: fm.LinePrimitiveLineType.LineStrip,
    LINE_LOOP: fm.LinePrimitiveLineType.LineLoop,
    LINE_LIST: fm.LinePrimitiveLineType.LineList,
}


class colors:  # noqa: N801 - a namespace of constants, read as colors.INSIDE
    """The palette (RGBA, 0..1), one meaning per color across every operation."""

    INSIDE: Color = (0.2, 0.85, 0.3, 1.0)
    """A plot inside the gate; a confirmed track; an identified pair."""
    OUTSIDE: Color = (0.95, 0.25, 0.2, 1.0)
    """A plot outside the gate; a failed or unsolvable item."""
    MARK: Color = (1.0, 1.0, 1.0, 1.0)
    """The gate's first mark (its centre), a probability's mark, the truth."""
    GATE: Color = (1.0, 0.75, 0.0, 1.0)
    """A gate's outline; a tentative track."""
    COVARIANCE: Color = (1.0, 0.95, 0.4, 0.8)
    """A covariance or CRLB ellipse (1 sigma)."""
    SOLUTION: Color = (1.0, 1.0, 0.2, 1.0)
    """A solved position."""
    TRANSMITTER: Color = (0.35, 0.55, 1.0, 1.0)
    RECEIVER: Color = (0.0, 0.9, 0.9, 1.0)
    CLUTTER: Color = (0.6, 0.6, 0.6, 1.0)
    """A plot of no track (clutter, unassociated)."""
    PASSIVE: Color = (0.9, 0.35, 0.9, 1.0)
    """A passive (ESM) bearing."""
    ACTIVE: Color = (0.0, 0.9, 0.9, 1.0)
    """An active (radar) bearing."""
    TEXT: Color = (0.9, 0.9, 0.9, 1.0)


def timestamp(log_time: int) -> fm.Timestamp:
    """A recording's time (ns since the epoch) as a Foxglove timestamp."""
    return fm.Timestamp(sec=log_time // 1_000_000_000, nsec=log_time % 1_000_000_000)


def _color(c: Color) -> fm.Color:
    return fm.Color(r=c[0], g=c[1], b=c[2], a=c[3])


def _identity(x: float = 0.0, y: float = 0.0) -> fm.Pose:
    """A pose at (x, y, 0), unrotated. Every primitive is given one: a pose left out
    decodes as null, which Foxglove's schemas refuse."""
    return fm.Pose(
        position=fm.Vector3(x=x, y=y, z=0.0), orientation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    )


def _points(xy: np.ndarray) -> list[fm.Point3]:
    z = xy[:, 2] if xy.shape[1] > 2 else np.zeros(len(xy))
    return [
        fm.Point3(x=x, y=y, z=h)
        for x, y, h in zip(xy[:, 0].tolist(), xy[:, 1].tolist(), z.tolist(), strict=True)
    ]


def as_points(values: Any) -> np.ndarray:
    """Positions as an (N, 2 or 3) float array; non-finite ones are dropped."""
    xy = np.asarray(values, dtype=float)
    if xy.ndim == 1:
        xy = xy.reshape(1, -1)
    if xy.size == 0:
        return np.zeros((0, 2))
    xy = xy[:, :3]
    return xy[np.isfinite(xy).all(axis=1)]


@dataclass
class _Line:
    kind: int
    xy: np.ndarray
    color: Color


@dataclass
class Canvas:
    """The primitives of one exchange's picture, built into a scene entity at the end
    (:meth:`entity`), when the picture's extent, and so the size of a cross, is known."""

    lines: list[_Line] = field(default_factory=list)
    marks: list[tuple[np.ndarray, Color, float]] = field(default_factory=list)
    texts: list[Text] = field(default_factory=list)
    left_out: int = 0
    """Items not drawn because of the caps."""
    _points: int = 0

    def _room(self, n: int) -> int:
        """How many of ``n`` points fit under :data:`MAX_POINTS`, counting the rest out."""
        fit = max(0, min(n, MAX_POINTS - self._points))
        self._points += fit
        return fit

    def plots(self, values: Any, color: Color, size: float = 1.0) -> None:
        """Crosses at ``values`` (N positions), ``size`` times the usual arm."""
        xy = as_points(values)
        taken = sum(len(m[0]) for m in self.marks)
        keep = self._room(4 * min(len(xy), max(0, MAX_MARKS - taken))) // 4
        self.left_out += len(xy) - keep
        if keep:
            self.marks.append((xy[:keep], color, size))

    def line(self, values: Any, color: Color, closed: bool = False) -> None:
        """A polyline through ``values`` (closed back to its start when ``closed``)."""
        xy = as_points(values)
        if len(xy) < 2:
            return
        if len(self.lines) >= MAX_LINES or self._room(len(xy)) < len(xy):
            self.left_out += 1
            return
        self.lines.append(_Line(LINE_LOOP if closed else LINE_STRIP, xy, color))

    def segments(self, starts: Any, ends: Any, color: Color) -> None:
        """One segment from each start to its end (a line list)."""
        a, b = np.asarray(starts, dtype=float), np.asarray(ends, dtype=float)
        if a.size == 0 or len(self.lines) >= MAX_LINES:
            return
        d = min(a.shape[-1], b.shape[-1], 3)
        pairs = np.stack([a.reshape(-1, a.shape[-1])[:, :d], b.reshape(-1, b.shape[-1])[:, :d]], 1)
        pairs = pairs[np.isfinite(pairs).all(axis=(1, 2))]
        keep = self._room(2 * len(pairs)) // 2
        self.left_out += len(pairs) - keep
        if keep:
            xy = pairs[:keep].reshape(-1, d)
            self.lines.append(_Line(LINE_LIST, xy, color))

    def circle(self, centre: Any, radius: float, color: Color) -> None:
        """A circle of ``radius`` metres about ``centre``."""
        if not (np.isfinite(radius) and radius > 0):
            return
        self.ellipse(centre, np.eye(2) * radius**2, color)

    def ellipse(self, centre: Any, covariance: Any, color: Color, k: float = 1.0) -> None:
        """The ``k``-sigma ellipse of a covariance (its top-left 2x2: x and y) about
        ``centre``; nothing when the covariance is not finite and positive semidefinite."""
        cov = np.asarray(covariance, dtype=float)
        if cov.ndim != 2 or min(cov.shape) < 2 or not np.isfinite(cov).all():
            return
        values, vectors = np.linalg.eigh(cov[:2, :2])
        if values.min() < 0 or not np.isfinite(k):
            return
        xy = np.asarray(centre, dtype=float)[:2] + k * (UNIT_CIRCLE * np.sqrt(values)) @ vectors.T
        self.line(xy, color, closed=True)

    def sector(
        self,
        sensor: Any,
        ranges: tuple[float, float],
        bearings_deg: tuple[float, float],
        color: Color,
    ) -> None:
        """The polar sector between two ranges and two bearings (clockwise from north) seen
        from ``sensor``: two arcs joined by two radials."""
        az = np.radians(np.linspace(bearings_deg[0], bearings_deg[1], 33))
        arc = np.stack([np.sin(az), np.cos(az)], axis=1)
        x0 = np.asarray(sensor, dtype=float)[:2]
        outline = np.concatenate([x0 + ranges[0] * arc, x0 + ranges[1] * arc[::-1]])
        self.line(outline, color, closed=True)

    def bearings(self, origin: Any, bearings_deg: Any, length: float, color: Color) -> None:
        """Lines from ``origin`` along each bearing (degrees clockwise from north)."""
        az = np.radians(np.asarray(bearings_deg, dtype=float).ravel())
        ends = np.asarray(origin, dtype=float)[:2] + length * np.stack([np.sin(az), np.cos(az)], 1)
        self.segments(
            np.broadcast_to(np.asarray(origin, dtype=float)[:2], ends.shape), ends, color
        )

    def text(self, at: Any, text: str, color: Color = colors.TEXT) -> None:
        """A label at ``at`` (only the first :data:`MAX_LINES` labels are kept)."""
        if len(self.texts) >= MAX_LINES or not np.isfinite(np.asarray(at[:2], dtype=float)).all():
            self.left_out += 1
            return
        self.texts.append((float(at[0]), float(at[1]), text[:200], color))

    def extent(self) -> float:
        """The picture's size, m: the largest span of anything drawn, at least
        :data:`MIN_EXTENT` (a radar alone is a cross of a few metres)."""
        parts = [line.xy[:, :2] for line in self.lines] + [m[0][:, :2] for m in self.marks]
        parts.append(np.array([[t[0], t[1]] for t in self.texts]).reshape(-1, 2))
        xy = np.concatenate(parts) if parts else np.zeros((0, 2))
        if len(xy) == 0:
            return MIN_EXTENT
        return max(float(np.ptp(xy, axis=0).max()), MIN_EXTENT)

    def primitives(self) -> list[Line]:
        """Every line to draw, the crosses made lines now the extent is known: (type, points,
        color), the type Foxglove's ``LinePrimitive.Type`` number."""
        arm = CROSS_FRACTION * self.extent()
        lines = [(line.kind, line.xy, line.color) for line in self.lines]
        lines += [(LINE_LIST, _crosses(xy, arm * size), color) for xy, color, size in self.marks]
        return lines

    def entity(self, entity_id: str, log_time: int, metadata: dict[str, str]) -> fm.SceneEntity:
        """The picture as one scene entity in :data:`FRAME`, stamped ``log_time``, built
        with the SDK's classes: the reference :meth:`encoded` is held to."""
        lines = [
            fm.LinePrimitive(
                type=_LINE_TYPES[kind],
                pose=_identity(),
                points=_points(xy),
                color=_color(color),
                thickness=LINE_PX,
                scale_invariant=True,
            )
            for kind, xy, color in self.primitives()
        ]
        texts = [
            fm.TextPrimitive(
                pose=_identity(x, y),
                billboard=True,
                font_size=TEXT_PX,
                scale_invariant=True,
                color=_color(color),
                text=text,
            )
            for x, y, text, color in self.texts
        ]
        return fm.SceneEntity(
            timestamp=timestamp(log_time),
            frame_id=FRAME,
            id=entity_id,
            lifetime=fm.Duration(sec=0, nsec=0),  # until the operation's next exchange
            frame_locked=False,
            metadata=[fm.KeyValuePair(key=k, value=v) for k, v in metadata.items()],
            lines=lines,
            texts=texts,
        )

    def encoded(self, entity_id: str, log_time: int, metadata: dict[str, str]) -> bytes:
        """``SceneUpdate(entities=[self.entity(...)]).encode()``, the SDK's bytes, written
        with numpy (:mod:`plotgate.service.scenes.wire`): what ``plotgate view`` writes."""
        return scene_update(
            FRAME, entity_id, log_time, metadata, self.primitives(), self.texts, LINE_PX, TEXT_PX
        )


def _crosses(xy: np.ndarray, arm: float) -> np.ndarray:
    """The four ends of an upright cross at each position, in line-list order."""
    out = np.repeat(xy[:, :2], 4, axis=0)
    out[0::4, 0] -= arm
    out[1::4, 0] += arm
    out[2::4, 1] -= arm
    out[3::4, 1] += arm
    if xy.shape[1] > 2:
        return np.concatenate([out, np.repeat(xy[:, 2:3], 4, axis=0)], axis=1)
    return out
