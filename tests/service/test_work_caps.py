"""Default work caps: an operation whose memory grows faster than its body is refused
before any work, with a 422 naming the work size and its cap (issue 24, findings 3 and 9).

The refusals are tested with the operation's handler replaced by one that fails the test
if it runs: the cap must answer before any work, and on a build without the cap the
request would reach the handler (a 500 here, seconds and gigabytes for real)."""

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import pytest
from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS, over_caps
from plotgate.service.schemas import (
    MAX_GATE_CLUTTER,
    MEMORY_BUDGET_MIB,
    RUN_COST,
    EvaluateRequest,
    GateAnalysisRequest,
    GateDesignRequest,
    GateProbabilityCurveRequest,
    GateProbabilityRequest,
    IdentifyPictureRequest,
    IdentifySimulateRequest,
    InitiationSettings,
    Mark,
    NoiseRequest,
    RingRegion,
    ScenarioIn,
    SpeedPrior,
    StudyRequest,
)
from plotgate.service.table import ENDPOINTS, work_caps
from tests.support.requests import answer, invalid_input, with_handler


def _without_work(name: str) -> Any:
    """The operation with a handler that fails the test if the request gets that far."""

    def handler(request: Any) -> Any:
        raise AssertionError(f"{name} started its work")

    return with_handler(name, handler)


@pytest.fixture
def workless(monkeypatch, settings) -> Callable[[str], TestClient]:
    """A client of an app whose operation ``name`` must not start its work."""
    clients = []

    def client(name: str) -> TestClient:
        monkeypatch.setitem(OPERATIONS, name, _without_work(name))
        c = TestClient(create_app(settings), raise_server_exceptions=False)
        clients.append(c.__enter__())
        return c

    yield client
    for c in clients:
        c.__exit__(None, None, None)


def test_a_picture_of_ten_thousand_by_ten_thousand_tracks_is_refused_before_any_work(workless):
    body = {"passive_deg": [[0.0, 0.1]] * 10_000, "active_deg": [[0.0, 0.1]] * 10_000}
    r = workless("identification.picture").post("/v1/identification/picture", json=body)
    problem = invalid_input(r, "passive_deg x active_deg")
    assert "is 100000000; this server allows at most 2500000" in problem["detail"]
    assert f"under {MEMORY_BUDGET_MIB} MiB" in problem["detail"]


def test_an_evaluation_in_clutter_too_thick_is_refused_before_a_plot_is_drawn(workless):
    body = {"scenario": {"scans": 4, "clutter": 5e4}, "runs": 20, "seed": 1}
    r = workless("initiation.evaluate").post("/v1/initiation/evaluate", json=body)
    problem = invalid_input(r, "scenario.clutter")
    assert "1.75 expected clutter plots in a capture gate" in problem["detail"]


def _gate_clutter_body(per_gate: float, **config: Any) -> dict[str, Any]:
    """An evaluation whose clutter puts ``per_gate`` expected plots in a capture gate of the
    default rules (v_min 0, v_max 50 m/s, 1 s scans) in a 10 km square."""
    clutter = per_gate * 1e8 / (3.141592653589793 * 50.0**2)
    return {"scenario": {"clutter": clutter, "region": [0, 1e4, 0, 1e4]}, "runs": 1, **config}


def test_the_gate_clutter_rule_takes_its_bound_and_refuses_beyond_it():
    EvaluateRequest.model_validate(_gate_clutter_body(MAX_GATE_CLUTTER * (1 - 1e-9)))
    with pytest.raises(ValueError, match="scenario.clutter|clutter"):
        EvaluateRequest.model_validate(_gate_clutter_body(MAX_GATE_CLUTTER * (1 + 1e-9)))


def test_the_gate_clutter_rule_holds_every_value_of_a_sweep():
    thin = _gate_clutter_body(0.25)
    EvaluateRequest.model_validate(thin)
    swept = {**thin, "sweep": {"parameter": "v_max", "values": [50.0, 150.0]}}  # 9x the area
    with pytest.raises(ValueError, match="clutter"):
        EvaluateRequest.model_validate(swept)


def test_clutter_in_a_region_of_no_area_is_refused():
    body = {"scenario": {"clutter": 1.0, "region": [0, 0, 0, 1e4]}, "runs": 1}
    with pytest.raises(ValueError, match="clutter"):
        EvaluateRequest.model_validate(body)
    EvaluateRequest.model_validate({"scenario": {"clutter": 0.0, "region": [0, 0, 0, 1e4]}})


def _eccentric(model: type, v: int, **fields: Any) -> Any:
    """An unconditional request of ``model`` whose B has axis ratio v - 0.5 (rounded up: v)."""
    cross = 50_000.0 * math.radians(0.5)
    mark = Mark(r=50_000.0, sigma_r=cross / (v - 0.5), sigma_az_deg=0.5)
    return model.model_construct(mark=mark, prior=SpeedPrior(v_max=500.0), **fields)


def _tracked_study(v: int) -> Any:
    """A study with tracks of prefix work v: v / 10^4 runs x 100 samples^2 x 1 receiver."""
    return StudyRequest.model_construct(
        runs=v // 10_000, sample_times=[0.0] * 100, receivers=[None], tracks=True
    )


def _curve(ratio: int, points: int) -> Any:
    """An unconditional ring-gate curve of ``points`` values at axis ratio ``ratio``."""
    ring = RingRegion(kind="ring", v_max=1.0)
    return _eccentric(
        GateProbabilityCurveRequest, ratio, against="speed", values=[1.0] * points, gate=ring
    )


