"""Wire models of track initiation (Mu et al.; the secondary-processing textbook; Konovalov).

Operations:

- ``initiation.initiate``: scans of plots (and the state of the previous call) in; the
  next state, what each scan did, and the tracks out. The state
  (:class:`~plotgate.service.schemas.initiation_state.SessionState`) is a typed, versioned JSON
  object bound to the settings that made it: send it back unchanged with the next scans
  and the same ``config``; a malformed, foreign or inconsistent state answers 422 naming
  its own field (``state.tracks.misses[3]``).
- ``initiation.simulate``: seeded scans of a scenario (targets, P_D, Poisson clutter,
  polar noise), every plot labelled with its source.
- ``initiation.evaluate``: Monte Carlo of initiation on a scenario: mean targets
  initiated, mean false tracks, time to confirmation.

Angles on the wire are degrees (``*_deg``); everything else SI.
"""

import math
import re
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError, model_validator

from plotgate.service.schemas.common import (
    MAX_DISTANCE,
    MAX_PLOTS,
    Loc,
    Plot,
    Position,
    Schema,
    invalid,
)
from plotgate.service.schemas.initiation_state import MAX_HISTORY, SessionState
from plotgate.service.schemas.solves import Time

__all__ = [
    "MAX_EVALUATION_PLOTS",
    "RUN_COST",
    "MAX_GATE_CLUTTER",
    "MAX_SCANS",
    "EvaluateRequest",
    "EvaluateResult",
    "EvaluationMeans",
    "InitiateRequest",
    "InitiateResult",
    "InitiationSettings",
    "ScanIn",
    "ScanOutcome",
    "ScenarioIn",
    "SimulateRequest",
    "SweepIn",
    "SweepPoint",
    "SimulateResult",
    "TargetIn",
    "TrackOut",
]

MAX_SCANS = 1000
"""Most scans of one initiate call or one simulated scenario."""
MAX_EVALUATION_PLOTS = 100_000_000
"""Most plots an evaluation may simulate and initiate, runs x scans x (clutter + targets) x
evaluations (1 + sweep values), on a Dask cluster of any size. The work size
``runs x scans x plots`` (:meth:`EvaluateRequest.work`) has caps far lower by default."""
RUN_COST = 200
"""What one run costs besides its plots, in plot-equivalents (:meth:`EvaluateRequest.work`):
2000 runs of one scan and one plot took as long as 230,000 plots at clutter 250 in the
same run (115 a run), rounded up."""
GATE_CLUTTER_COST = 30.0
"""The extra cost of a plot per expected clutter plot in a capture gate
(:meth:`ScenarioIn.gate_clutter`): the tentative tracks a plot starts or feeds grow with it.
Measured, one core: 5.4 us a plot at Mu et al.'s clutter 250 (0.009 plots a gate), 59 us at
clutter 10,000 (0.35 a gate), 11x, so 1 + 30 x 0.35."""
MODE_COST = {"cartesian": 1.0, "polar": 2.0}
"""The cost of a plot in each mode, relative to the Cartesian logic: Mu et al.'s polar
method took twice as long on the same scans (200 runs at clutter 250, in one run)."""
CONFIRMATION_COST = {"k_of_m": 1.0, "score": 2.0, "existence": 2.0}
"""The cost of a plot under each confirmation rule, relative to k/m. The score path (its
maximum-likelihood gates, every plot no confirmed track holds an initiator living out its
window) took 1.73-2.00x the k/m path's time a run, Mu et al.'s scenario at clutter 250 with
the README's score configuration (bench/HISTORY.md, issue 35). Existence (IPDA) weighs every
plot of every tentative track's gate and mixes the updates: 12.7 us a plot against k/m's
7.0 (one core, a loaded machine, 200 runs at clutter 250), 1.8x, rounded up (issue 38)."""
MAX_SPEED = 1e6
"""Largest |velocity component| of a simulated target, m/s."""
MAX_GATE_CLUTTER = 1.0
"""Most expected clutter plots in one capture gate of an evaluation
(:meth:`ScenarioIn.gate_clutter`). Above one, every plot's capture gate holds a false plot
on average, so the tentative tracks branch faster than they die: their number grows scan by
scan and the evaluation ends, after seconds and gigabytes, in core's refusal of a tangle
too large to assign. The rule refuses such a scenario from the request, before any work
(measured with the default scenario and rules, 4 scans, one run: clutter 30,000 per scan,
1.05 plots per gate, already takes 7.5 s and 726 MB for 31,380 false tracks)."""


