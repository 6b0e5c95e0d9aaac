"""Each input covariance is checked on its own, before any sum and whatever the gate kind:
the 422 names the input plot's own field and prints that plot's own matrix, never a sum
S = P_first + P_candidate that may happen to be positive definite."""

import pytest

from tests.support.requests import cartesian, invalid_input, polar

INDEFINITE = [[1e4, 1.5e4], [1.5e4, 1e4]]  # det = -1.25e8: not positive definite
ASYMMETRIC = [[1e4, 5e3], [0.0, 1e4]]
THIN = [[1e-6, 0.0], [0.0, 1e12]]  # axis ratio 1e9: numerically singular
WIDE = [[1e6, 0.0], [0.0, 1e6]]  # INDEFINITE + WIDE = [[1.01e6, 1.5e4], ...]: positive definite
GATES = {
    "ring": {"kind": "ring", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
    "expanded": {"kind": "expanded", "tau": 5.0, "v_max": 500.0},
    "combined": {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
    "ellipse": {"kind": "ellipse"},
    "rectangular": {"kind": "rectangular"},
    "sector": {"kind": "sector"},
    "first_association": {"kind": "first_association", "tau": 5.0, "v_max": 500.0},
}


def _plot(y: float, covariance: list[list[float]]) -> dict:
    return {"frame": "cartesian", "x": 0.0, "y": y, "covariance": covariance}


def _own_matrix(body: dict, field: str, matrix: list[list[float]]) -> None:
    """The reason for ``field`` prints ``matrix`` itself, not the sum with a partner."""
    [reason] = [e["reason"] for e in body["errors"] if e["field"] == field]
    assert str(matrix) in reason, reason
    assert "1010000.0" not in reason and "1000000.0" not in reason, reason


@pytest.mark.parametrize("kind", sorted(GATES))
@pytest.mark.parametrize(
    "cov", [INDEFINITE, ASYMMETRIC, THIN], ids=["indefinite", "asymmetric", "thin"]
)
def test_first_covariance_is_checked_before_the_sum(client, kind, cov):
    body = {
        "gate": GATES[kind],
        "first": _plot(50_000.0, cov),
        "candidates": [_plot(51_000.0, WIDE), _plot(50_010.0, WIDE)],
    }
    problem = invalid_input(client.post("/v1/gates/test", json=body), "first.covariance")
    _own_matrix(problem, "first.covariance", cov)


@pytest.mark.parametrize("kind", sorted(GATES))
def test_a_candidate_covariance_names_that_candidate(client, kind):
    body = {
        "gate": GATES[kind],
        "first": _plot(50_000.0, WIDE),
        "candidates": [
            _plot(51_000.0, WIDE),
            cartesian(0.0, 50_500.0),
            _plot(50_010.0, INDEFINITE),
            _plot(50_020.0, THIN),
        ],
    }
    problem = invalid_input(client.post("/v1/gates/test", json=body), "candidates[2].covariance")
    _own_matrix(problem, "candidates[2].covariance", INDEFINITE)
    assert [e["field"] for e in problem["errors"]] == ["candidates[2].covariance"]


@pytest.mark.parametrize("kind", sorted(GATES))
@pytest.mark.parametrize("side", ["first", "second"])
def test_a_pair_covariance_names_that_pair_and_side(client, kind, side):
    good = {"first": _plot(50_000.0, WIDE), "second": _plot(50_100.0, WIDE)}
    bad = dict(good, **{side: _plot(50_000.0, INDEFINITE)})
    body = {"gate": GATES[kind], "pairs": [good, good, good, bad, good]}
    field = f"pairs[3].{side}.covariance"
    problem = invalid_input(client.post("/v1/gates/pairs", json=body), field)
    _own_matrix(problem, field, INDEFINITE)


@pytest.mark.parametrize("kind", sorted(GATES))
def test_a_thin_polar_plot_is_named_with_its_sigmas(client, kind):
    # sigma_r 1 km against r sigma_az = 1e4 m x 1.7e-8 rad = 1.7e-4 m: axis ratio 5.7e6
    thin = polar(10_000.0, 45.0, sigma_r=1000.0, sigma_az_deg=1e-6)
    body = {
        "gate": GATES[kind],
        "first": polar(10_000.0, 40.0),
        "candidates": [polar(10_100.0, 45.0), polar(10_200.0, 45.0), thin],
    }
    problem = invalid_input(client.post("/v1/gates/test", json=body), "candidates[2]")
    [reason] = [e["reason"] for e in problem["errors"] if e["field"] == "candidates[2]"]
    assert "sigma_r = 1000 m" in reason and "sigma_az_deg = 1e-06" in reason, reason
    assert "axis ratio 5.73e+06" in reason, reason
    body = {"gate": GATES[kind], "first": thin, "candidates": [polar(10_100.0, 45.0)]}
    invalid_input(client.post("/v1/gates/test", json=body), "first")
    pair = {"first": polar(10_000.0, 40.0), "second": polar(10_100.0, 45.0)}
    body = {"gate": GATES[kind], "pairs": [pair, dict(pair, second=thin)]}
    invalid_input(client.post("/v1/gates/pairs", json=body), "pairs[1].second")


def test_a_polar_plot_within_the_bound_passes(client):
    # sigma_r 100 m against r sigma_az = 1e4 m x 1.7e-5 rad = 0.17 m: axis ratio 573
    ok = polar(10_000.0, 45.0, sigma_r=100.0, sigma_az_deg=1e-3)
    body = {"gate": GATES["ellipse"], "first": ok, "candidates": [ok]}
    assert client.post("/v1/gates/test", json=body).status_code == 200


def test_initiation_scans_name_the_plot_covariance(client):
    scans = [
        {"t": 0.0, "plots": [cartesian(1000.0, 2000.0)]},
        {
            "t": 1.0,
            "plots": [
                cartesian(1010.0, 2000.0),
                cartesian(5000.0, 5000.0),
                _plot(3000.0, INDEFINITE),
            ],
        },
    ]
    problem = invalid_input(
        client.post("/v1/initiation/initiate", json={"scans": scans}),
        "scans[1].plots[2].covariance",
    )
    _own_matrix(problem, "scans[1].plots[2].covariance", INDEFINITE)
    scans[1]["plots"][2] = polar(10_000.0, 45.0, sigma_r=1000.0, sigma_az_deg=1e-6)
    problem = invalid_input(
        client.post("/v1/initiation/initiate", json={"scans": scans}), "scans[1].plots[2]"
    )
    assert "sigma_az_deg = 1e-06" in problem["detail"]


MARK = {"r": 1000.0, "sigma_r": 1e4, "sigma_az_deg": 1e-6, "sigma_r2": 1.0, "sigma_az2_deg": 170.0}
"""The first mark's own ellipse: sigma_r 1e4 m against r sigma_az = 1.7e-5 m (axis ratio
5.7e8); the second's (1 m, 2967 m) makes B = P1 + P2 well conditioned (ratio 3.4)."""


def test_probability_marks_are_checked_on_their_own(client):
    body = {
        "gate": {"kind": "combined", "v_max": 500.0},
        "tau": 5.0,
        "mark": MARK,
        "velocity": {"speed": 100.0},
    }
    problem = invalid_input(client.post("/v1/gates/probability", json=body), "mark")
    assert "sigma_r = 10000 m and sigma_az_deg = 1e-06" in problem["detail"]
    second = dict(MARK, sigma_r=1.0, sigma_az_deg=170.0, sigma_r2=1e4, sigma_az2_deg=1e-6)
    problem = invalid_input(
        client.post("/v1/gates/probability", json=dict(body, mark=second)), "mark"
    )
    assert "sigma_r2 = 10000 m and sigma_az2_deg = 1e-06" in problem["detail"]


def test_probability_curve_against_range_names_the_value(client):
    # 1 mm against r x 1 deg: axis ratio 1.7e4 at 1 km, 3.5e4 at 2 km, 1.7e9 at 1e8 m
    mark = {"r": 1000.0, "sigma_r": 1e-3, "sigma_az_deg": 1.0}
    body = {
        "gate": {"kind": "combined", "v_max": 500.0},
        "tau": 5.0,
        "mark": mark,
        "against": "range",
        "values": [1000.0, 2000.0, 1e8],
        "speed": 100.0,
    }
    problem = invalid_input(client.post("/v1/gates/probability/curve", json=body), "values[2]")
    assert "at r = 1e+08 m" in problem["detail"]
