"""Shared test builders: requests."""

import dataclasses
import math

from plotgate.service import registry


def with_handler(name: str, handler) -> registry.Operation:
    """A copy of the registry's operation ``name`` answering with ``handler`` (held where
    the registry keeps the handler it imports on first use)."""
    op = dataclasses.replace(registry.OPERATIONS[name])
    vars(op)["handler"] = handler
    return op


def cartesian(
    x: float, y: float, sxx: float = 100.0**2, syy: float = 100.0**2, sxy: float = 0.0
) -> dict:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[sxx, sxy], [sxy, syy]]}


def polar(r: float, az_deg: float, sigma_r: float = 200.0, sigma_az_deg: float = 0.5) -> dict:
    return {
        "frame": "polar",
        "r": r,
        "az_deg": az_deg,
        "sigma_r": sigma_r,
        "sigma_az_deg": sigma_az_deg,
    }


def answer(r) -> dict:
    """The JSON body of a 200 answer."""
    assert r.status_code == 200, r.text
    return r.json()


def invalid_input(r, field: str, status: int = 422) -> dict:
    """The problem body of an invalid-input answer that names ``field``."""
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["status"] == status and body["type"] == "urn:plotgate:problem:invalid-input"
    assert field in [e["field"] for e in body["errors"]], body
    assert field in body["detail"]
    return body


GOOD = {
    "gate": {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
    "first": cartesian(0.0, 50_000.0),
    "candidates": [cartesian(0.0, 51_000.0), cartesian(0.0, 52_600.0)],
}


BAD_COV = dict(
    GOOD,
    candidates=[
        {"frame": "cartesian", "x": 0.0, "y": 5e4, "covariance": [[1.0, 2.0], [2.0, 1.0]]}
    ],
)


def assert_finite(value) -> None:
    """Every number in a JSON answer is finite."""
    if isinstance(value, dict):
        for v in value.values():
            assert_finite(v)
    elif isinstance(value, list):
        for v in value:
            assert_finite(v)
    elif isinstance(value, float):
        assert math.isfinite(value)