class InitiationSettings(Schema):
    """The rules of initiation (defaults: Cartesian logic, ring capture 2/2, 3/4, l = 2).

    Field for field core's ``InitiationConfig``, and the service passes them to it by
    name. The two are written out, not derived from each other: this model adds what
    only the wire has (descriptions, each setting's ceiling on the work of one request,
    JSON types) and schemas do not import core, while core's config is a plain frozen
    dataclass with no pydantic in it. A test
    (``tests/service/test_initiation_api.py``) holds them equal: the same names in the
    same order, the same defaults, the same choices, and every lower bound (and the
    probabilities' upper bounds) the same, listing the ceilings and floors only the wire
    has.
    """

    mode: Literal["cartesian", "polar"] = Field(
        default="cartesian",
        description="cartesian: the logic method (capture gate, "
        "constant-velocity filter, chi-square gates); polar: Mu et al.'s method (sector "
        "windows, range-only extrapolation, the acceleration check).",
    )
    v_min: float = Field(default=0.0, ge=0, le=1e6, description="Smallest target speed, m/s.")
    v_max: float = Field(default=50.0, gt=0, le=1e6, description="Largest target speed, m/s.")
    capture_gate: Literal["ring", "expanded", "combined"] = Field(
        default="ring", description="Cartesian capture gate about an initiator (Konovalov)."
    )
    capture_P_G: float = Field(
        default=0.99, gt=0, lt=1, description="Combined gate: ellipse-stage gating probability."
    )
    capture_p: float = Field(
        default=0.95, gt=0, lt=1, description="Expanded gate: probability of its coefficient K_g."
    )
    capture_scans: int = Field(default=2, ge=2, le=100, description="Criterion 2/N: N.")
    capture_time: float | None = Field(
        default=None,
        gt=0,
        le=1e6,
        description="Criterion 2/T: T in seconds, instead of 2/N; null: use 2/N.",
    )
    association: Literal["branch", "nearest"] = Field(
        default="branch",
        description="branch: every plot in a capture gate starts a tentative track (the "
        "secondary-processing textbook, approach 1); nearest: only the nearest one.",
    )
    filter: Literal["kalman", "alpha_beta"] = Field(
        default="kalman",
        description="Track filter: Kalman, or the secondary-processing textbook's alpha-beta.",
    )
    q: float = Field(
        default=1.0, gt=0, le=1e6, description="Kalman white-acceleration noise, m^2/s^3."
    )
    alpha_min: float = Field(default=0.2, gt=0, le=1, description="Alpha-beta: alpha floor.")
    beta_min: float = Field(default=0.05, gt=0, le=1, description="Alpha-beta: beta floor.")
    gate_P_G: float = Field(
        default=0.99, gt=0, lt=1, description="Gating probability of the track gates."
    )
    gate_widening: list[float] = Field(
        default=[1.0, 2.0, 4.0],
        min_length=1,
        max_length=10,
        description="Gate threshold factors after 0, 1, 2... misses in a row (the "
        "secondary-processing textbook's narrow, medium and wide gates); each >= 1, "
        "non-decreasing.",
    )
    confirm_k: int = Field(
        default=3,
        ge=1,
        le=100,
        description="Confirmation k of k/m; under score confirmation, the fewest plots a "
        "track confirms with.",
    )
    confirm_m: int = Field(default=4, ge=1, le=100, description="Confirmation m of k/m.")
    drop_misses: int = Field(
        default=2, ge=1, le=100, description="l of k/m - l: misses in a row that drop a track."
    )
    K_R: float | None = Field(
        default=None,
        ge=0.01,
        le=100,
        description="Polar range-window coefficient; null: from gate_P_G.",
    )
    K_az: float | None = Field(
        default=None,
        ge=0.01,
        le=100,
        description="Polar azimuth-window coefficient; null: from gate_P_G.",
    )
    a_max: float = Field(
        default=10.0, gt=0, le=1e4, description="Polar mode: largest radial acceleration, m/s^2."
    )
    K_A: float = Field(
        default=3.0,
        gt=1,
        le=100,
        description="Polar mode: factor (> 1) of the acceleration check.",
    )
    history: int = Field(
        default=8,
        ge=2,
        le=MAX_HISTORY,
        description="Plots remembered per track (>= confirm_m and >= 2).",
    )
    confirmation: Literal["k_of_m", "score", "existence"] = Field(
        default="k_of_m",
        description="k_of_m: confirm_k plots within the first confirm_m scans; score: the "
        "sequential log-likelihood-ratio track score (Blackman and Popoli, ch. 6) reaches "
        "ln((1 - true_deletion) / false_confirmation) with at least confirm_k plots, and a "
        "tentative track at or below "
        "ln(true_deletion / (1 - false_confirmation)) is dropped (Wald's test); existence "
        "(IPDA, Musicki, Evans and Stankovic 1994; cartesian mode): a tentative track's "
        "probability of existence, updated from every plot in its gate, reaches "
        "existence_confirm with at least confirm_k plots, and at or below existence_delete "
        "the track is dropped.",
    )
    P_D: float = Field(
        default=0.9, gt=0, lt=1, description="Score: a target's detection probability per scan."
    )
    clutter_density: float | None = Field(
        default=None,
        gt=0,
        le=1e6,
        description="Score: false plots per m^2 per scan; null: each scan's plot count over "
        "surveillance_area.",
    )
    surveillance_area: float | None = Field(
        default=None,
        gt=0,
        le=1e24,
        description="Score: the area the scans cover, m^2 (needed when clutter_density is null).",
    )
    new_target_density: float = Field(
        default=1e-8, gt=0, le=1e6, description="Score: new targets per m^2 per scan."
    )
    false_confirmation: float = Field(
        default=1e-3,
        gt=0,
        lt=1,
        description="Score: alpha, the wanted probability of confirming a false track.",
    )
    true_deletion: float = Field(
        default=0.1,
        gt=0,
        lt=1,
        description="Score: beta, the wanted probability of dropping a true track "
        "(false_confirmation + true_deletion < 1).",
    )
    survival: float = Field(
        default=0.98,
        ge=0,
        le=1,
        description="Existence: p11, the probability that a target still exists a scan "
        "later (the Markov chain of existence).",
    )
    existence_birth: float = Field(
        default=0.0,
        ge=0,
        le=1,
        description="Existence: p21, the probability that a track which is not a target's "
        "becomes one a scan later.",
    )
    existence_confirm: float = Field(
        default=0.99,
        gt=0,
        lt=1,
        description="Existence: a tentative track confirms at this probability of existence.",
    )
    existence_delete: float = Field(
        default=0.02,
        gt=0,
        lt=1,
        description="Existence: a tentative track is dropped at or below this probability of "
        "existence (< existence_confirm).",
    )


