"""Cost of the unconditional gating probability's requests against the axis ratio of B.

Run from the repository root::

    python bench/bench_axis_ratio.py [--ratios 2.18 10 26 70 436] [--budget 60]
    python bench/bench_axis_ratio.py --quick    # CI: ratios 2.18 and 26, gates.probability

Each operation's example request (``gates.probability``, ``gates.analysis``,
``gates.design``; for the first two also with the first-association window, the gate
with the most nodes) with the range sigma cut until B's axis ratio
sqrt(lambda_max / lambda_min) reaches each value (the azimuth sigma and the range stay the
example's: 0.5 deg at 50 km). Each request runs through the service's in-process path
(``service.registry.execute``, no caps), timed once and cold (no density table kept
from an earlier request), with the quadrature's gate node count (each gate node
integrates the prior's heading). The axis ratio is the work size ``mark.axis_ratio``
an operator may cap (``PLOTGATE_LIMITS``); the schema does not bound
it. Each operation first answers its example untimed (its lazy imports). Once a request
of an operation takes longer than ``--budget`` seconds, its larger ratios are not run
(they cost more). Prints a markdown table.

C, ``scipy.special.erf`` on 10^6 doubles, is timed in the same run (best of 20), and each
``gates.probability`` request at axis ratio 26 (when among ``--ratios``) ends as one
``SUMMARY {json}`` line in units of C, against the issue's aim of 3 C for every gate kind:
ring, combined, expanded and first-association, through the service's in-process path.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import platform
import sys
import time

import numpy as np
import scipy
from bench_probability import ERF_DOUBLES, best_time, gate_nodes, summary
from scipy import special

from plotgate.core.gates import heading
from plotgate.service.registry import OPERATIONS, execute
from plotgate.service.schemas import Mark
from plotgate.service.table import ENDPOINTS

FIRST_ASSOCIATION = {"kind": "first_association", "v_max": 500.0, "K_R": 3.0, "K_az": 3.0}
COMBINED = {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "P_G": 0.9}
EXPANDED = {"kind": "expanded", "v_max": 500.0, "p": 0.9}
REQUESTS = [
    ("gates.probability", None),
    ("gates.probability", COMBINED),
    ("gates.probability", EXPANDED),
    ("gates.probability", FIRST_ASSOCIATION),
    ("gates.analysis", None),
    ("gates.analysis", FIRST_ASSOCIATION),
    ("gates.design", None),
]


def at_ratio(name: str, gate: dict | None, ratio: float) -> dict:
    """The example of ``name`` (with ``gate``) with sigma_r set for B's axis ratio."""
    body = copy.deepcopy(ENDPOINTS[name].example)
    if gate is not None:
        body["gate"] = gate
    mark = body["mark"]
    cross = mark["r"] * math.radians(mark["sigma_az_deg"])  # m, across the line of sight
    mark["sigma_r"] = cross / ratio
    return body


def timed(name: str, body: dict) -> tuple[float, int]:
    """One request, cold: no density table kept from an earlier request."""
    heading.clear_tables()
    start = time.perf_counter()
    outcome = execute(OPERATIONS[name], json.dumps(body).encode())
    return time.perf_counter() - start, outcome.status


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ratios", type=float, nargs="+", default=[2.18, 10, 26, 70, 436])
    parser.add_argument("--budget", type=float, default=60.0)
    parser.add_argument(
        "--quick", action="store_true", help="CI: ratios 2.18 and 26, gates.probability only"
    )
    args = parser.parse_args()
    ratios = [2.18, 26.0] if args.quick else args.ratios
    requests = [r for r in REQUESTS if r[0] == "gates.probability"] if args.quick else REQUESTS
    C = best_time(lambda: special.erf(ERF_DOUBLES), repeats=20)
    print(
        f"Python {sys.version.split()[0]}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}, {platform.machine()}\n\n"
        f"C = scipy.special.erf on 10^6 doubles = {C * 1e3:.2f} ms (this run)\n"
    )
    rows = []
    with gate_nodes() as count:
        print("| operation | gate | sigma_r m | axis ratio | seconds | C | gate nodes | status |")
        print("|---|---|---:|---:|---:|---:|---:|---|")
        for name, gate in requests:
            timed(name, ENDPOINTS[name].example)  # untimed: the operation's lazy imports
            for ratio in ratios:
                body = at_ratio(name, gate, ratio)
                count[0] = 0
                seconds, status = timed(name, body)
                kind = body["gate"]["kind"]
                print(
                    f"| {name} | {kind} | {body['mark']['sigma_r']:.3g} "
                    f"| {Mark(**body['mark']).axis_ratio():.3g} | {seconds:.2f} "
                    f"| {seconds / C:.1f} | {count[0]:.3g} | {status} |",
                    flush=True,
                )
                if name == "gates.probability" and ratio == 26.0:
                    rows.append(
                        (
                            f"axis_ratio.26.{kind}",
                            f"gates.probability request, {kind} gate, axis ratio 26 "
                            "(the example's 50 km, 0.5 deg; sigma_r cut), in-process, cold",
                            f"C = scipy.special.erf on 10^6 doubles ({C * 1e3:.2f} ms, same run)",
                            f"{seconds / C:.2f} C",
                            "<= 3 C",
                            seconds <= 3.0 * C and status == 200,
                        )
                    )
                if seconds > args.budget:
                    break
    print()
    for fields in rows:
        summary(*fields)


if __name__ == "__main__":
    main()
