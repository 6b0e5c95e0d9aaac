"""The batched drawing of ``gates.test`` exchanges gives the bytes of the one-at-a-time
drawing it replaces (:meth:`Encoded.exchange`, the reference), on the usual records, on
random ones and on odd ones it leaves to the reference."""

import json

import numpy as np
import pytest

from plotgate.clients.recordings import Exchange
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.scenes import Encoded, batched
from plotgate.service.table import ENDPOINTS

T = 1_764_000_000_123_456_789
GATES = [
    {"kind": "ellipse", "P_G": 0.9},
    {"kind": "ellipse", "P_G": 0.99},
    {"kind": "ring", "v_min": 50.0, "v_max": 300.0, "tau": 2.0},
    {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "tau": 5.0, "P_G": 0.9},
    {"kind": "expanded", "v_max": 300.0, "tau": 1.5},
    {"kind": "first_association", "v_max": 300.0, "tau": 1.5},
    {"kind": "ring", "v_max": 300.0, "tau": 1.0},
    {"kind": "rectangular", "k": 3.0},
    {"kind": "sector", "K_R": 3.0, "K_az": 3.0},
]


def plot(rng: np.random.Generator, polar: bool, zero: bool = False) -> dict:
    if polar:
        out = {"frame": "polar", "r": float(rng.uniform(1e3, 9e4)), "az_deg": 0.0}
        out |= {"sigma_r": 50.0, "sigma_az_deg": 0.3}
        if not zero:
            out["az_deg"] = float(rng.uniform(-180, 360))
        if rng.random() < 0.3:
            out["sensor"] = [float(rng.normal() * 1e3), float(rng.normal() * 1e3)]
        return out
    x, y = (0.0 if zero else float(rng.normal() * 3e4)), float(rng.normal() * 3e4)
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[4e4, 1e3], [1e3, 9e4]]}


def exchange(i: int, body: dict, answer: dict | None = None) -> Exchange:
    """An exchange of ``body`` as the reader gives it: its records' bytes, its answer the
    service's (or ``answer``)."""
    data = json.dumps(body).encode()
    if answer is None:
        served = execute(OPERATIONS["gates.test"], data)
        key = "result" if served.status < 400 else "error"
        answer = {"status": served.status, key: json.loads(served.content)}
    request = {"request_id": f"r{i}", "operation": "gates.test", "body": body}
    response = {"request_id": f"r{i}", "operation": "gates.test", "duration_s": 0.01} | answer
    return Exchange(
        "gates.test",
        f"r{i}",
        log_time=T + i * 10**7,
        request_bytes=json.dumps(request).encode(),
        response_bytes=json.dumps(response).encode(),
    )


def one_at_a_time(batch: list[Exchange]) -> list[list[tuple[str, str, bytes]]]:
    encoded = Encoded()
    return [encoded.exchange(ex.operation, ex.request, ex.response, ex.log_time) for ex in batch]


def random_batch(seed: int, n: int) -> list[Exchange]:
    rng = np.random.default_rng(seed)
    batch = []
    for i in range(n):
        polar = rng.random() < 0.5
        count = int(rng.integers(0, 40))
        body = {
            "gate": GATES[int(rng.integers(len(GATES)))],
            "first": plot(rng, rng.random() < 0.5, zero=rng.random() < 0.2),
            "candidates": [
                plot(rng, polar if rng.random() < 0.8 else not polar, rng.random() < 0.1)
                for _ in range(count)
            ],
        }
        batch.append(exchange(i, body))
    return batch


@pytest.mark.parametrize("seed", range(6))
def test_random_gate_tests_draw_as_one_at_a_time(seed):
    batch = random_batch(seed, 80)
    assert Encoded().exchanges(batch) == one_at_a_time(batch)
    taken = [batched.plan(ex.request_bytes, ex.response_bytes, ex.log_time) for ex in batch]
    assert sum(p is not None for p in taken) > len(batch) // 2  # the batched path drew most


def test_the_example_and_a_bench_like_record_take_the_batched_path():
    plots = [
        {"frame": "cartesian", "x": 100.0 * i, "y": 5e4, "covariance": [[1e4, 0], [0, 1e4]]}
        for i in range(100)
    ]
    bench = {"gate": {"kind": "ellipse", "P_G": 0.9}, "first": plots[0], "candidates": plots}
    batch = [exchange(0, ENDPOINTS["gates.test"].example), exchange(1, bench)]
    for ex in batch:
        assert batched.plan(ex.request_bytes, ex.response_bytes, ex.log_time) is not None
    assert Encoded().exchanges(batch) == one_at_a_time(batch)


