"""Track initiation, simulation and evaluation (seeds 002, 003, 000; DESIGN section 5).

The wire's settings become :class:`core.initiation.InitiationConfig` (degrees nowhere:
the settings carry no angles), its scans of Cartesian or polar plots become
:class:`core.initiation.Scan` (each plot with its own sensor, converted as the gate
operations do), and the opaque ``state`` object goes through
:func:`core.initiation.state_from_json`, which refuses a malformed or foreign one.

Core errors name core arguments; :func:`initiate_field` maps them to the request: a
setting to ``config.<name>``, ``state`` to ``state``, ``scans`` with an index to
``scans[i]``, and a plot error (``z``, ``R``) inside scan i to ``scans[i].plots[j]``.
"""

import numpy as np

from core import PlotgateError
from core.initiation import (
    InitiationConfig,
    InitiationState,
    Scan,
    ScanReport,
    cartesian_scan,
    state_from_json,
)
from core.initiation import (
    initiate as core_initiate,
)
from core.initiation.evaluate import evaluate as core_evaluate
from core.initiation.simulate import Scenario
from core.initiation.simulate import simulate as core_simulate
from core.initiation.state import PLOT_STRIDE
from service.operations.answers import checked
from service.operations.gates import _cartesian
from service.schemas import (
    EvaluateRequest,
    EvaluateResult,
    InitiateRequest,
    InitiateResult,
    InitiationSettings,
    PolarPlot,
    ScanIn,
    ScanOutcome,
    ScenarioIn,
    SimulateRequest,
    SimulateResult,
    TrackOut,
)

__all__ = ["evaluate", "initiate", "initiate_field", "scenario_field", "simulate"]


class _ScanError(PlotgateError):
    """A plot error inside scan ``scan`` (re-raised with the scan's index)."""

    def __init__(self, exc: PlotgateError, scan: int) -> None:
        super().__init__(exc.field, exc.reason, exc.index)
        self.scan = scan


def _config(settings: InitiationSettings) -> InitiationConfig:
    values = settings.model_dump()
    values["gate_widening"] = tuple(values["gate_widening"])
    return InitiationConfig(**values)


def _scan(i: int, scan: ScanIn) -> Scan:
    try:
        if not scan.plots:
            return cartesian_scan(scan.t, np.zeros((0, 2)), np.zeros((0, 2, 2)))
        z, R, sensor = _cartesian(scan.plots)
        return cartesian_scan(scan.t, z, R, sensor)
    except PlotgateError as exc:
        raise _ScanError(exc, i) from exc


def _outcome(report: ScanReport) -> ScanOutcome:
    return ScanOutcome(scan=report.scan, t=report.t, associated=report.associated.tolist(),
                       initiators=report.initiators, started=report.started.tolist(),
                       confirmed=report.confirmed.tolist(), dropped=report.dropped.tolist(),
                       reasons=report.reasons.tolist())


