"""Track initiation, simulation and evaluation (Mu et al., the secondary-processing
textbook, Konovalov).

The wire's settings become :class:`plotgate.core.initiation.InitiationConfig` (degrees
nowhere: the settings carry no angles), its scans become
:class:`plotgate.core.initiation.Scan` (each plot with its own sensor; Cartesian plots as
positions and covariances, polar plots as the ranges and azimuths measured), and the
typed ``state`` (:class:`plotgate.service.schemas.SessionState`, its types and magnitudes
checked by the schema) goes through :func:`plotgate.core.initiation.state_from_json`,
which holds every field to its invariants and names it (``state.tracks.misses`` with row
3: ``state.tracks.misses[3]``). The work is bounded by the state's ceilings: core stops at
the first scan after which more tracks live than a state may carry
(:data:`~plotgate.service.schemas.MAX_STATE_TRACKS`, fewer for long histories) and the
state a call returns is validated by the same schema on the way out; either refusal
names ``scans``, so every state answered is a state the next call takes.

Core errors name core arguments; :data:`INITIATE_FIELDS` and :data:`SCENARIO_FIELDS` map
them to the request. A plot's own covariance is checked before the scan is built
(:func:`plotgate.service.operations.plots.plot_arrays`) and named
``scans[i].plots[j].covariance`` (a polar plot: ``scans[i].plots[j]``).
"""

import math
from typing import Any

import numpy as np
from pydantic import ValidationError

from plotgate.core import ParameterError, PlotgateError
from plotgate.core.frames import wrap_angle
from plotgate.core.initiation import (
    InitiationConfig,
    InitiationState,
    Scan,
    ScanReport,
    cartesian_scan,
    polar_scan,
    state_from_json,
)
from plotgate.core.initiation import (
    initiate as core_initiate,
)
from plotgate.core.initiation.evaluate import Evaluation
from plotgate.core.initiation.evaluate import evaluate as core_evaluate
from plotgate.core.initiation.evaluate import sweep as core_sweep
from plotgate.core.initiation.existence import existence
from plotgate.core.initiation.scan import merged_scan
from plotgate.core.initiation.simulate import Scenario
from plotgate.core.initiation.simulate import simulate as core_simulate
from plotgate.core.initiation.state import PLOT_STRIDE
from plotgate.core.initiation.state_json import PlotBounds
from plotgate.core.validation import MAX_CONDITION
from plotgate.service.cluster import lazy_map
from plotgate.service.fields import FieldMap
from plotgate.service.operations.answers import checked
from plotgate.service.operations.plots import plot_arrays
from plotgate.service.schemas import (
    EvaluateRequest,
    EvaluateResult,
    InitiateRequest,
    InitiateResult,
    InitiationSettings,
    PolarPlot,
    ScanIn,
    ScanOutcome,
    ScenarioIn,
    SessionInitiators,
    SessionState,
    SessionTracks,
    SimulateRequest,
    SimulateResult,
)
from plotgate.service.schemas.common import MAX_DISTANCE, MIN_VARIANCE
from plotgate.service.schemas.initiation_state import (
    MAX_HISTORY_CELLS,
    MAX_STATE_INITIATORS,
    MAX_STATE_TRACKS,
    SessionHeldPlots,
)
from plotgate.service.schemas.solves import MAX_TIME

__all__ = [
    "EVALUATE_FIELDS",
    "PLOT_BOUNDS",
    "SCENARIO_FIELDS",
    "SIMULATE_FIELDS",
    "INITIATE_FIELDS",
    "evaluate",
    "initiate",
    "simulate",
]


PLOT_BOUNDS = PlotBounds(
    min_variance=MIN_VARIANCE / MAX_CONDITION,
    max_sigma=math.pi * MAX_DISTANCE,
    max_time=MAX_TIME,
)
"""What a plot on the wire can be, so what a state that comes back can hold: a plot's
covariance has an eigenvalue of at least MIN_VARIANCE (its larger one: a diagonal
element or a squared range sigma) over the condition bound, 10^-18 m^2; its range and
cross-range sigmas reach at most pi MAX_DISTANCE (a polar plot's 180 degrees at 10^9 m;
a Cartesian plot's at most sqrt(2) 10^9 m); scan times stay within MAX_TIME."""


def _config(settings: InitiationSettings) -> InitiationConfig:
    values = settings.model_dump()
    values["gate_widening"] = tuple(values["gate_widening"])
    return InitiationConfig(**values)


