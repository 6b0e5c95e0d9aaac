"""The multistatic operations: position and trajectory solves, bounds, noise and the
accuracy study (Fadeev et al.)

Each declaration is the whole of one operation (:class:`~plotgate.service.schemas.Endpoint`):
its name, path and models, its handler and field map (named, imported on first use), its
work sizes and default caps, its description and example, its scene drawer and the
client's method. :mod:`plotgate.service.table` gathers every capability's declarations.
"""

from plotgate.service.schemas.crlb import CrlbRequest, CrlbResult
from plotgate.service.schemas.endpoints import Endpoint, Reference
from plotgate.service.schemas.noise import NoiseRequest, NoiseResult
from plotgate.service.schemas.position import PositionSolveRequest, PositionSolveResult
from plotgate.service.schemas.study import StudyRequest, StudyResult
from plotgate.service.schemas.trajectory import TrajectorySolveRequest, TrajectorySolveResult

__all__ = ["OPERATIONS"]

_SOLVES = "plotgate.service.operations.solves"
_STUDY = "plotgate.service.operations.study"
_SCENES = "plotgate.service.scenes.solves"

_TX = [0.0, 0.0]
_RX = [[10_000.0, 0.0], [0.0, 10_000.0], [-8000.0, -6000.0]]
_TIMES = [0.0, 1.0, 2.0, 3.0]
_SUMS = [  # |x(t) - rx| + |x(t) - tx|, x(t) = (3000, 4000) + (50, -20) t, m
    [13062.257748, 11708.203932, 19866.068747],
    [13023.195908, 11762.81763, 19903.960702],
    [12984.677262, 11818.154928, 19942.545883],
    [12946.697231, 11874.20777, 19981.818817],
]


def _study_range_sums(request: StudyRequest) -> int:
    """The range sums a study simulates and solves one by one. Memory: about 470 bytes each
    (2.4 million took 1.37 GB of RSS; the cap, 1.2 million, 809 MiB). Time: 1166 runs x 200
    samples x 3 receivers (700,000) took 2.9 s of CPU (``bench/bench_worst_requests.py``),
    so the cap is about 5 s."""
    return request.runs * len(request.sample_times) * len(request.receivers)


def _study_solve_work(request: StudyRequest) -> int:
    """The solves' work with many receivers: each solve of P pairs weighs its P x P
    covariance, so time and memory grow as P^2. 54 runs x 200 samples x 64 receivers (691,200
    range sums, under their cap) took 239 s and 2380 MiB of RSS on a shared machine, 54
    bytes a unit; 2 runs x 200 x 64 took 0.5 s of CPU. The default cap, 3,600,000 (the range
    sums' cap at 3 receivers), is about 1 s and 200 MiB."""
    return _study_range_sums(request) * len(request.receivers)


def _study_prefix_work(request: StudyRequest) -> int:
    """With ``tracks``, the work of every prefix's trajectory solve (runs x samples^2 x
    receivers^2; 0 without tracks). 55 runs x 200^2 x 3^2 (2e7) took 1.3 s of CPU, and so did
    2 runs x 1000^2 x 3^2 (``bench/bench_worst_requests.py``): the default cap, 6e7, is about
    4 s."""
    if not request.tracks:
        return 0
    return request.runs * len(request.sample_times) ** 2 * len(request.receivers) ** 2


POSITION = Endpoint(
    "solves.position",
    "/v1/solves/position",
    "Maximum-likelihood positions of a batch of multistatic range-sum problems, "
    "optionally with a closed-form solution",
    PositionSolveRequest,
    PositionSolveResult,
    slow=True,
    work={"problems": lambda r: len(r.problems)},
    handler=Reference(_SOLVES, "position"),
    fields=Reference(_SOLVES, "POSITION_FIELDS"),
    drawer=Reference(_SCENES, "position"),
    client_method="solve_position",
    description=(
        "Single-shot positions of a target from multistatic range sums l_k = |x - rx_k| + "
        "|x - tx_k| (m), after Fadeev, Myakinkov and Ogurtsov: the maximum-likelihood "
        "solution by weighted Gauss-Newton (eq. 6) with Levenberg-Marquardt step control, "
        "its covariance (H^T G H)^-1 (m^2), residuals, cost, a chi-square consistency test "
        "and, with three receivers in 2D, the alternative solution when it is also "
        "consistent; optionally the closed-form sum-range (spherical intersection) or "
        "difference-range (Chan-style) solution. Positions in m, 2D or 3D; a batch of "
        "independent problems, index i answering problems[i]."
    ),
    example_body={
        "problems": [{"range_sums": _SUMS[0], "transmitter": _TX, "receivers": _RX, "sigma": 0.5}],
        "method": "sum_range",
    },
)

TRAJECTORY = Endpoint(
    "solves.trajectory",
    "/v1/solves/trajectory",
    "Constant-velocity track from range sums at several sample times",
    TrajectorySolveRequest,
    TrajectorySolveResult,
    slow=True,
    work={"sample_times": lambda r: len(r.sample_times)},
    handler=Reference(_SOLVES, "trajectory"),
    fields=Reference(_SOLVES, "TRAJECTORY_FIELDS"),
    drawer=Reference(_SCENES, "trajectory"),
    client_method="solve_trajectory",
    description=(
        "A constant-velocity track (x0, v) fitted by maximum likelihood to range sums at "
        "several sample times (Fadeev et al., eq. 6 over a trajectory), with transmitter "
        "and receivers fixed, moving at constant velocity, or given per sample. Returns "
        "the state at the first sample time and the position with its covariance at any "
        "requested times. Positions in m, velocities in m/s, times in s."
    ),
    example_body={
        "sample_times": _TIMES,
        "range_sums": _SUMS,
        "transmitter": {"position": _TX},
        "receivers": [{"position": p} for p in _RX],
        "sigma": 0.5,
        "times": [1.5],
    },
)

