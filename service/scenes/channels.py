"""The live view's foxglove-sdk channels, in the publisher process
(:mod:`plotgate.service.scenes.live`): every scene topic advertised from the start, so a
client can subscribe before the first exchange of an operation."""

import json
import time
from typing import Any

import foxglove.messages as fm
from foxglove.channels import FrameTransformChannel, LogChannel, SceneUpdateChannel

from plotgate.service.scenes import (
    DRAWERS,
    LOG_TOPIC,
    MAX_TIME_NS,
    SCENE_PREFIX,
    TRANSFORM_TOPIC,
    log,
    radar_transform,
    scene_messages,
)

__all__ = ["LiveChannels"]

TRANSFORM_EVERY_S = 1.0


class LiveChannels:
    """A channel per scene topic, ``/log`` and ``/tf``; the radar frame's transform is
    sent with the first exchange and then at most once a second."""

    def __init__(self) -> None:
        self.channels: dict[str, Any] = {
            SCENE_PREFIX + op: SceneUpdateChannel(SCENE_PREFIX + op) for op in DRAWERS
        }
        self.channels[LOG_TOPIC] = LogChannel(LOG_TOPIC)
        self.transforms = FrameTransformChannel(TRANSFORM_TOPIC)
        self._transform_at = -float("inf")

    def log_exchange(self, offered: tuple[str, int, bytes, bytes]) -> None:
        """Draw one exchange (its records as the route made them) on its channels."""
        operation, log_time, request, response = offered
        if not 0 <= log_time <= MAX_TIME_NS:  # the server's clock past 2106
            return
        if time.monotonic() - self._transform_at >= TRANSFORM_EVERY_S:
            self.transforms.log(radar_transform(log_time), log_time=log_time)
            self._transform_at = time.monotonic()
        if not request:  # over the size a live picture takes
            note = log(log_time, fm.LogLevel.Info, operation, "too large to draw live")
            self.channels[LOG_TOPIC].log(note, log_time=log_time)
            return
        messages = scene_messages(operation, json.loads(request), json.loads(response), log_time)
        for topic, message in messages:
            channel = self.channels.get(topic)
            if channel is None:  # an operation this build does not draw
                channel = self.channels[topic] = SceneUpdateChannel(topic)
            channel.log(message, log_time=log_time)  # type: ignore[arg-type]  # by topic