class ScanIn(Schema):
    """One scan: its time and plots (each with its own sensor position)."""

    t: Time = Field(description="Scan time, s; scans come in time order.")
    plots: list[Plot] = Field(max_length=MAX_PLOTS, description="The scan's plots.")


class InitiateRequest(Schema):
    """Scans to run through initiation, continuing ``state`` when given."""

    config: InitiationSettings = Field(
        default=InitiationSettings(), description="The rules; the same for a whole session."
    )
    state: SessionState | None = Field(
        default=None,
        description="The state returned by the previous call, unchanged; null to start a session.",
    )
    scans: list[ScanIn] = Field(
        min_length=1, max_length=MAX_SCANS, description="The next scans, in time order."
    )

    @model_validator(mode="after")
    def _total(self) -> "InitiateRequest":
        total = sum(len(s.plots) for s in self.scans)
        if total > MAX_PLOTS:
            raise invalid(
                "InitiateRequest",
                [
                    (
                        ("scans",),
                        f"carry {total} plots in all; at most {MAX_PLOTS} per request",
                        total,
                    )
                ],
            )
        return self


DropReason = Literal["misses", "window", "acceleration", "speed", "pruned", "score", "existence"]


class ScanOutcome(Schema):
    """What one scan did."""

    scan: int = Field(description="The scan's number in the session (0 for the first).")
    t: float = Field(description="Its time, s.")
    associated: list[int] = Field(
        description="Per plot: the id of the track it updated or started, -1 if none."
    )
    initiators: int = Field(description="Plots that became initiators.")
    started: list[int] = Field(description="Ids of tentative tracks started.")
    confirmed: list[int] = Field(description="Ids of tracks confirmed.")
    dropped: list[int] = Field(description="Ids of tracks dropped.")
    reasons: list[DropReason] = Field(
        description="Why each was dropped: misses in a row, k out of reach in m, the polar "
        "acceleration check, a speed beyond v_max by more than 6 of its sigmas, sharing two "
        "plots with a confirmed track, a score at or below the deletion threshold, a "
        "probability of existence at or below existence_delete."
    )


