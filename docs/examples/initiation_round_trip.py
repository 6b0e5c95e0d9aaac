"""Track initiation in two calls, the first call's state sent back with the second, answers
what one call over every scan answers (docs/initiation.md).

Usage: python initiation_round_trip.py [URL]   (default http://127.0.0.1:8000)
"""

import sys

from plotgate.clients import Client

PLOT_COVARIANCE = [[40000.0, 0.0], [0.0, 40000.0]]  # m^2: 200 m sigma in x and y


def plot(x: float, y: float) -> dict:
    """A Cartesian plot in the radar frame (x east, y north, m)."""
    return {"frame": "cartesian", "x": x, "y": y, "covariance": PLOT_COVARIANCE}


# a target moving east at 25 m/s, and one clutter plot in the first scan
SCANS = [
    {"t": 0.0, "plots": [plot(5000.0, 10000.0), plot(9000.0, 2000.0)]},
    {"t": 1.0, "plots": [plot(5025.0, 10000.0)]},
    {"t": 2.0, "plots": [plot(5050.0, 10000.0)]},
]
CONFIG = {"v_max": 50.0}  # the largest target speed, m/s

with Client(sys.argv[1] if len(sys.argv) > 1 else "http://127.0.0.1:8000") as client:
    one = client.initiate({"config": CONFIG, "state": None, "scans": SCANS})
    first = client.initiate({"config": CONFIG, "state": None, "scans": SCANS[:2]})
    second = client.initiate({"config": CONFIG, "state": first.state, "scans": SCANS[2:]})

print(f"one call: {len(one.tracks)} track(s), statuses {[t.status for t in one.tracks]}")
print("two calls answer the same tracks:", second.tracks == one.tracks)
print("and the same state:", second.state == one.state)