SIZED: dict[tuple[str, str], Callable[[int], Any]] = {
    ("gates.probability", "mark.axis_ratio"): lambda v: _eccentric(GateProbabilityRequest, v),
    ("gates.analysis", "mark.axis_ratio"): lambda v: _eccentric(GateAnalysisRequest, v),
    ("gates.design", "mark.axis_ratio"): lambda v: _eccentric(GateDesignRequest, v),
    ("gates.probability_curve", "mark.axis_ratio"): lambda v: _curve(v, 1),
    ("gates.probability_curve", "values x gate cost"): lambda v: _curve(2, v),
    ("identification.picture", "passive_deg x active_deg"): lambda v: (
        IdentifyPictureRequest.model_construct(passive_deg=[[0.0, 1.0]] * v, active_deg=[[0.0]])
    ),
    ("solves.study", "runs x sample_times x receivers"): lambda v: StudyRequest.model_construct(
        runs=v, sample_times=[0.0], receivers=[None]
    ),
    ("solves.study", "runs x sample_times x receivers^2"): lambda v: StudyRequest.model_construct(
        runs=v // 36, sample_times=[0.0], receivers=[None] * 6
    ),
    ("solves.study", "runs x sample_times^2 x receivers^2"): _tracked_study,
    ("solves.noise", "sample_times x window"): lambda v: NoiseRequest.model_construct(
        sample_times=[0.0] * v, window=1
    ),
    ("identification.simulate", "runs x (n + m)"): lambda v: (
        IdentifySimulateRequest.model_construct(runs=v, n=1, m=0)
    ),
    ("initiation.evaluate", "runs x scans x plots"): lambda v: EvaluateRequest.model_construct(
        config=InitiationSettings(),
        sweep=None,
        runs=1,
        scenario=ScenarioIn.model_construct(
            scans=1, clutter=0.0, targets=[None] * (v - RUN_COST), region=(0.0, 1.0, 0.0, 1.0)
        ),
    ),
}
"""A request (unvalidated: only its sizes are read) whose work size is exactly v (a multiple
of :data:`STEP` where it has one), every other size within its cap."""

STEP = {
    ("solves.study", "runs x sample_times^2 x receivers^2"): 10_000,
    ("solves.study", "runs x sample_times x receivers^2"): 36,
}
"""The sizes only multiples of a step reach within the other caps (runs x 100 samples^2,
runs x 6 receivers^2)."""

DEFAULT_CAPS = [(name, size, cap) for name, e in ENDPOINTS.items() for size, cap in e.caps.items()]


def test_every_default_cap_has_a_sized_request_here():
    assert {(name, size) for name, size, _ in DEFAULT_CAPS} == set(SIZED)


@pytest.mark.parametrize(("name", "size", "cap"), DEFAULT_CAPS)
def test_a_default_cap_takes_its_value_and_refuses_one_more(name, size, cap):
    op = OPERATIONS[name]
    caps = Settings(record=False).limits[name]
    assert caps[size] == cap
    step = STEP.get((name, size), 1)
    assert over_caps(op, SIZED[name, size](cap), caps) is None
    problem = over_caps(op, SIZED[name, size](cap + step), caps)
    assert problem is not None and problem.status == 422
    assert [e.field for e in problem.errors] == [size]
    assert f"is {cap + step}; this server allows at most {cap} (the default" in problem.detail


def test_an_operator_lowers_or_raises_a_default_and_keeps_the_others(tmp_path):
    operator = {"identification.picture": {"passive_deg x active_deg": 10, "active_deg": 3}}
    caps = Settings(log_dir=tmp_path, limits=operator).limits
    assert caps["identification.picture"] == {"passive_deg x active_deg": 10, "active_deg": 3}
    assert caps["solves.study"] == ENDPOINTS["solves.study"].caps
    raised = work_caps({"solves.study": {"runs x sample_times x receivers": 2_400_000}})
    assert raised["solves.study"]["runs x sample_times x receivers"] == 2_400_000


def test_an_operators_cap_is_named_as_such(tmp_path):
    operator = {"identification.picture": {"passive_deg x active_deg": 3}}
    settings = Settings(log_dir=tmp_path, record=False, limits=operator)
    body = {"passive_deg": [[0.0, 0.1]] * 2, "active_deg": [[0.0, 0.1]] * 2}
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        problem = invalid_input(
            c.post("/v1/identification/picture", json=body), "passive_deg x active_deg"
        )
        assert problem["detail"].endswith("at most 3 (PLOTGATE_LIMITS)")
        spec = c.get("/openapi.json").json()["paths"]
    limits = spec["/v1/identification/picture"]["post"]["x-plotgate-limits"]
    assert limits == {"passive_deg": None, "active_deg": None, "passive_deg x active_deg": 3}
    assert (
        spec["/v1/solves/study"]["post"]["x-plotgate-limits"]["runs x sample_times x receivers"]
        == ENDPOINTS["solves.study"].caps["runs x sample_times x receivers"]
    )


def test_a_picture_at_a_small_size_is_answered(client):
    body = {"passive_deg": [[10.0, 10.2]] * 3, "active_deg": [[10.1, 10.0]] * 2}
    assert len(answer(client.post("/v1/identification/picture", json=body))["z"]) == 3


def test_a_default_cap_on_a_size_the_operation_lacks_is_a_bug():
    e = ENDPOINTS["solves.study"]
    with pytest.raises(ValueError, match="default caps on sizes it lacks"):
        dataclasses.replace(e, caps={"plots": 1})