class TrackOut(Schema):
    """A live track after the last scan."""

    id: int = Field(description="Track id, unique in the session.")
    status: Literal["tentative", "confirmed"] = Field(description="Tentative or confirmed.")
    position: list[float] = Field(description="[x, y] at the last scan, m.")
    velocity: list[float] = Field(description="[vx, vy], m/s.")
    covariance: list[list[float]] = Field(description="4 x 4 covariance of [x, y, vx, vy].")
    plots: list[Annotated[list[int], Field(min_length=2, max_length=2)]] = Field(
        description="Its most recent plots (up to config.history), oldest first, as "
        "[scan number, plot index in that scan]."
    )
    n_plots: int = Field(description="Plots taken so far.")
    score: float = Field(
        description="Track score, the log-likelihood ratio of target against clutter "
        "(config.confirmation score; 0 under k_of_m)."
    )
    existence: float | None = Field(
        default=None,
        description="Probability of existence (config.confirmation existence; its score "
        "is the log-odds, ln(P / (1 - P))); null under the other confirmations.",
    )
    misses: int = Field(description="Misses in a row.")
    first_scan: int = Field(description="Scan number of its first plot.")
    confirmed_scan: int | None = Field(description="Scan number of confirmation, or null.")


class InitiateResult(Schema):
    """The next state, the scans' outcomes and the live tracks."""

    state: SessionState = Field(description="Send back with the next scans.")
    scans: list[ScanOutcome] = Field(description="One per scan of the request.")
    tracks: list[TrackOut] = Field(description="The live tracks after the last scan.")


Speed = Annotated[float, Field(ge=-MAX_SPEED, le=MAX_SPEED)]
Coordinate = Annotated[float, Field(ge=-MAX_DISTANCE, le=MAX_DISTANCE)]


class TargetIn(Schema):
    """A constant-velocity target."""

    position: Position = Field(description="Position at the first scan, m.")
    velocity: tuple[Speed, Speed] = Field(
        description="Velocity [vx, vy], m/s; |component| <= 1e6."
    )


