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

from collections.abc import Callable
from typing import Any

import foxglove.messages as fm

from plotgate.service.scenes import gates, identification, initiation, solves
from plotgate.service.scenes.draw import FRAME, Canvas, colors, timestamp

__all__ = [
    "DRAWERS",
    "FRAME",
    "Encoded",
    "LOG_TOPIC",
    "PARENT_FRAME",
    "SCENE_PREFIX",
    "TRANSFORM_TOPIC",
    "Message",
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

Message = fm.SceneUpdate | fm.FrameTransform | fm.Log
Drawer = Callable[[Canvas, dict[str, Any], dict[str, Any]], None]

DRAWERS: dict[str, Drawer] = {
    **gates.DRAWERS,
    **solves.DRAWERS,
    **initiation.DRAWERS,
    **identification.DRAWERS,
}
"""Every operation's drawing, by operation name."""

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


def scene_messages(
    operation: str,
    request: dict[str, Any] | None,
    response: dict[str, Any] | None,
    log_time: int,
) -> list[tuple[str, Message]]:
    """The scene and log messages of one exchange (its request and response records as
    recorded, either None when missing), as ``(topic, message)``."""
    if request is None:
        return [_note(log_time, fm.LogLevel.Warning, operation, response, "request record lost")]
    rid = str(request.get("request_id"))
    if response is None:
        return [_note(log_time, fm.LogLevel.Warning, operation, request, "never answered")]
    status = response.get("status")
    metadata = {"request_id": rid, "status": str(status), "operation": operation}
    canvas = Canvas()
    out: list[tuple[str, Message]] = []
    if not isinstance(status, int) or status >= 400 or "body" not in request:
        canvas.text((0.0, 0.0), f"{status} {_problem(response)}", colors.OUTSIDE)
        level = (
            fm.LogLevel.Error
            if not isinstance(status, int) or status >= 500
            else fm.LogLevel.Warning
        )
        out.append(
            (LOG_TOPIC, log(log_time, level, operation, f"{rid}: {status} {_problem(response)}"))
        )
    else:
        try:
            DRAWERS[operation](canvas, request["body"], response["result"])
        except _CANNOT_DRAW as exc:
            canvas = Canvas()
            reason = f"cannot draw this record: {type(exc).__name__}: {str(exc)[:200]}"
            canvas.text((0.0, 0.0), reason, colors.OUTSIDE)
            out.append(
                (LOG_TOPIC, log(log_time, fm.LogLevel.Warning, operation, f"{rid}: {reason}"))
            )
        if canvas.left_out:
            note = f"{rid}: drawn in part, {canvas.left_out} items left out (the scene's caps)"
            out.append((LOG_TOPIC, log(log_time, fm.LogLevel.Info, operation, note)))
    entity = canvas.entity(ENTITY_ID, log_time, metadata)
    out.insert(0, (SCENE_PREFIX + operation, fm.SceneUpdate(entities=[entity])))
    return out


def _note(
    log_time: int, level: fm.LogLevel, operation: str, record: dict[str, Any] | None, what: str
) -> tuple[str, Message]:
    rid = None if record is None else record.get("request_id")
    return LOG_TOPIC, log(log_time, level, operation, f"{rid}: {what}")


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
        """:func:`scene_messages`, encoded."""
        messages = scene_messages(operation, request, response, log_time)
        return [self._encoded(topic, message) for topic, message in messages]

    def transform(self, log_time: int) -> tuple[str, str, bytes]:
        """:func:`radar_transform` on :data:`TRANSFORM_TOPIC`, encoded."""
        return self._encoded(TRANSFORM_TOPIC, radar_transform(log_time))
