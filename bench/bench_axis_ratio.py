"""Cost of one unconditional gating probability against the axis ratio of B.

Run from the repository root::

    python bench/bench_axis_ratio.py

Konovalov's example (ring gate 100..500 m/s, tau 5 s, first mark 50 km north, sigma_az
0.5 deg, the area prior) with the range sigma swept from 200 m (B's axis ratio
sqrt(lambda_max / lambda_min) about 2, the paper's case) down to 1 mm (about 4 x 10^5),
then the azimuth sigma down to 1e-6 degrees; each probability through the service's
in-process path (``service.registry.execute``), timed once (the slow ones take minutes),
with the quadrature's gate node count (each gate node integrates the prior's heading).
The axis ratio is the work size ``mark.axis_ratio``
an operator may cap (``PLOTGATE_LIMITS``); the last rows time ``gates.design``, which
evaluates about twenty such probabilities. Prints a markdown table.
"""

from __future__ import annotations

import json
import platform
import sys
import time

import numpy as np
import scipy

import plotgate.core.gates.probability as gp
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.schemas import Mark

MARK = {"r": 50_000.0, "az_deg": 0.0, "sigma_r": 200.0, "sigma_az_deg": 0.5}
PRIOR = {"kind": "area", "v_min": 100.0, "v_max": 500.0}
CASES = [("sigma_r", v) for v in (200.0, 20.0, 1.0, 1e-3)] + [
    ("sigma_az_deg", v) for v in (0.05, 1e-3, 1e-6)
]
DESIGN_CASES = [("sigma_r", v) for v in (200.0, 20.0)]


def nodes_counted() -> list[int]:
    """Patch the panel rule to count the gate's (direction x radius) nodes; returns the
    counter. The heading nodes of each are built inside the compiled kernels."""
    count = [0]
    rule = gp.panel_rule

    def counting(edges: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
        x, w = rule(edges, m)
        if x.ndim == 3:
            count[0] += x.size
        return x, w

    gp.panel_rule = counting
    return count


def timed(name: str, body: dict) -> tuple[float, int, str]:
    start = time.perf_counter()
    outcome = execute(OPERATIONS[name], json.dumps(body).encode())
    return time.perf_counter() - start, outcome.status, outcome.content.decode()[:60]


def main() -> None:
    print(
        f"Python {sys.version.split()[0]}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}, {platform.machine()}\n"
    )
    count = nodes_counted()
    print("| operation | changed | axis ratio | seconds | gate nodes | status |")
    print("|---|---|---:|---:|---:|---|")
    for field, value in CASES:
        mark = dict(MARK, **{field: value})
        ratio = Mark(**mark).axis_ratio()
        count[0] = 0
        body = {
            "gate": {"kind": "ring", "v_min": 100.0, "v_max": 500.0},
            "mark": mark,
            "tau": 5.0,
            "prior": PRIOR,
        }
        seconds, status, _ = timed("gates.probability", body)
        print(
            f"| gates.probability | {field} = {value:g} | {ratio:.3g} | {seconds:.2f} | "
            f"{count[0]:.3g} | {status} |",
            flush=True,
        )
    for field, value in DESIGN_CASES:
        mark = dict(MARK, **{field: value})
        ratio = Mark(**mark).axis_ratio()
        count[0] = 0
        body = {
            "gate": {"kind": "expanded", "v_max": 300.0},
            "mark": mark,
            "tau": 5.0,
            "capture": 0.9,
            "prior": {"kind": "area", "v_min": 0.0, "v_max": 300.0},
            "P_D1": 0.99,
            "resolution": {"range": 500.0, "azimuth_deg": 1.5},
        }
        seconds, status, _ = timed("gates.design", body)
        print(
            f"| gates.design | {field} = {value:g} | {ratio:.3g} | {seconds:.2f} | "
            f"{count[0]:.3g} | {status} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