def _scan(i: int, scan: ScanIn) -> Scan:
    """Scan i as core takes it: Cartesian plots as positions and covariances, polar plots
    as the ranges and azimuths measured (azimuths beyond +-180 degrees wrapped), each
    plot's own covariance checked first."""
    z, R, sensor = plot_arrays(scan.plots, lambda j: f"scans[{i}].plots[{j}]")
    is_polar = np.array([isinstance(p, PolarPlot) for p in scan.plots], dtype=bool)
    polar_plots = [p for p in scan.plots if isinstance(p, PolarPlot)]
    measured = np.array([(p.r, p.az_deg, p.sigma_r, p.sigma_az_deg) for p in polar_plots])
    r, az_deg, sigma_r, sigma_az_deg = measured.reshape(-1, 4).T
    az = np.radians(az_deg)
    az = np.where(np.abs(az) <= np.pi, az, wrap_angle(az))
    rows = np.flatnonzero(~is_polar)
    try:
        cartesian = cartesian_scan(scan.t, z[rows], R[rows], sensor[rows])
        rows = np.flatnonzero(is_polar)
        polar = polar_scan(scan.t, r, az, sigma_r, np.radians(sigma_az_deg), sensor[rows])
    except PlotgateError as exc:  # named here: the error's index is the kind's, not the scan's
        where = (
            f"scans[{i}].plots" if exc.index is None else f"scans[{i}].plots[{rows[exc.index]}]"
        )
        raise type(exc)(f"scans[{i}].t" if exc.field == "t" else where, exc.reason) from exc
    return merged_scan(cartesian, polar, is_polar)


def _outcome(report: ScanReport) -> ScanOutcome:
    return ScanOutcome(
        scan=report.scan,
        t=report.t,
        associated=report.associated.tolist(),
        initiators=report.initiators,
        started=report.started.tolist(),
        confirmed=report.confirmed.tolist(),
        dropped=report.dropped.tolist(),
        reasons=report.reasons.tolist(),
    )