class ScenarioIn(Schema):
    """Targets, one radar and Poisson clutter (Mu et al.'s test by default)."""

    targets: list[TargetIn] = Field(
        default=[
            TargetIn(position=(5000.0 + 1000.0 * i, 10000.0 - 1000.0 * i), velocity=(25.0, 0.0))
            for i in range(5)
        ],
        max_length=1000,
        description="The targets (default: Mu et al.'s five).",
    )
    scans: int = Field(default=4, ge=1, le=MAX_SCANS, description="Number of scans.")
    interval: float = Field(default=1.0, gt=0, le=1e6, description="Time between scans, s.")
    P_D: float = Field(default=0.8, ge=0, le=1, description="Detection probability.")
    clutter: float = Field(
        default=20.0, ge=0, le=MAX_PLOTS, description="Mean clutter plots per scan (Poisson)."
    )
    region: tuple[Coordinate, Coordinate, Coordinate, Coordinate] = Field(
        default=(0.0, 15000.0, 0.0, 15000.0),
        description="Clutter rectangle (x_min, x_max, y_min, y_max), m; |coordinate| <= 1e9.",
    )
    sensor: Position = Field(default=(0.0, 0.0), description="Radar position, m.")
    sigma_r: float = Field(
        default=5.0,
        ge=1e-3,
        le=MAX_DISTANCE,
        description="Range sigma, m, from 1 mm (as a plot's).",
    )
    sigma_az_deg: float = Field(
        default=0.2,
        ge=1e-6,
        le=180,
        description="Azimuth sigma, degrees, from 1e-6 (as a plot's).",
    )

    def plots(self) -> float:
        """Expected plots of the whole scenario (for the work limits)."""
        return self.scans * (self.clutter + len(self.targets))

    def gate_clutter(self, config: "InitiationSettings") -> float:
        """Expected clutter plots in the capture gate ``config`` opens about a plot on the
        next scan: the clutter density times the ring between ``v_min`` and ``v_max`` times
        one interval, pi (v_max^2 - v_min^2) T^2.

        The ring without its noise margin is the least area any capture gate covers (the
        expanded and combined gates contain it; the polar sector window, 2 v_max T by
        2 v_max T, is larger), and a window of two or more scans only widens it, so this
        undercounts: a scenario refused by it is dense under every rule. Clutter in a
        rectangle of no area is infinitely dense.
        """
        x_min, x_max, y_min, y_max = self.region
        area = (x_max - x_min) * (y_max - y_min)
        if self.clutter == 0:
            return 0.0
        if area <= 0:
            return math.inf
        ring = math.pi * (config.v_max**2 - config.v_min**2) * self.interval**2
        return self.clutter / area * ring

    @model_validator(mode="after")
    def _in_reach(self) -> "ScenarioIn":
        """Every plot the scenario draws must be one a plot schema takes: within 1e9 m of
        the sensor. A target's range is largest at its first or last scan (it moves in a
        straight line) and must leave 10 sigma_r for the noise (a draw beyond has
        probability 1e-23); the clutter rectangle's farthest corner must be within reach."""
        sx, sy = self.sensor
        x_min, x_max, y_min, y_max = self.region
        far = max(math.hypot(x - sx, y - sy) for x in (x_min, x_max) for y in (y_min, y_max))
        errors: list[tuple[Loc, str, Any]] = []
        if far > MAX_DISTANCE:
            errors.append(
                (
                    ("region",),
                    f"reaches {far:.6g} m from the sensor; plots must lie "
                    f"within {MAX_DISTANCE:g} m of it",
                    list(self.region),
                )
            )
        span = self.interval * (self.scans - 1)
        for i, target in enumerate(self.targets):
            (x, y), (vx, vy) = target.position, target.velocity
            reach = max(
                math.hypot(x - sx, y - sy), math.hypot(x + vx * span - sx, y + vy * span - sy)
            )
            if reach + 10.0 * self.sigma_r > MAX_DISTANCE:
                errors.append(
                    (
                        ("targets", i),
                        f"is {reach:.6g} m from the sensor within the "
                        f"scans; with 10 sigma_r of noise its plots must stay within "
                        f"{MAX_DISTANCE:g} m",
                        None,
                    )
                )
                break
        if errors:
            raise invalid("ScenarioIn", errors)
        return self


class SimulateRequest(Schema):
    """A scenario and the seed of its draw."""

    scenario: ScenarioIn = Field(default=ScenarioIn(), description="The scenario.")
    seed: int = Field(default=0, ge=0, le=2**63 - 1, description="Seed of the draw.")

    @model_validator(mode="after")
    def _size(self) -> "SimulateRequest":
        if self.scenario.plots() > MAX_PLOTS:
            raise invalid(
                "SimulateRequest",
                [
                    (
                        ("scenario",),
                        f"expects {self.scenario.plots():.0f} plots; at most "
                        f"{MAX_PLOTS} per request",
                        self.scenario.plots(),
                    )
                ],
            )
        return self


class SimulateResult(Schema):
    """Simulated scans (polar plots) ready for ``initiation.initiate``, and the truth."""

    scans: list[ScanIn] = Field(description="The scans, plots in random order.")
    labels: list[list[int]] = Field(description="Per scan and plot: target index or -1.")
    truth: list[list[Annotated[list[float], Field(min_length=2, max_length=2)]]] = Field(
        description="Per scan, every target's true position, m."
    )


