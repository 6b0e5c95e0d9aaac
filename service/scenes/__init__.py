"""Exchanges as Foxglove scenes: what ``plotgate view`` writes and ``serve --foxglove-port``
publishes, one builder for both.

Each answered exchange becomes, stamped with its request's time:

- a ``foxglove.SceneUpdate`` on ``/scene/<operation>``, one entity (id ``exchange``, so the
  next exchange of the operation replaces it) in the ``radar`` frame (x east, y north, m)
  holding the operation's picture (:mod:`~plotgate.service.scenes.gates`,
  :mod:`~plotgate.service.scenes.solves`, :mod:`~plotgate.service.scenes.initiation`,
  :mod:`~plotgate.service.scenes.identification`), its metadata the request id, status and
  operation;
- a ``foxglove.Log`` on ``/log`` for a problem: the exchange's own (a 4xx is a warning, a
  5xx an error, naming the fields the problem names), a request never answered, an answer
  whose request is lost, a record this build cannot draw, or a picture cut at the caps.

A failed exchange's scene is its status in red at the origin, so scrubbing to it never
shows the previous exchange's picture as if it were its own. :func:`radar_transform` is the
``foxglove.FrameTransform`` placing ``radar`` in ``world`` (the identity: plotgate's
positions are already in the radar's frame); the writers send it at the first exchange and
then once a second of recording time, so a viewer that seeks anywhere finds it.

Messages are foxglove-sdk's schema classes (protobuf, the SDK's encoding), never
hand-written schemas. Imported only by ``plotgate view`` and by a server given
``--foxglove-port``: foxglove-sdk is the optional extra ``plotgate[view]``.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import foxglove.messages as fm

from plotgate.service.scenes.batched import BatchDrawer, Plan
from plotgate.service.scenes.draw import FRAME, Canvas, colors, timestamp
from plotgate.service.table import ENDPOINTS

__all__ = [
    "DRAWERS",
    "FRAME",
    "Drawn",
    "Encoded",
    "LOG_TOPIC",
    "MAX_TIME_NS",
    "PARENT_FRAME",
    "SCENE_PREFIX",
    "TRANSFORM_TOPIC",
    "Message",
    "Recorded",
    "draw",
    "log",
    "radar_transform",
    "scene_messages",
    "schema_of",
]

SCENE_PREFIX = "/scene/"
LOG_TOPIC = "/log"
TRANSFORM_TOPIC = "/tf"
PARENT_FRAME = "world"
ENTITY_ID = "exchange"
MAX_TIME_NS = 2**32 * 1_000_000_000 - 1
"""The last time Foxglove's Timestamp holds (its seconds are 32 bits: early 2106). An
exchange stamped later (a damaged or hostile file's) is not drawn."""

Message = fm.SceneUpdate | fm.FrameTransform | fm.Log
Drawer = Callable[[Canvas, dict[str, Any], dict[str, Any]], None]

DRAWERS: dict[str, Drawer] = {
    name: e.drawer.load() for name, e in ENDPOINTS.items() if e.drawer is not None
}
"""Every operation's drawing (its declaration's ``drawer``), by operation name."""

BATCH_DRAWERS: dict[str, BatchDrawer] = {
    name: e.batch_drawer.load() for name, e in ENDPOINTS.items() if e.batch_drawer is not None
}
"""The operations whose exchanges ``view`` draws many at once (a
:class:`~plotgate.service.scenes.batched.BatchDrawer`, the declaration's
``batch_drawer``), by operation name."""

_CANNOT_DRAW = (KeyError, TypeError, IndexError, ValueError, AttributeError, OverflowError)
"""What a record of an unexpected shape raises while drawn (geometry's docstring)."""


def schema_of(message_type: type[Message]) -> Any:
    """The SDK's schema (``foxglove.Schema``: name, encoding, data) of a message class."""
    return message_type.get_schema()


def radar_transform(log_time: int) -> fm.FrameTransform:
    """The radar frame in the world frame (identity), stamped ``log_time``."""
    return fm.FrameTransform(
        timestamp=timestamp(log_time),
        parent_frame_id=PARENT_FRAME,
        child_frame_id=FRAME,
        translation=fm.Vector3(x=0.0, y=0.0, z=0.0),
        rotation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
    )


def log(log_time: int, level: fm.LogLevel, operation: str, message: str) -> fm.Log:
    """A Log message of ``operation`` (its ``name``)."""
    return fm.Log(timestamp=timestamp(log_time), level=level, message=message, name=operation)


@dataclass
class Drawn:
    """One exchange drawn: its picture (None when there is none to show: a request never
    answered, an answer whose request is lost), the scene entity's metadata, and its Log
    messages."""

    canvas: Canvas | None
    metadata: dict[str, str]
    logs: list[fm.Log]


def draw(
    operation: str,
    request: dict[str, Any] | None,
    response: dict[str, Any] | None,
    log_time: int,
) -> Drawn:
    """Draw one exchange from its request and response records as recorded (either None
    when missing)."""
    if request is None or response is None:
        what = "request record lost" if request is None else "never answered"
        rid = (request or response or {}).get("request_id")
        return Drawn(None, {}, [log(log_time, fm.LogLevel.Warning, operation, f"{rid}: {what}")])
    rid = str(request.get("request_id"))
    status = response.get("status")
    drawn = Drawn(Canvas(), {"request_id": rid, "status": str(status), "operation": operation}, [])
    if not isinstance(status, int) or status >= 400 or "body" not in request:
        failed = f"{status} {_problem(response)}"
        assert drawn.canvas is not None
        drawn.canvas.text((0.0, 0.0), failed, colors.OUTSIDE)
        server = not isinstance(status, int) or status >= 500
        level = fm.LogLevel.Error if server else fm.LogLevel.Warning
        drawn.logs.append(log(log_time, level, operation, f"{rid}: {failed}"))
        return drawn
    try:
        assert drawn.canvas is not None
        DRAWERS[operation](drawn.canvas, request["body"], response["result"])
    except _CANNOT_DRAW as exc:
        drawn.canvas = Canvas()
        reason = f"cannot draw this record: {type(exc).__name__}: {str(exc)[:200]}"
        drawn.canvas.text((0.0, 0.0), reason, colors.OUTSIDE)
        drawn.logs.append(log(log_time, fm.LogLevel.Warning, operation, f"{rid}: {reason}"))
    if drawn.canvas.left_out:
        note = f"{rid}: drawn in part, {drawn.canvas.left_out} items left out (the scene's caps)"
        drawn.logs.append(log(log_time, fm.LogLevel.Info, operation, note))
    return drawn


def scene_messages(
    operation: str,
    request: dict[str, Any] | None,
    response: dict[str, Any] | None,
    log_time: int,
) -> list[tuple[str, Message]]:
    """The scene and log messages of one exchange (:func:`draw`), as ``(topic, message)``
    of the SDK's classes."""
    if not 0 <= log_time <= MAX_TIME_NS:
        return []
    drawn = draw(operation, request, response, log_time)
    out: list[tuple[str, Message]] = [(LOG_TOPIC, message) for message in drawn.logs]
    if drawn.canvas is not None:
        entity = drawn.canvas.entity(ENTITY_ID, log_time, drawn.metadata)
        out.insert(0, (SCENE_PREFIX + operation, fm.SceneUpdate(entities=[entity])))
    return out


def _problem(response: dict[str, Any]) -> str:
    """A problem's title, detail and fields, on one line; a record without one, said so."""
    error = response.get("error")
    if not isinstance(error, dict):
        return "the request's body was not JSON" if response.get("status", 0) < 400 else "error"
    fields = "; ".join(
        f"{e.get('field')}: {e.get('reason')}"
        for e in error.get("errors") or []
        if isinstance(e, dict)
    )
    text = f"{error.get('title')}: {fields or error.get('detail')}"
    return text[:1000]


class Recorded(Protocol):
    """An exchange as a reader gives it (``plotgate.clients.recordings.Exchange``): its
    records' bytes, and their values built on first use."""

    operation: str
    log_time: int
    request_bytes: bytes | None
    response_bytes: bytes | None

    @property
    def request(self) -> dict[str, Any] | None: ...

    @property
    def response(self) -> dict[str, Any] | None: ...


class Encoded:
    """The scenes as bytes, for writers that know nothing of foxglove-sdk (``plotgate
    view``'s, in the clients layer, which is handed one): schemas by name, and each
    message as ``(topic, schema name, protobuf bytes)``."""

    def __init__(self) -> None:
        self._schemas = {
            cls: cls.get_schema() for cls in (fm.SceneUpdate, fm.FrameTransform, fm.Log)
        }

    def schemas(self) -> dict[str, tuple[str, bytes]]:
        """Each schema's name: its encoding and data."""
        return {s.name: (s.encoding, bytes(s.data)) for s in self._schemas.values()}

    def _encoded(self, topic: str, message: Message) -> tuple[str, str, bytes]:
        return topic, self._schemas[type(message)].name, message.encode()

    def exchange(
        self,
        operation: str,
        request: dict[str, Any] | None,
        response: dict[str, Any] | None,
        log_time: int,
    ) -> list[tuple[str, str, bytes]]:
        """:func:`scene_messages`, encoded (the scene by
        :meth:`~plotgate.service.scenes.draw.Canvas.encoded`: the SDK's bytes, with numpy)."""
        if not 0 <= log_time <= MAX_TIME_NS:
            return []
        drawn = draw(operation, request, response, log_time)
        out = [self._encoded(LOG_TOPIC, message) for message in drawn.logs]
        if drawn.canvas is not None:
            scene = drawn.canvas.encoded(ENTITY_ID, log_time, drawn.metadata)
            name = self._schemas[fm.SceneUpdate].name
            out.insert(0, (SCENE_PREFIX + operation, name, scene))
        return out

    def transform(self, log_time: int) -> list[tuple[str, str, bytes]]:
        """:func:`radar_transform` on :data:`TRANSFORM_TOPIC`, encoded (none past
        :data:`MAX_TIME_NS`)."""
        if not 0 <= log_time <= MAX_TIME_NS:
            return []
        return [self._encoded(TRANSFORM_TOPIC, radar_transform(log_time))]

    def exchanges(self, batch: Sequence[Recorded]) -> list[list[tuple[str, str, bytes]]]:
        """:meth:`exchange` of each exchange of ``batch``: those of an operation with a batch
        drawing (:data:`BATCH_DRAWERS`) drawn together from their bytes when of its common
        form, the others one at a time from their values."""
        out: list[list[tuple[str, str, bytes]] | None] = [None] * len(batch)
        planned: dict[str, tuple[list[Plan], list[int]]] = {}
        for i, ex in enumerate(batch):
            drawer = BATCH_DRAWERS.get(ex.operation)
            if (
                drawer is not None
                and ex.request_bytes is not None
                and ex.response_bytes is not None
                and 0 <= ex.log_time <= MAX_TIME_NS
            ):
                plan = drawer.plan(ex.request_bytes, ex.response_bytes, ex.log_time)
                if plan is not None:
                    plans, places = planned.setdefault(ex.operation, ([], []))
                    plans.append(plan)
                    places.append(i)
                    continue
            out[i] = self.exchange(ex.operation, ex.request, ex.response, ex.log_time)
        name = self._schemas[fm.SceneUpdate].name
        for operation, (plans, places) in planned.items():
            topic = SCENE_PREFIX + operation
            scenes = BATCH_DRAWERS[operation].draw(plans, ENTITY_ID, operation)
            for i, scene in zip(places, scenes, strict=True):
                out[i] = [(topic, name, scene)]
        return [messages or [] for messages in out]
