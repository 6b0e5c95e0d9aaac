"""Gating probabilities, curves, analysis and design over HTTP (Konovalov, eq. 1-6).

Numbers are checked against core called directly and against the paper's worked
example (tau 5 s, v 100..500 m/s, sigma_r 200 m, sigma_az 0.5 deg); bad input answers a
problem+json naming the field. Unconditional probabilities cost ~0.3-1 s each, a design
several seconds, so those cases are few and small.
"""

import json
import math

import numpy as np
import pytest
from fastapi.testclient import TestClient

from plotgate import core
from plotgate.clients.cli import main
from plotgate.clients.recordings import read_recording
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.schemas import MAX_CURVE_POINTS, MAX_UNCONDITIONAL_POINTS, Mark
from tests.support.requests import answer, invalid_input

TAU = 5.0
RING = {"kind": "ring", "v_min": 100.0, "v_max": 500.0}
COMBINED = {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "P_G": 0.9}
MARK = {"r": 50_000.0, "az_deg": 0.0, "sigma_r": 200.0, "sigma_az_deg": 0.5}
AREA = {"kind": "area", "v_min": 100.0, "v_max": 500.0}
RESOLUTION = {"range": 500.0, "azimuth_deg": 1.5}
SIGMA_AZ = math.radians(0.5)


def _geometry(r=50_000.0, az_deg=0.0):
    return core.mark_geometry(r, np.radians(az_deg), 200.0, SIGMA_AZ, TAU)


def _velocity(speed, course_deg):
    c = math.radians(course_deg)
    return np.multiply.outer(speed, [math.sin(c), math.cos(c)])


def _probability(**changes) -> dict:
    return {"gate": RING, "mark": MARK, "tau": TAU, "velocity": {"speed": 200.0}, **changes}


# --- gates.probability -----------------------------------------------------------------


def test_paper_ring_gate_unconditional(client):
    # Konovalov: ring gate, area prior, R = 50 km -> 0.82
    body = answer(
        client.post(
            "/v1/gates/probability", json={"gate": RING, "mark": MARK, "tau": TAU, "prior": AREA}
        )
    )
    assert body["conditional"] is False
    assert body["probability"] == pytest.approx(0.82, abs=0.01)
    assert body["error"] < 1e-6
    expected = core.unconditional_probability(
        core.RingGate(100.0, 500.0), _geometry(), 100.0, 500.0, "area"
    )
    assert body["probability"] == pytest.approx(expected.probability[0], abs=1e-12)


def test_conditional_matches_core(client):
    mark = dict(MARK, az_deg=20.0, sigma_r2=300.0, sigma_az2_deg=0.25)
    body = answer(
        client.post(
            "/v1/gates/probability",
            json=_probability(
                gate=COMBINED, mark=mark, velocity={"speed": 450.0, "course_deg": 30.0}
            ),
        )
    )
    assert body["conditional"] is True
    geometry = core.mark_geometry(
        50_000.0, np.radians(20.0), 200.0, SIGMA_AZ, TAU, 300.0, np.radians(0.25)
    )
    expected = core.conditional_probability(
        core.CombinedGate(100.0, 500.0, 0.9), geometry, _velocity(450.0, 30.0)
    )
    assert body["probability"] == pytest.approx(expected.probability[0], abs=1e-12)
    assert body["error"] == pytest.approx(expected.error[0], abs=1e-15)


def test_course_is_clockwise_from_north(client):
    # an ellipse centred on the true displacement v tau holds exactly P_G
    speed, course = 300.0, 60.0
    offset = [float(x) for x in _velocity(speed, course) * TAU]
    gate = {"kind": "ellipse", "P_G": 0.9, "offset": offset}
    body = answer(
        client.post(
            "/v1/gates/probability",
            json=_probability(gate=gate, velocity={"speed": speed, "course_deg": course}),
        )
    )
    assert body["probability"] == pytest.approx(0.9, abs=1e-9)


