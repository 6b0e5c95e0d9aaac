"""One small, valid request per operation: the OpenAPI example and the fuzzers' seed.

Each example answers 200 in a few tens of milliseconds in-process (a test holds every
one to its request model and to a 200 answer). ``/docs`` shows it as the request body's
example, Schemathesis sends it in its examples and coverage phases, and the numeric
bounds test (``tests/service/test_numeric_bounds.py``) starts every mutation from it.

The numbers are the papers' worked cases where there is one: Konovalov's gate (tau 5 s,
speeds 100..500 m/s, first mark 50 km north, sigma_r 200 m, sigma_az 0.5 deg), Fadeev et
al.'s noise-free range sums of a target at (3000, 4000) m moving at (50, -20) m/s seen by a
transmitter at the origin and three receivers (rounded to 1 um, far below sigma 0.5 m),
Kvasnov's bearings either side of north. Monte Carlo sizes are kept small.
"""

from typing import Any

__all__ = ["EXAMPLES"]

_MARK = {"r": 50_000.0, "az_deg": 0.0, "sigma_r": 200.0, "sigma_az_deg": 0.5}
_RING = {"kind": "ring", "v_min": 100.0, "v_max": 500.0}
_PRIOR = {"kind": "area", "v_min": 100.0, "v_max": 500.0}
_RESOLUTION = {"range": 500.0, "azimuth_deg": 1.5}
_TX = [0.0, 0.0]
_RX = [[10_000.0, 0.0], [0.0, 10_000.0], [-8000.0, -6000.0]]
_TIMES = [0.0, 1.0, 2.0, 3.0]
_SUMS = [  # |x(t) - rx| + |x(t) - tx|, x(t) = (3000, 4000) + (50, -20) t, m
    [13062.257748, 11708.203932, 19866.068747],
    [13023.195908, 11762.81763, 19903.960702],
    [12984.677262, 11818.154928, 19942.545883],
    [12946.697231, 11874.20777, 19981.818817],
]


def _polar(r: float, az_deg: float) -> dict[str, Any]:
    return {"frame": "polar", "r": r, "az_deg": az_deg, "sigma_r": 200.0, "sigma_az_deg": 0.5}


def _cartesian(x: float, y: float) -> dict[str, Any]:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[40_000.0, 0.0], [0.0, 40_000.0]]}


EXAMPLES: dict[str, dict[str, Any]] = {
    "gates.test": {
        "gate": {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
        "first": _polar(50_000.0, 0.0),
        "candidates": [
            _polar(51_000.0, 0.5),
            _cartesian(0.0, 52_600.0),
            _cartesian(0.0, 60_000.0),
        ],
    },
    "gates.pairs": {
        "gate": {"kind": "ring", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
        "pairs": [
            {"first": _polar(50_000.0, 0.0), "second": _polar(51_000.0, 0.5)},
            {"first": _cartesian(0.0, 20_000.0), "second": _cartesian(300.0, 20_400.0)},
        ],
    },
    "gates.probability": {"gate": _RING, "mark": _MARK, "tau": 5.0, "prior": _PRIOR},
    "gates.probability_curve": {
        "gate": _RING,
        "mark": _MARK,
        "tau": 5.0,
        "against": "speed",
        "values": [100.0, 300.0, 500.0],
        "course_deg": 0.0,
    },
    "gates.analysis": {
        "gate": {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
        "mark": _MARK,
        "tau": 5.0,
        "resolution": _RESOLUTION,
        "false_alarm": 1e-4,
        "m_max": 3,
        "prior": _PRIOR,
        "P_D1": 0.9,
        "P_D2": 0.9,
    },
    "gates.design": {
        "gate": {"kind": "expanded", "v_max": 300.0},
        "mark": _MARK,
        "tau": 5.0,
        "capture": 0.9,
        "prior": {"kind": "area", "v_min": 0.0, "v_max": 300.0},
        "P_D1": 0.99,
        "P_D2": 1.0,
        "resolution": _RESOLUTION,
    },
    "solves.position": {
        "problems": [{"range_sums": _SUMS[0], "transmitter": _TX, "receivers": _RX, "sigma": 0.5}],
        "method": "sum_range",
    },
    "solves.trajectory": {
        "sample_times": _TIMES,
        "range_sums": _SUMS,
        "transmitter": {"position": _TX},
        "receivers": [{"position": p} for p in _RX],
        "sigma": 0.5,
        "times": [1.5],
    },
    "solves.crlb": {
        "targets": [[3000.0, 4000.0], [-5000.0, 2000.0]],
        "transmitter": {"position": _TX},
        "receivers": [{"position": p} for p in _RX],
        "sigma": 0.5,
    },
    "solves.noise": {
        "sample_times": _TIMES,
        "range_sums": _SUMS,
        "degree": 2,
        "positions": [[3000.0, 4000.0], [3050.3, 3979.8], [3099.9, 3960.1], [3150.2, 3940.0]],
        "window": 3,
        "smoothing_degree": 1,
    },
    "solves.study": {
        "transmitter": {"position": _TX},
        "receivers": [{"position": p} for p in _RX],
        "target": {"position": [3000.0, 4000.0], "velocity": [50.0, -20.0]},
        "sample_times": _TIMES,
        "sigma": 0.5,
        "runs": 20,
        "seed": 1,
    },
    "initiation.initiate": {
        "config": {"v_max": 50.0},
        "state": None,
        "scans": [
            {"t": 0.0, "plots": [_cartesian(5000.0, 10_000.0), _cartesian(9000.0, 2000.0)]},
            {"t": 1.0, "plots": [_cartesian(5025.0, 10_000.0)]},
            {"t": 2.0, "plots": [_cartesian(5050.0, 10_000.0)]},
        ],
    },
    "initiation.simulate": {"scenario": {"scans": 4, "clutter": 5.0}, "seed": 1},
    "initiation.evaluate": {"scenario": {"scans": 4, "clutter": 5.0}, "runs": 5, "seed": 1},
    "identification.pair": {
        "passive_bearings_deg": [359.8, 0.1, 359.9, 0.2, 0.0, 359.7],
        "active_bearings_deg": [0.1, 359.95],
        "delta_deg": 0.5,
        "beta_max": 0.05,
    },
    "identification.picture": {
        "passive_deg": [[10.1, 9.9, 10.0, 10.2], [45.0, 45.3, 44.8, 45.1]],
        "active_deg": [[45.1, 45.0], [10.05, 9.95]],
        "sigma_deg": 0.2,
    },
    "identification.simulate": {"n": 50, "m": 5, "sigma_deg": 1.0, "runs": 500, "seed": 1},
}
"""Operation name -> a valid request body (JSON-ready)."""