CRLB = Endpoint(
    "solves.crlb",
    "/v1/solves/crlb",
    "Cramer-Rao bound of multistatic positioning, single shot or along a track",
    CrlbRequest,
    CrlbResult,
    slow=True,
    work={
        "targets": lambda r: len(r.targets or ()),
        "sample_times": lambda r: len(r.sample_times or ()),
    },
    handler=Reference(_SOLVES, "crlb"),
    fields=Reference(_SOLVES, "CRLB_FIELDS"),
    drawer=Reference(_SCENES, "crlb"),
    client_method="crlb",
    description=(
        "The Cramer-Rao bound of multistatic positioning (Fadeev et al., eq. 3): J = sum "
        "over samples and receivers of grad l grad l^T / sigma^2, single shot at each "
        "target position and accumulated along a track. Returns sigma_x, sigma_y (m) and "
        "the GDOP sqrt(trace(J^-1)) / sigma_ref, with sigma_ref the harmonic-mean sigma."
    ),
    example_body={
        "targets": [[3000.0, 4000.0], [-5000.0, 2000.0]],
        "transmitter": {"position": _TX},
        "receivers": [{"position": p} for p in _RX],
        "sigma": 0.5,
    },
)

NOISE = Endpoint(
    "solves.noise",
    "/v1/solves/noise",
    "Range-sum noise from quadratic fits, and sliding-window smoothing of coordinates",
    NoiseRequest,
    NoiseResult,
    slow=True,
    work={
        "sample_times": lambda r: len(r.sample_times),
        "sample_times x window": lambda r: len(r.sample_times) * (r.window or 0),
    },
    # one pseudo-inverse per sample over its window: time, not memory (core fits in
    # blocks); 1000 samples x a window of 1000 at degree 10 took 23 s on 2 loaded cores
    caps={"sample_times x window": 1_000_000},
    handler=Reference(_SOLVES, "noise"),
    fields=Reference(_SOLVES, "NOISE_FIELDS"),
    drawer=Reference(_SCENES, "noise"),
    client_method="estimate_noise",
    description=(
        "The range-sum noise estimated from the data (Fadeev et al., eq. 5): a quadratic "
        "(or higher-degree) fit of each range-sum series l_k(t) in sliding windows, with "
        "sigma^2 from the residuals over their degrees of freedom; and polynomial smoothing "
        "of solved coordinates in a sliding window. Range sums and sigmas in m, times in s."
    ),
    example_body={
        "sample_times": _TIMES,
        "range_sums": _SUMS,
        "degree": 2,
        "positions": [[3000.0, 4000.0], [3050.3, 3979.8], [3099.9, 3960.1], [3150.2, 3940.0]],
        "window": 3,
        "smoothing_degree": 1,
    },
)

STUDY = Endpoint(
    "solves.study",
    "/v1/solves/study",
    "Monte Carlo accuracy study of the multistatic solvers along a track (Fadeev "
    "et al., Fig. 3, curves 1-6)",
    StudyRequest,
    StudyResult,
    slow=True,
    work={
        "runs": lambda r: r.runs,
        "sample_times": lambda r: len(r.sample_times),
        "runs x sample_times x receivers": _study_range_sums,
        "runs x sample_times x receivers^2": _study_solve_work,
        "runs x sample_times^2 x receivers^2": _study_prefix_work,
    },
    caps={
        "runs x sample_times^2 x receivers^2": 60_000_000,
        "runs x sample_times x receivers^2": 3_600_000,
        "runs x sample_times x receivers": 1_200_000,
    },
    handler=Reference(_STUDY, "study"),
    fields=Reference(_STUDY, "STUDY_FIELDS"),
    drawer=Reference(_SCENES, "study"),
    client_method="accuracy_study",
    description=(
        "The Monte Carlo accuracy study of Fadeev et al., Fig. 3: along a constant-velocity "
        "target's track, `runs` seeded noisy range-sum series, and at every sample time "
        "the six curves (1 single-shot CRLB, 2 accumulated CRLB, 3 ML track, 4 ML single "
        "shot, 5 sum-range, 6 difference-range; RMSE per axis, m) with the diagnostics "
        "(Monte Carlo standard error, false minima, chi-square consistency) and the eq. 5 "
        "noise estimate. Seeded: the same request gives the same numbers. "
        "`plotgate study` judges the answer against the bounds."
    ),
    example_body={
        "transmitter": {"position": _TX},
        "receivers": [{"position": p} for p in _RX],
        "target": {"position": [3000.0, 4000.0], "velocity": [50.0, -20.0]},
        "sample_times": _TIMES,
        "sigma": 0.5,
        "runs": 20,
        "seed": 1,
    },
)

OPERATIONS = (
    POSITION,
    TRAJECTORY,
    CRLB,
    NOISE,
    STUDY,
)