def _tracks(state: InitiationState, config: InitiationConfig) -> list[dict[str, Any]]:
    """The live tracks as wire objects (:class:`TrackOut`), validated with the answer."""
    tr = state.tracks
    plots = [
        [[int(p // PLOT_STRIDE), int(p % PLOT_STRIDE)] for p in row if p >= 0]
        for row in tr.plots.tolist()
    ]
    alive = existence(tr.score).tolist() if config.confirmation == "existence" else None
    return [
        {
            "id": i,
            "status": "confirmed" if c else "tentative",
            "position": x[:2],
            "velocity": x[2:],
            "covariance": P,
            "plots": p,
            "n_plots": n,
            "score": sc,
            "existence": alive[j] if alive is not None else None,
            "misses": m,
            "first_scan": f,
            "confirmed_scan": k if c else None,
        }
        for j, (i, c, x, P, p, n, sc, m, f, k) in enumerate(
            zip(
                tr.id.tolist(),
                tr.confirmed.tolist(),
                tr.x.tolist(),
                tr.P.tolist(),
                plots,
                tr.n.tolist(),
                tr.score.tolist(),
                tr.misses.tolist(),
                tr.first_scan.tolist(),
                tr.confirmed_scan.tolist(),
                strict=True,
            )
        )
    ]


def _answered(state: InitiationState) -> SessionState:
    """The wire state, refused (naming ``scans``) beyond the schema's ceilings."""
    try:
        return SessionState.model_validate(state.to_json())
    except ValidationError as exc:
        first = exc.errors(include_url=False)[0]
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first["loc"])
        raise ParameterError(
            "scans",
            f"would leave a state the next call could not take "
            f"back (state{where}: {first['msg']}); a state carries at "
            f"most {MAX_STATE_INITIATORS} initiators and "
            f"{MAX_STATE_TRACKS} tracks ({MAX_HISTORY_CELLS} history "
            "cells), its values within the schema's magnitudes",
        ) from None


@checked
def initiate(request: InitiateRequest) -> InitiateResult:
    """Run the request's scans through initiation, continuing its state."""
    config = _config(request.config)
    state = None
    if request.state is not None:  # the validated lists as they are: no copy of the state
        wire = request.state
        state = state_from_json(
            {
                **dict(wire),
                "initiators": dict(wire.initiators),
                "tracks": dict(wire.tracks),
                "plots": dict(wire.plots),
            },
            config,
            PLOT_BOUNDS,
        )
    scans = [_scan(i, s) for i, s in enumerate(request.scans)]
    most = min(MAX_STATE_TRACKS, MAX_HISTORY_CELLS // config.history)
    state, reports = core_initiate(state, scans, config, max_tracks=most)
    return InitiateResult.model_validate(
        {
            "state": _answered(state),
            "tracks": _tracks(state, config),
            "scans": [_outcome(r) for r in reports],
        }
    )


def _scenario(s: ScenarioIn) -> Scenario:
    return Scenario(
        x0=np.array([t.position for t in s.targets], dtype=float).reshape(-1, 2),
        v=np.array([t.velocity for t in s.targets], dtype=float).reshape(-1, 2),
        scans=s.scans,
        interval=s.interval,
        P_D=s.P_D,
        clutter=s.clutter,
        region=np.array(s.region),
        sensor=np.array(s.sensor),
        sigma_r=s.sigma_r,
        sigma_az=np.radians(s.sigma_az_deg),
    )


def _azimuth_deg(az: np.ndarray) -> np.ndarray:
    """Azimuths in degrees, those beyond +-360 (noise of a sigma_az up to 180 degrees
    added to atan2's (-180, 180]) wrapped to [-180, 180), as a plot takes them."""
    deg = np.degrees(az)
    wrapped: np.ndarray = np.where(np.abs(deg) <= 360.0, deg, np.mod(deg + 180.0, 360.0) - 180.0)
    return wrapped


@checked
def simulate(request: SimulateRequest) -> SimulateResult:
    """Seeded scans of a scenario, every plot labelled."""
    sim = core_simulate(_scenario(request.scenario), request.seed)
    scans = [
        ScanIn(
            t=s.t,
            plots=[
                PolarPlot(
                    frame="polar",
                    r=float(r),
                    az_deg=float(az),
                    sigma_r=float(sr),
                    sigma_az_deg=float(np.degrees(sa)),
                    sensor=tuple(c),
                )
                for r, az, sr, sa, c in zip(
                    s.r, _azimuth_deg(s.az), s.sigma_r, s.sigma_az, s.sensor.tolist(), strict=True
                )
            ],
        )
        for s in sim.scans
    ]
    return SimulateResult(
        scans=scans, labels=[lab.tolist() for lab in sim.labels], truth=sim.truth.tolist()
    )


def _point(ev: Evaluation) -> dict[str, Any]:
    """An evaluation's means as wire fields (NaN, from one run or no confirmation, as null)."""

    def number(x: float) -> float | None:
        return None if np.isnan(x) else x

    return {
        "confirmable": ev.ceiling,
        "mean_true": ev.mean_true,
        "se_true": number(ev.se_true),
        "mean_false": ev.mean_false,
        "se_false": number(ev.se_false),
        "mean_true_by_distance": ev.mean_true_by_distance,
        "mean_false_by_distance": ev.mean_false_by_distance,
        "mean_time_to_confirmation": number(ev.mean_time_to_confirmation),
    }


@checked
def evaluate(request: EvaluateRequest) -> EvaluateResult:
    """Monte Carlo of initiation on a scenario; with a sweep, on the same scans per value.

    The runs go to the open cluster, if any, once core has checked the request
    (:func:`plotgate.service.cluster.lazy_map`), with the same numbers bit for bit. A
    sweep's values reach core as sent: the request's validator has already checked each
    one strictly as its setting (``SweepIn.settings``: "0.9" is no number and 3.0 no
    integer), ``confirm`` as its k/m string.
    """
    scenario, config = _scenario(request.scenario), _config(request.config)
    sweep = request.sweep
    if sweep is None:
        ev = core_evaluate(
            scenario, config, request.runs, request.seed, request.distance, mapper=lazy_map
        )
        return EvaluateResult.model_validate(
            {"runs": ev.runs, "targets": ev.targets, **_point(ev)}
        )
    base, *curve = core_sweep(
        scenario,
        config,
        sweep.parameter,
        sweep.values,
        request.runs,
        request.seed,
        request.distance,
        baseline=True,
        mapper=lazy_map,
    )
    return EvaluateResult.model_validate(
        {
            "runs": base.runs,
            "targets": base.targets,
            **_point(base),
            "sweep": [
                {"value": v, **_point(ev)} for v, ev in zip(sweep.values, curve, strict=True)
            ],
        }
    )


_STATE_ROWS = (
    ("initiators", SessionInitiators),
    ("tracks", SessionTracks),
    ("plots", SessionHeldPlots),
)

INITIATE_FIELDS: FieldMap = {
    **{name: f"config.{name}" for name in InitiationSettings.model_fields},
    **{
        f"state.{part}.{name}": f"state.{part}.{name}[{{i}}]"
        for part, rows in _STATE_ROWS
        for name in rows.model_fields
    },
    "scans": "scans[{i}]",
}
"""Where core's errors on an ``initiation.initiate`` request point
(:mod:`plotgate.service.fields`): a setting to ``config.<name>``, a state row to its
field and row (``state.tracks.misses[3]``), a scan to ``scans[i]``. Every other error
already names its request path and is named as it is: the state's own fields
(``state.config_digest``), and a plot or scan time, named by :func:`_scan`
(``scans[0].plots[4].covariance``, ``scans[1].t``)."""

_SCENARIO_NAMES = {"x0": "targets", "v": "targets", "sigma_az": "sigma_az_deg"}

SCENARIO_FIELDS: FieldMap = {
    **{name: f"config.{name}" for name in InitiationSettings.model_fields},
    **{
        name: f"scenario.{_SCENARIO_NAMES.get(name, name)}"
        for name in Scenario.__dataclass_fields__
    },
}
"""Where core's errors on an ``initiation.simulate`` or ``initiation.evaluate`` request
point: a scenario argument to its ``scenario`` field (``x0`` and ``v`` to ``targets``), a
setting to ``config.<name>``; ``runs``, ``seed`` and ``distance`` are named as they are."""

SIMULATE_FIELDS: FieldMap = SCENARIO_FIELDS
"""Where core's errors on an ``initiation.simulate`` request point."""

EVALUATE_FIELDS: FieldMap = {**SCENARIO_FIELDS, "values": "sweep.values[{i}]"}
"""Where core's errors on an ``initiation.evaluate`` request point: as a simulation's, and
a sweep value that makes settings core refuses (``confirm`` 5/4) to ``sweep.values[i]``."""
