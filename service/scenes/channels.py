"""The live view's foxglove-sdk channels, in the publisher process
(:mod:`plotgate.service.scenes.live`): every scene topic advertised from the start, so a
client can subscribe before the first exchange of an operation. Messages are logged as the
bytes :class:`~plotgate.service.scenes.Encoded` writes (the SDK's encoding, with numpy), on
channels of the SDK's schemas."""

import json
import time

import foxglove
import foxglove.messages as fm

from plotgate.service.scenes import (
    DRAWERS,
    LOG_TOPIC,
    SCENE_PREFIX,
    TRANSFORM_TOPIC,
    Encoded,
    Message,
    log,
)

__all__ = ["LiveChannels"]

TRANSFORM_EVERY_S = 1.0


class LiveChannels:
    """A channel per scene topic, ``/log`` and ``/tf``; the radar frame's transform is
    sent with the first exchange and then at most once a second."""

    def __init__(self) -> None:
        self.encoded = Encoded()
        self.channels: dict[str, foxglove.Channel] = {}
        for op in DRAWERS:
            self._channel(SCENE_PREFIX + op, fm.SceneUpdate)
        self._channel(LOG_TOPIC, fm.Log)
        self._channel(TRANSFORM_TOPIC, fm.FrameTransform)
        self._transform_at = -float("inf")

    def _channel(self, topic: str, message_type: type[Message]) -> foxglove.Channel:
        if topic not in self.channels:
            schema = message_type.get_schema()
            self.channels[topic] = foxglove.Channel(
                topic, message_encoding=schema.encoding, schema=schema
            )
        return self.channels[topic]

    def log_exchange(self, offered: tuple[str, int, bytes, bytes]) -> None:
        """Draw one exchange (its records as the route made them) on its channels."""
        operation, log_time, request, response = offered
        messages = []
        if time.monotonic() - self._transform_at >= TRANSFORM_EVERY_S:
            messages += self.encoded.transform(log_time)
            self._transform_at = time.monotonic()
        if request:
            values = json.loads(request), json.loads(response)
            messages += self.encoded.exchange(operation, *values, log_time)
        else:  # over the size a live picture takes
            note = log(log_time, fm.LogLevel.Info, operation, "too large to draw live")
            messages.append((LOG_TOPIC, "foxglove.Log", note.encode()))
        for topic, _, data in messages:
            self._channel(topic, fm.SceneUpdate).log(data, log_time=log_time)
