"""Seeded random requests at the edges of the schema bounds: every answer is 200 or a 4xx
problem naming an input field, never a 500, never a numpy warning (warnings are errors)."""

import json
import random

import pytest

from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.schemas import MAX_DISTANCE

COORDS = [0.0, 1e-300, -1e-300, 1.0, -1.0, 5e4, -5e4, MAX_DISTANCE, -MAX_DISTANCE]
VARIANCES = [1e-6, 1.0, 4e4, 1e10, MAX_DISTANCE**2]
COVARIANCES = [0.0, 1e-300, 1e-6, -1e-6, 2e4, 1e9, -1e9, MAX_DISTANCE**2, -(MAX_DISTANCE**2)]
PARAMETERS = {
    "tau": [1e-300, 5.0, 1e6],
    "v_min": [0.0, 1e-300, 100.0, 1e6],
    "v_max": [0.0, 1e-300, 500.0, 1e6],
    "p": [1e-6, 0.5, 0.9, 1 - 1e-16],
    "P_G": [1e-300, 0.9, 1 - 1e-16],
    "k": [0.01, 3.0, 100.0],
    "K_R": [0.01, 3.0, 100.0],
    "K_az": [0.01, 3.0, 100.0],
}
GATES = {
    "ring": ["tau", "v_min", "v_max"],
    "expanded": ["tau", "v_max", "p"],
    "combined": ["tau", "v_min", "v_max", "P_G"],
    "ellipse": ["P_G"],
    "rectangular": ["k"],
    "sector": ["K_R", "K_az"],
    "first_association": ["tau", "v_max", "K_R", "K_az"],
}


def _plot(rnd: random.Random) -> dict:
    sensor = [rnd.choice(COORDS), rnd.choice(COORDS)]
    if rnd.random() < 0.5:
        a, b, c = rnd.choice(VARIANCES), rnd.choice(COVARIANCES), rnd.choice(VARIANCES)
        return {
            "frame": "cartesian",
            "x": rnd.choice(COORDS),
            "y": rnd.choice(COORDS),
            "covariance": [[a, b], [b, c]],
            "sensor": sensor,
        }
    return {
        "frame": "polar",
        "r": rnd.choice([1.0, 1.5, 5e4, MAX_DISTANCE]),
        "az_deg": rnd.choice([0.0, 1e-300, 90.0, 359.9, 360.0, -360.0]),
        "sigma_r": rnd.choice([1e-3, 200.0, MAX_DISTANCE]),
        "sigma_az_deg": rnd.choice([1e-6, 0.5, 180.0]),
        "sensor": sensor,
    }


def _gate(rnd: random.Random) -> dict:
    kind = rnd.choice(sorted(GATES))
    return {"kind": kind, **{name: rnd.choice(PARAMETERS[name]) for name in GATES[kind]}}


@pytest.mark.parametrize("seed", range(4))
def test_random_edge_requests_never_fail_the_server(seed):
    rnd = random.Random(seed)
    statuses = set()
    for _ in range(1000):
        n = rnd.randint(1, 4)
        if rnd.random() < 0.5:
            op = OPERATIONS["gates.test"]
            body = {
                "gate": _gate(rnd),
                "first": _plot(rnd),
                "candidates": [_plot(rnd) for _ in range(n)],
            }
        else:
            op = OPERATIONS["gates.pairs"]
            body = {
                "gate": _gate(rnd),
                "pairs": [{"first": _plot(rnd), "second": _plot(rnd)} for _ in range(n)],
            }
        outcome = execute(op, json.dumps(body).encode())
        statuses.add(outcome.status)
        if outcome.status != 200:
            problem = outcome.json()
            assert outcome.status == 422, problem
            fields = [e["field"] for e in problem["errors"]]
            assert fields and all(
                f.startswith(("gate", "first", "candidates", "pairs")) for f in fields
            ), problem
    assert statuses == {200, 422}