def _tracks(state: InitiationState) -> list[TrackOut]:
    tr = state.tracks
    out = []
    for i in range(tr.size):  # one wire object per live track
        plots = tr.plots[i][tr.plots[i] >= 0]
        out.append(TrackOut(
            id=int(tr.id[i]), status="confirmed" if tr.confirmed[i] else "tentative",
            position=tr.x[i, :2].tolist(), velocity=tr.x[i, 2:].tolist(),
            covariance=tr.P[i].tolist(),
            plots=[[int(p // PLOT_STRIDE), int(p % PLOT_STRIDE)] for p in plots],
            n_plots=int(tr.n[i]), misses=int(tr.misses[i]), first_scan=int(tr.first_scan[i]),
            confirmed_scan=int(tr.confirmed_scan[i]) if tr.confirmed[i] else None))
    return out


@checked
def initiate(request: InitiateRequest) -> InitiateResult:
    """Run the request's scans through initiation, continuing its state."""
    config = _config(request.config)
    state = None if request.state is None else state_from_json(request.state, config)
    scans = [_scan(i, s) for i, s in enumerate(request.scans)]
    state, reports = core_initiate(state, scans, config)
    return InitiateResult(state=state.to_json(), scans=[_outcome(r) for r in reports],
                          tracks=_tracks(state))


def initiate_field(request: InitiateRequest, exc: PlotgateError) -> str:
    """``config.<name>``, ``state``, ``scans[i]`` or ``scans[i].plots[j]``."""
    if isinstance(exc, _ScanError):
        where = f"scans[{exc.scan}]"
        if exc.field == "t":
            return f"{where}.t"
        return f"{where}.plots" if exc.index is None else f"{where}.plots[{exc.index}]"
    if exc.field == "scans":
        return "scans" if exc.index is None else f"scans[{exc.index}]"
    if exc.field == "state":
        return "state"
    return f"config.{exc.field}"


def _scenario(s: ScenarioIn) -> Scenario:
    return Scenario(x0=np.array([t.position for t in s.targets], dtype=float).reshape(-1, 2),
                    v=np.array([t.velocity for t in s.targets], dtype=float).reshape(-1, 2),
                    scans=s.scans, interval=s.interval, P_D=s.P_D, clutter=s.clutter,
                    region=np.array(s.region), sensor=np.array(s.sensor),
                    sigma_r=s.sigma_r, sigma_az=np.radians(s.sigma_az_deg))


def _azimuth_deg(az: np.ndarray) -> np.ndarray:
    """Azimuths in degrees, those beyond +-360 (noise of a sigma_az up to 180 degrees
    added to atan2's (-180, 180]) wrapped to [-180, 180), as a plot takes them."""
    deg = np.degrees(az)
    return np.where(np.abs(deg) <= 360.0, deg, np.mod(deg + 180.0, 360.0) - 180.0)


@checked
def simulate(request: SimulateRequest) -> SimulateResult:
    """Seeded scans of a scenario, every plot labelled."""
    sim = core_simulate(_scenario(request.scenario), request.seed)
    scans = [ScanIn(t=s.t, plots=[
        PolarPlot(frame="polar", r=float(r), az_deg=float(az), sigma_r=float(sr),
                  sigma_az_deg=float(np.degrees(sa)), sensor=tuple(c))
        for r, az, sr, sa, c in zip(s.r, _azimuth_deg(s.az), s.sigma_r, s.sigma_az,
                                    s.sensor.tolist(), strict=True)]) for s in sim.scans]
    return SimulateResult(scans=scans, labels=[lab.tolist() for lab in sim.labels],
                          truth=sim.truth.tolist())


@checked
def evaluate(request: EvaluateRequest) -> EvaluateResult:
    """Monte Carlo of initiation on a scenario."""
    ev = core_evaluate(_scenario(request.scenario), _config(request.config), request.runs,
                       request.seed, request.distance)
    ttc = ev.mean_time_to_confirmation
    return EvaluateResult(
        runs=ev.runs, targets=ev.targets, confirmable=ev.ceiling, mean_true=ev.mean_true,
        mean_false=ev.mean_false, mean_true_by_distance=ev.mean_true_by_distance,
        mean_false_by_distance=ev.mean_false_by_distance,
        mean_time_to_confirmation=None if np.isnan(ttc) else ttc)


def scenario_field(request: SimulateRequest | EvaluateRequest, exc: PlotgateError) -> str:
    """``scenario.<name>`` for a scenario error, ``config.<name>`` for a setting."""
    names = {"x0": "targets", "v": "targets", "sigma_az": "sigma_az_deg"}
    if exc.field in Scenario.__dataclass_fields__ or exc.field in names:
        return f"scenario.{names.get(exc.field, exc.field)}"
    if exc.field in ("runs", "seed", "distance"):
        return exc.field
    return f"config.{exc.field}"