@pytest.mark.parametrize(
    "gate",
    [
        {"kind": "expanded", "v_max": 500.0, "p": 0.9},
        {"kind": "rectangular", "k": 3.0, "offset": [500.0, 800.0]},
        {"kind": "sector", "K_R": 3.0, "K_az": 3.0, "offset": [500.0, 800.0]},
        {"kind": "first_association", "v_max": 500.0, "K_R": 3.0, "K_az": 3.0},
    ],
    ids=lambda g: g["kind"],
)
def test_every_gate_kind(client, gate):
    body = answer(
        client.post(
            "/v1/gates/probability",
            json=_probability(gate=gate, velocity={"speed": 190.0, "course_deg": 32.0}),
        )
    )
    kinds = {
        "expanded": lambda: core.ExpandedGate(500.0, 0.9),
        "rectangular": lambda: core.RectangularGate(3.0, (500.0, 800.0)),
        "sector": lambda: core.SectorGate(3.0, 3.0, (500.0, 800.0)),
        "first_association": lambda: core.FirstAssociationGate(500.0, 3.0, 3.0),
    }
    expected = core.conditional_probability(
        kinds[gate["kind"]](), _geometry(), _velocity(190.0, 32.0)
    )
    assert body["probability"] == pytest.approx(expected.probability[0], abs=1e-12)
    assert 0.5 < body["probability"] < 1.0


# --- gates.probability_curve -----------------------------------------------------------


def _curve(**changes) -> dict:
    return {
        "gate": RING,
        "mark": MARK,
        "tau": TAU,
        "against": "speed",
        "values": [100.0, 200.0, 300.0, 400.0, 500.0],
        "course_deg": 0.0,
        **changes,
    }


def test_speed_curve_matches_core(client):
    speeds = [50.0, 100.0, 250.0, 499.0, 600.0]
    body = answer(
        client.post("/v1/gates/probability/curve", json=_curve(values=speeds, course_deg=45.0))
    )
    assert body["against"] == "speed" and body["conditional"] is True
    assert body["values"] == speeds
    gate = core.RingGate(100.0, 500.0)
    for speed, p in zip(speeds, body["probability"], strict=True):
        expected = core.conditional_probability(gate, _geometry(), _velocity(speed, 45.0))
        assert p == pytest.approx(expected.probability[0], abs=1e-12)
    assert max(body["error"]) < 1e-6
    assert body["probability"][2] > 0.9 > body["probability"][0]


def test_range_curve_conditional_matches_core(client):
    ranges = [5_000.0, 20_000.0, 50_000.0, 100_000.0]
    body = answer(
        client.post(
            "/v1/gates/probability/curve",
            json=_curve(
                gate=COMBINED, against="range", values=ranges, speed=300.0, course_deg=90.0
            ),
        )
    )
    assert body["conditional"] is True and body["values"] == ranges
    gate = core.CombinedGate(100.0, 500.0, 0.9)
    for r, p in zip(ranges, body["probability"], strict=True):
        expected = core.conditional_probability(gate, _geometry(r), _velocity(300.0, 90.0))
        assert p == pytest.approx(expected.probability[0], abs=1e-12)


def test_range_curve_unconditional_paper_values(client):
    # Konovalov: ring gate, area prior: 0.90 at 20 km, 0.82 at 50 km
    body = answer(
        client.post(
            "/v1/gates/probability/curve",
            json=_curve(against="range", values=[20_000.0, 50_000.0], prior=AREA),
        )
    )
    assert body["conditional"] is False
    assert body["probability"] == pytest.approx([0.90, 0.82], abs=0.01)
    assert max(body["error"]) < 1e-6


# --- gates.analysis --------------------------------------------------------------------


def _analysis(**changes) -> dict:
    return {
        "gate": COMBINED,
        "mark": MARK,
        "tau": TAU,
        "resolution": RESOLUTION,
        "false_alarm": 1e-4,
        **changes,
    }