SWEEP_PARAMETERS = (
    "confirm",
    *(name for name in InitiationSettings.model_fields if name != "gate_widening"),
)
"""What a sweep may vary: a setting (any but gate_widening) or ``confirm`` (k/m)."""
MAX_SWEEP = 50
"""Most values of one sweep."""
K_OF_M = re.compile(r"([0-9]{1,3})/([0-9]{1,3})", re.ASCII)
"""A sweep's k/m: ASCII digits, at most three each, no spaces."""


class SweepIn(Schema):
    """One setting and the values it takes: the points of an operating curve."""

    parameter: Literal[SWEEP_PARAMETERS] = Field(  # type: ignore[valid-type]
        description='The setting varied (``confirm``: k/m as a string such as "3/4").'
    )
    values: list[float | int | str | None] = Field(
        min_length=1,
        max_length=MAX_SWEEP,
        description="Its values, each checked as the setting itself; every other setting is "
        "the request's config.",
    )

    @model_validator(mode="before")
    @classmethod
    def _scalars(cls, data: Any) -> Any:
        """Each value a number, a string or null, refused at its own index otherwise (a
        union would name its branches: ``values[0].float``)."""
        values = data.get("values") if isinstance(data, dict) else None
        if isinstance(values, list):
            errors: list[tuple[Loc, str, Any]] = [
                (("values", i), "must be a number, a string or null", v)
                for i, v in enumerate(values)
                if isinstance(v, bool) or not isinstance(v, (int, float, str, type(None)))
            ]
            if errors:
                raise invalid("SweepIn", errors)
        return data

    def settings(self, config: InitiationSettings) -> list[InitiationSettings]:
        """The config with each value in turn (k/m split into confirm_k and confirm_m),
        each checked as strictly as the setting in ``config``: "0.9" is no gating
        probability and 3.0 no integer."""
        out = []
        errors: list[tuple[Loc, str, Any]] = []
        for i, value in enumerate(self.values):
            changes: dict[str, Any] = {self.parameter: value}
            if self.parameter == "confirm":
                match = K_OF_M.fullmatch(value) if isinstance(value, str) else None
                if match is None:
                    errors.append((("values", i), "must be a string k/m such as '3/4'", value))
                    continue
                k, m = int(match[1]), int(match[2])
                changes = {"confirm_k": k, "confirm_m": m, "history": max(config.history, m)}
            try:
                out.append(
                    InitiationSettings.model_validate(
                        {**config.model_dump(), **changes}, strict=True
                    )
                )
            except ValidationError as exc:
                first = exc.errors(include_url=False)[0]
                where = ".".join(str(part) for part in first["loc"])
                errors.append((("values", i), f"{where}: {first['msg']}", value))
        if errors:
            raise invalid("SweepIn", errors)
        return out


class EvaluationMeans(Schema):
    """Means over the runs of one evaluation, with their standard errors."""

    confirmable: float = Field(
        description="Mean targets detected in k of the m scans from their first detection."
    )
    mean_true: float = Field(description="Targets initiated per run (by plot labels).")
    se_true: float | None = Field(description="Its standard error; null for one run.")
    mean_false: float = Field(description="False tracks per run (by plot labels).")
    se_false: float | None = Field(description="Its standard error; null for one run.")
    mean_true_by_distance: float = Field(description="Targets initiated per run (by distance).")
    mean_false_by_distance: float = Field(description="False tracks per run (by distance).")
    mean_time_to_confirmation: float | None = Field(
        description="Seconds from first detection to confirmation; null if none."
    )


class SweepPoint(EvaluationMeans):
    """The evaluation at one value of a sweep."""

    value: float | int | str | None = Field(description="The setting's value.")


