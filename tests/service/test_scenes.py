"""The scene builder: every operation draws its exchange; problems and odd records are logs."""

import json

import foxglove.messages as fm
import numpy as np
import pytest

from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.scenes import DRAWERS, LOG_TOPIC, SCENE_PREFIX, scene_messages
from plotgate.service.scenes.draw import MAX_MARKS, Canvas
from plotgate.service.schemas.examples import EXAMPLES

T = 1_764_000_000_123_456_789


def exchange(operation: str, body: dict) -> tuple[dict, dict]:
    answer = execute(OPERATIONS[operation], json.dumps(body).encode())
    request = {"request_id": "r1", "operation": operation, "body": body}
    response = {"request_id": "r1", "operation": operation, "status": answer.status}
    key = "result" if answer.status < 400 else "error"
    response |= {"duration_s": 0.01, key: json.loads(answer.content)}
    return request, response


def test_every_operation_has_a_drawing():
    assert set(DRAWERS) == set(OPERATIONS)


@pytest.mark.parametrize("operation", sorted(EXAMPLES))
def test_every_operation_draws_its_example(operation):
    messages = scene_messages(operation, *exchange(operation, EXAMPLES[operation]), T)
    [(topic, scene)] = messages  # no log: nothing went wrong
    assert topic == SCENE_PREFIX + operation
    assert isinstance(scene, fm.SceneUpdate)
    assert len(scene.encode()) > 200  # lines and labels, not an empty entity


def test_a_problem_is_a_warning_and_a_red_label():
    body = dict(EXAMPLES["gates.test"], first={"frame": "cartesian", "x": 0.0})
    request, response = exchange("gates.test", body)
    assert response["status"] == 422
    (topic, _), (log_topic, log) = scene_messages("gates.test", request, response, T)
    assert (topic, log_topic) == (SCENE_PREFIX + "gates.test", LOG_TOPIC)
    # the SDK's messages show their fields only in their repr
    assert "level=3" in repr(log)  # foxglove.LogLevel.Warning
    assert "first.cartesian.y: Field required" in repr(log) and "r1" in repr(log)


def test_records_of_unexpected_shape_and_missing_halves_are_logs():
    request, response = exchange("gates.test", EXAMPLES["gates.test"])
    response["result"] = {"inside": "not a list"}
    messages = scene_messages("gates.test", request, response, T)
    assert [topic for topic, _ in messages] == [SCENE_PREFIX + "gates.test", LOG_TOPIC]
    assert "cannot draw" in repr(messages[1][1])
    [(topic, log)] = scene_messages("gates.test", request, None, T)
    assert topic == LOG_TOPIC and "never answered" in repr(log)
    [(topic, log)] = scene_messages("gates.test", None, response, T)
    assert topic == LOG_TOPIC and "request record lost" in repr(log)


def test_the_canvas_caps_what_one_exchange_draws():
    canvas = Canvas()
    rng = np.random.default_rng(1)
    canvas.plots(rng.normal(size=(MAX_MARKS + 7, 2)), (1.0, 1.0, 1.0, 1.0))
    assert canvas.left_out == 7
    assert sum(len(xy) for xy, _, _ in canvas.marks) == MAX_MARKS