def answered(**result) -> dict:
    return {"status": 200, "result": {"threshold": 4.6} | result}


CARTESIAN = {"frame": "cartesian", "x": 1.0, "y": 2.0}
ODD = {
    "a refused request": ({"gate": {"kind": "ellipse"}}, None),
    "a server error": (None, {"status": 500, "error": {"title": "boom"}}),
    "a result without its fields": (None, {"status": 200, "result": {}}),
    "a count as a float": (None, answered(kind="e", count_inside=1.0, inside=[True])),
    "inside as numbers": (None, answered(kind="e", count_inside=1, inside=[1, 0])),
    "a short inside": (None, answered(kind="e", count_inside=1, inside=[True])),
    "a long inside": (None, answered(kind="e", count_inside=1, inside=[True] * 9)),
    "a negative threshold": (None, answered(kind="e", count_inside=0, inside=[], threshold=-1)),
    "an overflowing covariance": (
        {"first": CARTESIAN | {"covariance": [[1e308, 0], [0, 1e308]]}},
        None,
    ),
    "a plot without a frame": ({"candidates": [{"x": 1.0, "y": 2.0}]}, None),
    "a plot of strings": ({"candidates": [CARTESIAN | {"x": "1"}]}, None),
    "a null tau": ({"gate": {"kind": "ring", "v_max": 3.0, "tau": None}}, None),
    "no v_max": ({"gate": {"kind": "expanded", "tau": 1.0}}, None),
    "a null v_min": ({"gate": {"kind": "ring", "v_max": 3.0, "v_min": None, "tau": 1.0}}, None),
    "a zero radius": ({"gate": {"kind": "ring", "v_max": 0.0, "tau": 1.0}}, None),
    "an unknown gate": ({"gate": {"kind": "hexagon"}}, None),
    "a three-number sensor": (
        {"candidates": [{"frame": "polar", "r": 1.0, "az_deg": 2.0, "sensor": [1, 2, 3]}]},
        None,
    ),
    "no candidates": ({"candidates": []}, None),
}


@pytest.mark.parametrize("case", ODD)
def test_odd_records_draw_as_one_at_a_time(case):
    change, answer = ODD[case]
    rng = np.random.default_rng(1)
    body = {"gate": GATES[0], "first": plot(rng, False), "candidates": [plot(rng, False)] * 3}
    body |= change or {}
    batch = [exchange(0, body, answer), *random_batch(7, 5)]
    assert Encoded().exchanges(batch) == one_at_a_time(batch)


def test_other_operations_and_lost_records_are_drawn_one_at_a_time():
    example = ENDPOINTS["gates.pairs"].example
    served = execute(OPERATIONS["gates.pairs"], json.dumps(example).encode())
    pairs = Exchange(
        "gates.pairs",
        "p",
        log_time=T,
        request_bytes=json.dumps({"request_id": "p", "body": example}).encode(),
        response_bytes=json.dumps({"status": 200, "result": json.loads(served.content)}).encode(),
    )
    unanswered = exchange(1, {"gate": GATES[0]})
    unanswered.response_bytes = None
    late = exchange(2, {"gate": GATES[0]})
    late.log_time = 2**64 - 1
    batch = [pairs, unanswered, late, *random_batch(3, 4)]
    assert Encoded().exchanges(batch) == one_at_a_time(batch)
    assert Encoded().exchanges([]) == []


def test_values_past_a_doubles_range_are_drawn_one_at_a_time():
    far = {"frame": "polar", "r": 1.5e308, "az_deg": 45.0, "sensor": [1.5e308, 0.0]}
    rng = np.random.default_rng(2)
    body = {"gate": GATES[2], "first": plot(rng, False), "candidates": [far, far]}
    huge = {"kind": "ring", "v_max": 1e200, "tau": 1e10}  # its radius squared overflows
    batch = [exchange(0, body), exchange(1, body | {"gate": huge, "candidates": []})]
    for ex in batch:
        assert batched.plan(ex.request_bytes, ex.response_bytes, T) is None
    assert Encoded().exchanges(batch) == one_at_a_time(batch)