def test_analysis_combined_gate(client):
    body = answer(client.post("/v1/gates/analysis", json=_analysis(m_max=3)))
    gate, geometry = core.CombinedGate(100.0, 500.0, 0.9), _geometry()
    area = core.gate_area(gate, geometry)
    cells = core.resolution_cells(area, 50_000.0, 500.0, math.radians(1.5))
    marks = core.false_marks(cells, 1e-4, 3)
    assert body["area"] == pytest.approx(area[0], rel=1e-12)
    assert body["cells"] == pytest.approx(cells[0], rel=1e-12)
    assert body["false_marks"]["mean"] == pytest.approx(1e-4 * cells[0], rel=1e-12)
    np.testing.assert_allclose(
        body["false_marks"]["probabilities"], marks.probabilities[0], rtol=1e-12
    )
    assert body["false_marks"]["at_least_one"] == pytest.approx(marks.at_least_one[0], rel=1e-12)
    # the paper's approximation S_ring + S_e / 2: about 31 cells, P(>= 1) = 0.0031
    approx = body["approximation"]
    assert approx["area"] == pytest.approx(
        core.combined_area_approximation(gate, geometry)[0], rel=1e-12
    )
    assert approx["cells"] == pytest.approx(31.0, abs=0.5)
    assert approx["false_marks"]["at_least_one"] == pytest.approx(0.0031, abs=5e-5)
    assert body["gate_probability"] is None and body["capture"] is None


def test_analysis_expanded_gate_paper_cells(client):
    # Konovalov: the expanded gate (p = 0.9) covers about 49 cells, P(>= 1) = 0.0049
    gate = {"kind": "expanded", "v_max": 500.0, "p": 0.9}
    body = answer(client.post("/v1/gates/analysis", json=_analysis(gate=gate)))
    assert body["cells"] == pytest.approx(49.0, abs=1.0)
    assert body["false_marks"]["at_least_one"] == pytest.approx(0.0049, abs=1e-4)
    assert len(body["false_marks"]["probabilities"]) == 6
    assert body["approximation"] is None


def test_analysis_with_prior_gives_capture(client):
    body = answer(
        client.post(
            "/v1/gates/analysis", json=_analysis(gate=RING, prior=AREA, P_D1=0.9, P_D2=0.8)
        )
    )
    assert body["gate_probability"] == pytest.approx(0.82, abs=0.01)
    assert body["error"] < 1e-6
    assert body["capture"] == pytest.approx(body["gate_probability"] * 0.72, rel=1e-12)
    assert body["area"] == pytest.approx(math.pi * (2500.0**2 - 500.0**2), rel=1e-9)


# --- gates.design ----------------------------------------------------------------------


def _design(**changes) -> dict:
    return {
        "gate": {"kind": "combined", "v_min": 100.0, "v_max": 500.0},
        "mark": MARK,
        "tau": TAU,
        "capture": 0.99,
        "prior": AREA,
        "resolution": RESOLUTION,
        **changes,
    }


def test_design_combined_gate(client):
    body = answer(client.post("/v1/gates/design", json=_design()))
    assert body["parameter"] == "P_G" and 0.5 < body["value"] < 0.99
    assert body["threshold"] == pytest.approx(core.gate_threshold(body["value"], 2), rel=1e-12)
    assert body["probability"] == pytest.approx(0.99, abs=1e-5)
    assert body["capture"] == pytest.approx(body["probability"], rel=1e-12)
    gate, geometry = core.CombinedGate(100.0, 500.0, body["value"]), _geometry()
    check = core.unconditional_probability(gate, geometry, 100.0, 500.0, "area")
    assert body["probability"] == pytest.approx(check.probability[0], abs=1e-9)
    assert body["area"] == pytest.approx(core.gate_area(gate, geometry)[0], rel=1e-9)
    cells = float(core.resolution_cells(body["area"], 50_000.0, 500.0, math.radians(1.5)))
    assert body["cells"] == pytest.approx(cells, rel=1e-12)
    assert body["false_marks"]["at_least_one"] == pytest.approx(-math.expm1(-1e-4 * cells))


@pytest.mark.parametrize(
    "changes",
    [
        {"capture": 0.95, "P_D1": 0.9},  # above P_D1 P_D2: unreachable
        {"capture": 0.5},
    ],  # the ring alone already gives 0.82
    ids=["unreachable", "first-stage-suffices"],
)
def test_design_capture_out_of_reach(client, changes):
    body = invalid_input(client.post("/v1/gates/design", json=_design(**changes)), "capture")
    assert str(changes["capture"]) in body["detail"]


