"""The scene builder: every operation draws its exchange; problems and odd records are logs."""

import json

import foxglove.messages as fm
import numpy as np
import pytest

from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.scenes import (
    DRAWERS,
    LOG_TOPIC,
    MAX_TIME_NS,
    SCENE_PREFIX,
    Encoded,
    draw,
    scene_messages,
)
from plotgate.service.scenes.draw import MAX_MARKS, Canvas
from plotgate.service.scenes.geometry import plot_position, plot_positions
from plotgate.service.table import ENDPOINTS

EXAMPLES = {name: e.example for name, e in ENDPOINTS.items()}

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


def sdk_bytes(canvas: Canvas, log_time: int, metadata: dict[str, str]) -> bytes:
    """The reference: the picture built with the SDK's classes, encoded by the SDK."""
    return fm.SceneUpdate(entities=[canvas.entity("exchange", log_time, metadata)]).encode()


@pytest.mark.parametrize("operation", sorted(EXAMPLES))
def test_the_numpy_encoding_is_the_sdks_byte_for_byte(operation):
    request, response = exchange(operation, EXAMPLES[operation])
    drawn = draw(operation, request, response, T)
    assert drawn.canvas.encoded("exchange", T, drawn.metadata) == sdk_bytes(
        drawn.canvas, T, drawn.metadata
    )


def test_the_numpy_encoding_matches_on_random_pictures_zeros_included():
    rng = np.random.default_rng(7)
    for trial in range(30):
        canvas = Canvas()
        n = int(rng.integers(0, 40))
        xy = rng.normal(scale=10.0 ** rng.integers(-3, 6), size=(n, 3 if trial % 3 else 2))
        xy[rng.random(xy.shape) < 0.3] = 0.0
        xy[rng.random(xy.shape) < 0.1] = -0.0
        canvas.plots(xy, tuple(rng.choice([0.0, 0.5, 1.0], 4)), size=float(rng.random()))
        canvas.line(xy, (0.0, 0.0, 0.0, 0.0), closed=bool(trial % 2))
        canvas.segments(xy[: n // 2], xy[n // 2 : 2 * (n // 2)], (1.0, 0.0, 0.0, 1.0))
        canvas.ellipse(xy[0, :2] if n else [0.0, 0.0], np.diag([4.0, 1.0]), (1, 1, 0, 1))
        canvas.text([float(rng.normal()), 0.0], "é" * int(rng.integers(0, 3)))
        metadata = {"request_id": f"r{trial}", "": "empty key", "k": ""}
        t = int(rng.integers(0, MAX_TIME_NS))
        assert canvas.encoded("exchange", t, metadata) == sdk_bytes(canvas, t, metadata)


@pytest.mark.parametrize("dims", [2, 3])
def test_the_numpy_encoding_matches_when_a_few_points_have_a_zero(dims):
    """Pictures whose points mostly have the same non-zero coordinates, a few with a zero
    among them (a cross on x = 0, a point at the origin): the fixed-width path, patched."""
    rng = np.random.default_rng(11)
    for trial in range(10):
        xy = rng.normal(scale=1e4, size=(100, dims))
        odd = rng.choice(100, size=int(rng.integers(1, 3)), replace=False)
        xy[odd, rng.integers(0, dims, size=len(odd))] = 0.0 if trial % 2 else -0.0
        canvas = Canvas()
        canvas.plots(xy, (0.2, 0.85, 0.3, 1.0))
        canvas.line(xy[:10], (1.0, 0.75, 0.0, 1.0))
        canvas.plots(np.zeros((1, dims)), (1.0, 1.0, 1.0, 1.0))
        t = int(rng.integers(0, MAX_TIME_NS))
        assert canvas.encoded("exchange", t, {}) == sdk_bytes(canvas, t, {})


def test_plot_positions_are_plot_position_at_speed():
    rng = np.random.default_rng(3)
    plots = [
        {"frame": "cartesian", "x": x, "y": y, "covariance": [[1, 0], [0, 1]]}
        for x, y in rng.normal(size=(20, 2))
    ] + [
        {"frame": "polar", "r": r, "az_deg": az, "sigma_r": 1.0, "sigma_az_deg": 0.1}
        | ({"sensor": [5.0, -3.0]} if az > 0 else {})
        for r, az in zip(rng.uniform(1, 1e5, 20), rng.uniform(-180, 180, 20), strict=True)
    ]
    reference = np.array([plot_position(p)[0] for p in plots])
    assert np.allclose(plot_positions(plots), reference, rtol=1e-15, atol=1e-9)


def test_times_past_the_schemas_range_draw_nothing():
    request, response = exchange("gates.test", EXAMPLES["gates.test"])
    assert scene_messages("gates.test", request, response, MAX_TIME_NS + 1) == []
    assert Encoded().exchange("gates.test", request, response, 2**64 - 1) == []
    assert Encoded().transform(2**64 - 1) == []
