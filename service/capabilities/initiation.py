"""The track-initiation operations: initiate, simulate scans, evaluate by Monte Carlo

Each declaration is the whole of one operation (:class:`~plotgate.service.schemas.Endpoint`):
its name, path and models, its handler and field map (named, imported on first use), its
work sizes and default caps, its description and example, its scene drawer and the
client's method. :mod:`plotgate.service.table` gathers every capability's declarations.
"""

import math
from typing import Any

from plotgate.service.schemas.endpoints import Endpoint, Reference
from plotgate.service.schemas.initiation import (
    EvaluateRequest,
    EvaluateResult,
    InitiateRequest,
    InitiateResult,
    SimulateRequest,
    SimulateResult,
)

__all__ = ["CLUSTER_EVALUATION_WORK", "EVALUATION_WORK_CAP", "OPERATIONS"]

_INITIATION = "plotgate.service.operations.initiation"
_SCENES = "plotgate.service.scenes.initiation"

EVALUATION_WORK_CAP = 1_200_000
"""Default cap of ``initiation.evaluate``'s ``runs x scans x plots``, plot-equivalents
(:meth:`~plotgate.service.schemas.EvaluateRequest.work`): about 6.5 s on one core."""
CLUSTER_EVALUATION_WORK = 200_000_000
"""Its ceiling on a cluster of any size: about 18 core-minutes of work. What the service
gathers is one score a run and rule, at most 10^4 runs x 51 rules (the schema's bounds),
a few hundred bytes each; the plots stay on the workers (``bench/HISTORY.md`` measures the
service's peak RSS during a 10^4-run evaluation on a cluster)."""


def _cartesian(x: float, y: float) -> dict[str, Any]:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[40_000.0, 0.0], [0.0, 40_000.0]]}


INITIATE = Endpoint(
    "initiation.initiate",
    "/v1/initiation/initiate",
    "Start and confirm tracks from scans of plots in clutter, continuing a state",
    InitiateRequest,
    InitiateResult,
    slow=True,
    work={
        "scans": lambda r: len(r.scans),
        "scans.plots": lambda r: max((len(s.plots) for s in r.scans), default=0),
        "state": lambda r: 0 if r.state is None else r.state.size(),
    },
    handler=Reference(_INITIATION, "initiate"),
    fields=Reference(_INITIATION, "INITIATE_FIELDS"),
    drawer=Reference(_SCENES, "initiate"),
    client_method="initiate",
    description=(
        "Starts and confirms tracks from scans of plots in clutter, statelessly: the "
        "answer's `state` goes back with the next call's scans. Capture of a second plot "
        "in a ring, expanded or combined gate (Konovalov) within 2/N scans or T seconds, "
        "tentative tracks predicted at constant velocity and gated by chi-square (Kalman "
        "or the alpha-beta smoother of the secondary-processing textbook), and "
        "confirmation by k/m logic or by the sequential track score (Wald's thresholds "
        "from `false_confirmation` and `true_deletion`). The polar mode is Mu et al.'s "
        "method: sector gates (eq. 1-4), range-only extrapolation and the radial "
        "acceleration check. Plots in m (Cartesian) or m and degrees (polar), times in s."
    ),
    example_body={
        "config": {"v_max": 50.0},
        "state": None,
        "scans": [
            {"t": 0.0, "plots": [_cartesian(5000.0, 10_000.0), _cartesian(9000.0, 2000.0)]},
            {"t": 1.0, "plots": [_cartesian(5025.0, 10_000.0)]},
            {"t": 2.0, "plots": [_cartesian(5050.0, 10_000.0)]},
        ],
    },
)

SIMULATE = Endpoint(
    "initiation.simulate",
    "/v1/initiation/simulate",
    "Seeded scans of targets in Poisson clutter, every plot labelled",
    SimulateRequest,
    SimulateResult,
    slow=True,
    work={"scenario.scans": lambda r: r.scenario.scans},
    handler=Reference(_INITIATION, "simulate"),
    fields=Reference(_INITIATION, "SIMULATE_FIELDS"),
    drawer=Reference(_SCENES, "simulate"),
    client_method="simulate_scans",
    description=(
        "Seeded scans of targets in Poisson clutter, every plot labelled with its source "
        "(a target's index, or -1 for clutter), and the true positions. The default is Mu "
        "et al.'s scenario: five ground targets at 25 m/s, radar at the origin, a 15 km "
        "square, P_D = 0.8, sigma_r = 5 m, sigma_az = 0.2 degrees, 1 s scans. Positions "
        "in m, times in s; the same seed gives the same scans."
    ),
    example_body={"scenario": {"scans": 4, "clutter": 5.0}, "seed": 1},
)

EVALUATE = Endpoint(
    "initiation.evaluate",
    "/v1/initiation/evaluate",
    "Monte Carlo of track initiation: targets initiated, false tracks",
    EvaluateRequest,
    EvaluateResult,
    slow=True,
    work={
        "runs": lambda r: r.runs,
        "scenario.scans": lambda r: r.scenario.scans,
        "scenario.clutter": lambda r: math.ceil(r.scenario.clutter),
        "sweep.values": lambda r: 0 if r.sweep is None else len(r.sweep.values),
        "runs x scans x plots": EvaluateRequest.work,
    },
    # plot-equivalents of about 5.4 us on one core (EvaluateRequest.work): 6.5 s;
    # a cluster takes 30 times as many per worker thread, up to the schema's ceiling
    caps={"runs x scans x plots": EVALUATION_WORK_CAP},
    cluster_caps={"runs x scans x plots": CLUSTER_EVALUATION_WORK},
    handler=Reference(_INITIATION, "evaluate"),
    fields=Reference(_INITIATION, "EVALUATE_FIELDS"),
    drawer=Reference(_SCENES, "evaluate"),
    client_method="evaluate_initiation",
    description=(
        "A Monte Carlo of track initiation on a simulated scenario (Mu et al.'s by "
        "default): per run, targets initiated and false tracks, scored by plot labels (a "
        "confirmed track is true when more than half of its plots come from one target "
        "not yet counted), with the means, their standard errors, the by-distance score "
        "and the time to confirmation. With `sweep`, one operating point per value of a "
        "setting, all on the same simulated scans. Seeds are spawned per run, so the "
        "numbers are the same in-process and on any Dask cluster."
    ),
    example_body={"scenario": {"scans": 4, "clutter": 5.0}, "runs": 5, "seed": 1},
)

OPERATIONS = (
    INITIATE,
    SIMULATE,
    EVALUATE,
)