def test_design_takes_only_combined_or_expanded(client):
    invalid_input(client.post("/v1/gates/design", json=_design(gate=RING)), "gate")


# --- bad input -------------------------------------------------------------------------


def test_v_min_above_v_max_in_the_gate(client):
    gate = dict(RING, v_min=600.0)
    body = invalid_input(
        client.post("/v1/gates/probability", json=_probability(gate=gate)), "gate.v_min"
    )
    assert "600" in body["detail"]
    r = client.post("/v1/gates/analysis", json=_analysis(gate=dict(COMBINED, v_min=600.0)))
    invalid_input(r, "gate.v_min")


@pytest.mark.parametrize(
    ("path", "body"),
    [
        ("/v1/gates/probability", {"gate": RING, "mark": MARK, "tau": TAU}),
        ("/v1/gates/probability/curve", _curve(against="range", values=[5e4])),
        ("/v1/gates/analysis", _analysis()),
        ("/v1/gates/design", _design()),
    ],
    ids=["probability", "curve", "analysis", "design"],
)
def test_v_min_above_v_max_in_the_prior(client, path, body):
    prior = dict(AREA, v_min=600.0)
    invalid_input(client.post(path, json=dict(body, prior=prior)), "prior.v_min")
    # both inconsistent: core checks the prior first
    both = dict(body, prior=prior, gate=dict(COMBINED, v_min=700.0))
    invalid_input(client.post(path, json=both), "prior.v_min")


@pytest.mark.parametrize("P_G", [0.0, 1.0, 1.5, -0.1])
def test_probability_outside_unit_interval(client, P_G):
    gate = dict(COMBINED, P_G=P_G)
    invalid_input(
        client.post("/v1/gates/probability", json=_probability(gate=gate)), "gate.combined.P_G"
    )
    invalid_input(client.post("/v1/gates/design", json=_design(gate=gate)), "gate.combined.P_G")


@pytest.mark.parametrize(
    ("field", "value", "where"),
    [
        ("capture", 1.0, "capture"),
        ("capture", 0.0, "capture"),
        ("P_D1", 0.0, "P_D1"),
        ("P_D2", 1.2, "P_D2"),
        ("false_alarm", 0.0, "false_alarm"),
    ],
)
def test_design_probabilities_outside_unit_interval(client, field, value, where):
    invalid_input(client.post("/v1/gates/design", json=_design(**{field: value})), where)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("sigma_r", 0.0),
        ("sigma_r", -5.0),
        ("sigma_az_deg", 0.0),
        ("sigma_az_deg", -0.5),
        ("sigma_r2", 0.0),
        ("sigma_az2_deg", -1.0),
    ],
)
def test_zero_or_negative_sigma(client, field, value):
    mark = dict(MARK, **{field: value})
    invalid_input(
        client.post("/v1/gates/probability", json=_probability(mark=mark)), f"mark.{field}"
    )
    invalid_input(client.post("/v1/gates/analysis", json=_analysis(mark=mark)), f"mark.{field}")


@pytest.mark.parametrize("tau", [0.0, -5.0])
def test_tau_not_positive(client, tau):
    invalid_input(client.post("/v1/gates/probability", json=_probability(tau=tau)), "tau")
    invalid_input(client.post("/v1/gates/probability/curve", json=_curve(tau=tau)), "tau")
    invalid_input(client.post("/v1/gates/design", json=_design(tau=tau)), "tau")


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
@pytest.mark.parametrize(
    ("path", "body", "marker", "field"),
    [
        ("/v1/gates/probability", _probability(tau=1234.5), "1234.5", "tau"),
        (
            "/v1/gates/probability",
            _probability(velocity={"speed": 1234.5}),
            "1234.5",
            "velocity.speed",
        ),
        ("/v1/gates/probability/curve", _curve(values=[100.0, 1234.5]), "1234.5", "values[1]"),
        ("/v1/gates/analysis", _analysis(mark=dict(MARK, r=1234.5)), "1234.5", "mark.r"),
    ],
    ids=["tau", "speed", "curve-value", "range"],
)
def test_non_finite_numbers(client, token, path, body, marker, field):
    text = json.dumps(body).replace(marker, token, 1)
    r = client.post(path, content=text.encode(), headers={"content-type": "application/json"})
    invalid_input(r, field)