class EvaluateRequest(Schema):
    """Monte Carlo of initiation on a scenario (and, with ``sweep``, an operating curve)."""

    scenario: ScenarioIn = Field(default=ScenarioIn(), description="The scenario.")
    config: InitiationSettings = Field(
        default=InitiationSettings(), description="The rules evaluated."
    )
    runs: int = Field(default=100, ge=1, le=10_000, description="Monte Carlo runs.")
    seed: int = Field(default=0, ge=0, le=2**63 - 1, description="Seed (run r: spawn r).")
    distance: float = Field(
        default=100.0, gt=0, le=MAX_DISTANCE, description="Radius of the distance-based score, m."
    )
    sweep: SweepIn | None = Field(
        default=None,
        description="An operating curve: the config evaluated again under each value of one "
        "setting, on the same simulated scans; null: the config alone.",
    )

    @model_validator(mode="after")
    def _work(self) -> "EvaluateRequest":
        configs = [self.config]
        if self.sweep is not None:
            try:
                configs += self.sweep.settings(self.config)
            except ValidationError as exc:
                raise invalid(
                    "EvaluateRequest",
                    [
                        (("sweep", *e["loc"]), e["msg"], e.get("input"))
                        for e in exc.errors(include_url=False)
                    ],
                ) from None
        self._clutter_thin_enough(configs)
        plots = self.runs * self.scenario.plots() * len(configs)
        if plots > MAX_EVALUATION_PLOTS:
            raise invalid(
                "EvaluateRequest",
                [
                    (
                        ("runs",),
                        f"runs x expected plots per run x evaluations (1 + sweep "
                        f"values) is {plots:.0f}; at most {MAX_EVALUATION_PLOTS}",
                        self.runs,
                    )
                ],
            )
        return self

    def configs(self) -> list[InitiationSettings]:
        """The rules evaluated: the config, then one per sweep value."""
        return [self.config, *(() if self.sweep is None else self.sweep.settings(self.config))]

    def work(self) -> int:
        """The work size ``runs x scans x plots``: the evaluation's cost in plot-equivalents,
        what its default cap (one core, :data:`~plotgate.service.schemas.TIME_BUDGET_S`)
        and its cluster cap count.

        Each rule evaluated initiates every run's plots, runs x scans x (clutter +
        targets), each plot weighted by what it costs there: 1 + :data:`GATE_CLUTTER_COST`
        x the expected clutter plots in a capture gate, times :data:`MODE_COST` of the
        mode and :data:`CONFIRMATION_COST` of the confirmation rule; and each run costs
        :data:`RUN_COST` more. A plot-equivalent is about 5.4 us on one core (Mu et al.'s
        scenario at clutter 250, Cartesian logic); the default cap, 1,200,000, is about
        6.5 s. The estimate is what sets the cap; the bench
        (``bench/bench_worst_requests.py``) checks its worst requests against the 10 s.
        """
        total = 0.0
        for config in self.configs():
            weight = (
                (1.0 + GATE_CLUTTER_COST * self.scenario.gate_clutter(config))
                * MODE_COST[config.mode]
                * CONFIRMATION_COST[config.confirmation]
            )
            total += self.runs * (self.scenario.plots() * weight + RUN_COST)
        return math.ceil(total)

    def _clutter_thin_enough(self, configs: list[InitiationSettings]) -> None:
        """Refuse (on ``scenario.clutter``) a scenario whose clutter fills the capture gates
        of any rule evaluated (:data:`MAX_GATE_CLUTTER`), before a plot is drawn."""
        densest = max(self.scenario.gate_clutter(config) for config in configs)
        if densest > MAX_GATE_CLUTTER:
            raise invalid(
                "EvaluateRequest",
                [
                    (
                        ("scenario", "clutter"),
                        f"puts {densest:.3g} expected clutter plots in a capture gate "
                        f"(clutter / region area x pi (v_max^2 - v_min^2) interval^2); at "
                        f"most {MAX_GATE_CLUTTER:g}: the clutter is too thick for initiation",
                        self.scenario.clutter,
                    )
                ],
            )


class _EvaluationSize(Schema):
    runs: int = Field(description="Monte Carlo runs.")
    targets: int = Field(description="Targets in the scenario.")


class EvaluateResult(EvaluationMeans, _EvaluationSize):
    """Means over the runs (of the config as sent), and the sweep's points; runs and
    targets first (pydantic orders a model's fields from its last base to its first)."""

    sweep: list[SweepPoint] | None = Field(
        default=None, description="One point per value of the request's sweep, in order."
    )