def test_gate_carries_no_tau(client):
    body = _probability(gate=dict(RING, tau=5.0))
    invalid_input(client.post("/v1/gates/probability", json=body), "gate.ring.tau")


@pytest.mark.parametrize(
    "given", [{}, {"velocity": {"speed": 200.0}, "prior": AREA}], ids=["neither", "both"]
)
def test_exactly_one_of_velocity_and_prior(client, given):
    body = {"gate": RING, "mark": MARK, "tau": TAU, **given}
    problem = invalid_input(client.post("/v1/gates/probability", json=body), "velocity")
    assert "prior" in [e["field"] for e in problem["errors"]]


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"speed": 200.0}, "speed"),
        ({"prior": AREA}, "prior"),
        ({"against": "range", "values": [5e4]}, "speed"),
        ({"against": "range", "values": [5e4], "speed": 200.0, "prior": AREA}, "prior"),
        ({"against": "range", "values": [5e4, 0.5], "speed": 200.0}, "values[1]"),
        ({"values": [100.0, 2e6]}, "values[1]"),
        ({"values": []}, "values"),
        ({"against": "altitude"}, "against"),
    ],
    ids=[
        "speed-given",
        "prior-given",
        "neither",
        "both",
        "range-too-small",
        "speed-too-large",
        "empty",
        "unknown-against",
    ],
)
def test_curve_rules(client, changes, field):
    invalid_input(client.post("/v1/gates/probability/curve", json=_curve(**changes)), field)


def test_too_many_curve_values(client):
    speeds = [200.0] * (MAX_CURVE_POINTS + 1)
    invalid_input(client.post("/v1/gates/probability/curve", json=_curve(values=speeds)), "values")
    ranges = [5e4] * (MAX_UNCONDITIONAL_POINTS + 1)
    body = _curve(against="range", values=ranges, prior=AREA)
    problem = invalid_input(client.post("/v1/gates/probability/curve", json=body), "values")
    assert str(MAX_UNCONDITIONAL_POINTS) in problem["detail"]
    # the same number of values is fine for a conditional curve
    body = _curve(against="range", values=ranges, speed=200.0)
    assert len(answer(client.post("/v1/gates/probability/curve", json=body))["probability"]) == 101


def test_numerically_singular_mark(client):
    # r sigma_az / sigma_r above 10^6: B cannot be used (core names B)
    mark = dict(MARK, sigma_r=1e-3, sigma_az_deg=1e-3, r=1e8)
    invalid_input(client.post("/v1/gates/probability", json=_probability(mark=mark)), "mark")
    body = _curve(against="range", values=[5e4, 1e8], speed=200.0, mark=dict(mark, r=5e4))
    invalid_input(client.post("/v1/gates/probability/curve", json=body), "values[1]")


# --- the unconditional quadrature's work: the axis ratio of B ---------------------------


@pytest.mark.parametrize(
    ("r", "sigma_r", "sigma_az_deg", "sigma_r2", "sigma_az2_deg"),
    [
        (50_000.0, 200.0, 0.5, None, None),
        (50_000.0, 1e-3, 0.5, 20.0, None),
        (1.0, 200.0, 1e-6, None, 3.0),
        (1e9, 5.0, 180.0, 1e9, 1e-6),
    ],
)
def test_axis_ratio_is_that_of_cores_B(r, sigma_r, sigma_az_deg, sigma_r2, sigma_az2_deg):
    mark = Mark(
        r=r,
        az_deg=33.0,
        sigma_r=sigma_r,
        sigma_az_deg=sigma_az_deg,
        sigma_r2=sigma_r2,
        sigma_az2_deg=sigma_az2_deg,
    )
    g = core.mark_geometry(
        r,
        math.radians(33.0),
        sigma_r,
        math.radians(sigma_az_deg),
        TAU,
        sigma_r2,
        None if sigma_az2_deg is None else math.radians(sigma_az2_deg),
    )
    B = np.array([[g.B.xx[0], g.B.xy[0]], [g.B.xy[0], g.B.yy[0]]])
    lam = np.linalg.eigvalsh(B)  # exact enough below a ratio of ~1e6
    if lam[0] > 1e-12 * lam[1]:
        assert mark.axis_ratio() == pytest.approx(math.sqrt(lam[1] / lam[0]), rel=1e-6)
    along = sigma_r**2 + (sigma_r if sigma_r2 is None else sigma_r2) ** 2
    assert mark.axis_ratio() ** 2 == pytest.approx(
        max(along, np.trace(B) - along) / min(along, np.trace(B) - along), rel=1e-6
    )


def test_operators_cap_the_axis_ratio_of_unconditional_probabilities(tmp_path):
    limits = {
        name: {"mark.axis_ratio": 10}
        for name in (
            "gates.probability",
            "gates.probability_curve",
            "gates.analysis",
            "gates.design",
        )
    }
    thin = dict(MARK, sigma_r=1.0)  # B: 617 m by 1.4 m sigmas, a ratio of 437: minutes
    with TestClient(create_app(Settings(log_dir=tmp_path, limits=limits))) as c:
        body = invalid_input(
            c.post(
                "/v1/gates/probability",
                json={"gate": RING, "mark": thin, "tau": TAU, "prior": AREA},
            ),
            "mark.axis_ratio",
        )
        assert "is 437; this server allows at most 10" in body["detail"]
        invalid_input(c.post("/v1/gates/design", json=_design(mark=thin)), "mark.axis_ratio")
        invalid_input(
            c.post("/v1/gates/analysis", json=_analysis(mark=thin, prior=AREA)), "mark.axis_ratio"
        )
        # conditional probabilities and areas cost milliseconds at any ratio: not capped
        answer(c.post("/v1/gates/probability", json=_probability(mark=thin)))
        answer(c.post("/v1/gates/analysis", json=_analysis(mark=thin)))
        answer(c.post("/v1/gates/probability/curve", json=_curve(mark=thin)))
        spec = c.get("/openapi.json").json()["paths"]
        assert spec["/v1/gates/design"]["post"]["x-plotgate-limits"] == {"mark.axis_ratio": 10}


# --- recording and replay --------------------------------------------------------------

SESSION = [
    ("p-cond", "/v1/gates/probability", _probability(gate=COMBINED)),
    ("p-uncond", "/v1/gates/probability", {"gate": RING, "mark": MARK, "tau": TAU, "prior": AREA}),
    ("curve", "/v1/gates/probability/curve", _curve(values=[100.0, 300.0, 600.0])),
    ("analysis", "/v1/gates/analysis", _analysis()),
    (
        "design",
        "/v1/gates/design",
        _design(gate={"kind": "expanded", "v_max": 500.0}, capture=0.9, P_D1=0.99),
    ),
    ("bad", "/v1/gates/probability", _probability(gate=dict(RING, v_min=600.0))),
]


def test_session_is_recorded_and_replays(settings, tmp_path, capsys):
    with TestClient(create_app(settings)) as c:
        statuses = {
            rid: c.post(path, json=body, headers={"x-request-id": rid}).status_code
            for rid, path, body in SESSION
        }
    assert statuses == {
        "p-cond": 200,
        "p-uncond": 200,
        "curve": 200,
        "analysis": 200,
        "design": 200,
        "bad": 422,
    }
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    ops = {e.request_id: e.operation for e in read_recording(path).exchanges}
    assert ops == {
        "p-cond": "gates.probability",
        "p-uncond": "gates.probability",
        "curve": "gates.probability_curve",
        "analysis": "gates.analysis",
        "design": "gates.design",
        "bad": "gates.probability",
    }

    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    summary = json.loads(report.read_text())
    assert summary["compared"] == summary["unchanged"] == len(SESSION)
    capsys.readouterr()
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    for op in ("gates.probability", "gates.probability_curve", "gates.analysis", "gates.design"):
        assert op in out
