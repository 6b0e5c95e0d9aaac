"""Multistatic position solves, bounds and noise estimates over HTTP (Fadeev et al.).

Happy paths use noise-free range sums, so every answer must equal the truth within
1e-6 m; each is also checked against core called directly on the same arrays. Bad
input answers a problem+json naming the field; a geometry with no real solution is
answered (solvable false), not refused.
"""

import asyncio
import copy
import json

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient

from plotgate.clients import AsyncClient, InvalidInputError
from plotgate.clients.cli import main
from plotgate.clients.recordings import read_recording
from plotgate.clients.study import DEFAULT_REQUEST
from plotgate.core.multistatic import (
    crlb,
    difference_crlb,
    difference_range_solve,
    ml_solve,
    platform_positions,
    range_sum_jacobian,
    range_sum_noise,
    range_sums,
    smooth_positions,
    sum_range_solve,
    trajectory_crlb,
    trajectory_solve,
)
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.schemas import MAX_PROBLEMS
from plotgate.service.table import ENDPOINTS
from tests.support.requests import answer, assert_finite, invalid_input

SIGMA = 0.5
TRUTH = 1e-6  # m: noise-free answers equal the truth within this

TX2 = [0.0, 0.0]
RX2 = [[10000.0, 0.0], [0.0, 10000.0], [-8000.0, -6000.0]]
X2 = [[3000.0, 4000.0], [-5000.0, 2000.0], [12000.0, 9000.0], [500.0, -7000.0]]

TX3 = [0.0, 0.0, 0.0]
RX3 = [
    [10000.0, 0.0, 500.0],
    [0.0, 10000.0, -300.0],
    [-8000.0, -6000.0, 1000.0],
    [6000.0, -7000.0, -800.0],
]
X3 = [[3000.0, 4000.0, 2000.0], [-5000.0, 2000.0, -1500.0], [12000.0, 9000.0, 3000.0]]

GEOMETRIES = {"2d": (TX2, RX2, X2), "3d": (TX3, RX3, X3)}


def _sums(x, tx, rx) -> list[float]:
    return range_sums(x, tx, rx).tolist()


def _p(x, tx=TX2, rx=RX2, **changes) -> dict:
    """A noise-free problem of a target at x (a fresh copy: tests may edit it)."""
    return copy.deepcopy(
        {
            "range_sums": _sums(x, tx, rx),
            "transmitter": tx,
            "receivers": rx,
            "sigma": SIGMA,
            **changes,
        }
    )


def _position(*problems, **changes) -> dict:
    return {"problems": list(problems), **changes}


# --- solves.position -------------------------------------------------------------------


@pytest.mark.parametrize("geometry", ["2d", "3d"])
def test_position_ml_equals_truth_and_core(client, geometry):
    tx, rx, xs = GEOMETRIES[geometry]
    body = answer(client.post("/v1/solves/position", json=_position(*[_p(x, tx, rx) for x in xs])))
    assert body["method"] == "ml" and body["dimensions"] == len(tx)
    assert body["count_solvable"] == len(xs)
    expected = ml_solve(range_sums(xs, tx, rx), tx, rx, SIGMA)
    for i, (sol, x) in enumerate(zip(body["solutions"], xs, strict=True)):
        np.testing.assert_allclose(sol["position"], x, rtol=0, atol=TRUTH)
        np.testing.assert_allclose(sol["position"], expected.x[i], rtol=0, atol=1e-9)
        np.testing.assert_allclose(sol["covariance"], expected.covariance[i], rtol=1e-9)
        np.testing.assert_allclose(sol["residuals"], 0.0, atol=TRUTH)
        assert sol["cost"] == pytest.approx(expected.cost[i], abs=1e-12)
        assert sol["normalized_cost"] == pytest.approx(expected.normalized_cost[i], abs=1e-12)
        assert sol["iterations"] == expected.iterations[i]
        assert sol["consistent"] and sol["converged"] and sol["solvable"]
        assert sol["closed_form"] is None
        cov = np.array(sol["covariance"])
        assert cov.shape == (len(tx), len(tx)) and np.all(np.linalg.eigvalsh(cov) > 0)


@pytest.mark.parametrize("geometry", ["2d", "3d"])
@pytest.mark.parametrize("method", ["sum_range", "difference_range"])
def test_position_closed_forms(client, geometry, method):
    tx, rx, xs = GEOMETRIES[geometry]
    body = answer(
        client.post(
            "/v1/solves/position", json=_position(*[_p(x, tx, rx) for x in xs], method=method)
        )
    )
    assert body["method"] == method
    solve = sum_range_solve if method == "sum_range" else difference_range_solve
    l_ = range_sums(xs, tx, rx)
    expected = solve(l_, tx, rx, baseline_tol=5 * SIGMA)
    for i, (sol, x) in enumerate(zip(body["solutions"], xs, strict=True)):
        closed = sol["closed_form"]
        assert closed["method"] == method and closed["solvable"]
        np.testing.assert_allclose(closed["position"], x, rtol=0, atol=TRUTH)
        np.testing.assert_allclose(closed["position"], expected.x[i], rtol=0, atol=1e-9)
        assert closed["residual"] == pytest.approx(0.0, abs=TRUTH)
        assert (closed["alternative"] is None) == (not expected.has_alternative[i])
        np.testing.assert_allclose(sol["position"], x, rtol=0, atol=TRUTH)  # ML as well


def test_position_mixed_problems_keep_their_order(client):
    # P = 3 and P = 4 problems, several transmitters, per-measurement sigmas, a guess
    rx4 = [*RX2, [7000.0, -9000.0]]
    txs = [[0.0, 0.0], [0.0, 0.0], [2000.0, 3000.0], [2000.0, 3000.0]]
    sigmas = [0.5, 1.0, 0.7, 2.0]
    several = {
        "range_sums": range_sums(X2[1], txs, rx4).tolist(),
        "transmitters": txs,
        "receivers": rx4,
        "sigmas": sigmas,
    }
    guessed = _p(X2[2], initial=[X2[2][0] + 400.0, X2[2][1] - 300.0])
    problems = [_p(X2[0]), several, guessed, _p(X2[3], sigma=2.0)]
    body = answer(client.post("/v1/solves/position", json=_position(*problems)))
    for sol, x in zip(body["solutions"], [X2[0], X2[1], X2[2], X2[3]], strict=True):
        np.testing.assert_allclose(sol["position"], x, rtol=0, atol=TRUTH)
        assert sol["converged"] and sol["solvable"]
        assert len(sol["residuals"]) == (4 if sol is body["solutions"][1] else 3)
    expected = ml_solve(range_sums(X2[1], txs, rx4), txs, rx4, sigmas)
    np.testing.assert_allclose(
        body["solutions"][1]["covariance"], expected.covariance[0], rtol=1e-9
    )
    guess = ml_solve(
        range_sums(X2[2], TX2, RX2), TX2, RX2, SIGMA, x0=[X2[2][0] + 400.0, X2[2][1] - 300.0]
    )
    np.testing.assert_allclose(body["solutions"][2]["position"], guess.x[0], atol=1e-9)


def test_position_3d_from_an_initial_guess_matches_core(client):
    x = X3[0]
    start = [x[0] + 500.0, x[1] - 300.0, x[2] + 200.0]
    body = answer(
        client.post("/v1/solves/position", json=_position(_p(x, TX3, RX3, initial=start)))
    )
    expected = ml_solve(range_sums(x, TX3, RX3), TX3, RX3, SIGMA, x0=start)
    sol = body["solutions"][0]
    np.testing.assert_allclose(sol["position"], expected.x[0], rtol=0, atol=1e-9)
    assert sol["converged"] and sol["iterations"] == expected.iterations[0]
    np.testing.assert_allclose(sol["position"], x, rtol=0, atol=TRUTH)


def test_two_ellipse_intersections_give_an_alternative(client):
    # one transmitter, two receivers in 2D: two exact solutions
    problems = [_p(x, TX2, RX2[:2]) for x in X2]
    body = answer(
        client.post("/v1/solves/position", json=_position(*problems, method="sum_range"))
    )
    for sol, x in zip(body["solutions"], X2, strict=True):
        assert sol["alternative"] is not None and sol["solvable"] and sol["consistent"]
        found = [sol["position"], sol["alternative"]]
        assert min(np.abs(np.subtract(f, x)).max() for f in found) < TRUTH
        assert sol["closed_form"]["alternative"] is not None
        assert (
            min(
                np.abs(np.subtract(f, x)).max()
                for f in (sol["closed_form"]["position"], sol["closed_form"]["alternative"])
            )
            < TRUTH
        )


def test_no_real_solution_is_reported_not_refused(client):
    # the thin ellipse about the second baseline lies inside the wide first one
    nowhere = {
        "range_sums": [30000.0, 10001.0],
        "transmitter": TX2,
        "receivers": RX2[:2],
        "sigma": SIGMA,
    }
    for method in ("ml", "sum_range"):
        body = answer(
            client.post("/v1/solves/position", json=_position(_p(X2[0]), nowhere, method=method))
        )
        assert_finite(body)
        good, bad = body["solutions"]
        assert good["solvable"] and not bad["solvable"]
        assert body["count_solvable"] == 1
        assert bad["cost"] > 1e6  # the least-squares point misses by kilometres
        if method == "sum_range":
            assert not bad["closed_form"]["solvable"]
    # redundant data that fit no position: not consistent, not solvable
    off = _p(X2[0])
    off["range_sums"] = [
        s + d for s, d in zip(off["range_sums"], [0.0, 400.0, -300.0], strict=True)
    ]
    sol = answer(client.post("/v1/solves/position", json=_position(off)))["solutions"][0]
    assert not sol["solvable"] and not sol["consistent"]


def test_position_on_a_baseline_is_finite(client):
    # the target on the first baseline: that pair's gradient vanishes, P = D
    body = answer(
        client.post("/v1/solves/position", json=_position(_p([5000.0, 0.0], TX2, RX2[:2])))
    )
    assert_finite(body)


# --- solves.position from an initial guess at a baseline crossing ---------------------

TRAPPED = 10.0  # CRLB sigmas (Mahalanobis) from the truth: a false minimum (the study's bound)


def _study_crossing():
    """``plotgate study``'s default scenario at sample 112, the target on the central
    baseline: tx (2,), rx (3, 2), the target x (2,)."""
    req = DEFAULT_REQUEST
    t = req["sample_times"][112]
    tx = platform_positions(req["transmitter"]["position"], req["transmitter"]["velocity"], t)
    rx = np.array([platform_positions(r["position"], r["velocity"], t) for r in req["receivers"]])
    x = np.asarray(req["target"]["position"]) + t * np.asarray(req["target"]["velocity"])
    return tx, rx, x


def _problem(ls, tx, rx, **changes) -> dict:
    return {
        "range_sums": np.asarray(ls).tolist(),
        "transmitter": tx.tolist(),
        "receivers": rx.tolist(),
        "sigma": SIGMA,
        **changes,
    }


def test_initial_guesses_500_m_off_at_a_crossing_are_not_trapped(client):
    tx, rx, x = _study_crossing()
    assert np.linalg.norm(range_sum_jacobian(x, tx, rx)[1]) < 1e-12  # on baseline 2
    J = crlb(x, tx, rx, SIGMA).information[0]
    rng = np.random.default_rng(21)
    n = 500
    ls = range_sums(x, tx, rx) + SIGMA * rng.standard_normal((n, 3))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    starts = x + 500.0 * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    body = answer(
        client.post(
            "/v1/solves/position",
            json=_position(
                *[
                    _problem(l_, tx, rx, initial=s.tolist())
                    for l_, s in zip(ls, starts, strict=True)
                ]
            ),
        )
    )

    def sigmas(e):
        return np.sqrt(np.einsum("ni,ij,nj->n", e, J, e))

    got = np.array([s["position"] for s in body["solutions"]])
    assert (sigmas(got - x) <= TRAPPED).all()  # 0 of 500 trapped (measured: at most 3.4)
    assert all(s["converged"] and s["alternative"] is None for s in body["solutions"])
    # from the guess alone, as before, most would have ended at the transmitter
    alone = ml_solve(ls, tx, rx, SIGMA, x0=starts, closed_form_starts=False)
    assert (sigmas(alone.x - x) > TRAPPED).sum() > 250  # measured: 300
    # the operation is core's ml_solve with x0
    expected = ml_solve(ls, tx, rx, SIGMA, x0=starts)
    np.testing.assert_allclose(got, expected.x, rtol=0, atol=1e-9)
    assert [s["consistent"] for s in body["solutions"]] == expected.consistent.tolist()


def test_an_initial_guess_picks_one_of_two_exact_solutions(client):
    # P = D: the outer pairs at the crossing; their ellipses meet at the target and near
    # the transmitter, the root the closed form ranks first
    tx, rx, x = _study_crossing()
    outer = rx[[0, 2]]
    problem = _problem(range_sums(x, tx, outer), tx, outer)
    body = answer(
        client.post(
            "/v1/solves/position",
            json=_position(problem, dict(problem, initial=x.tolist()), method="sum_range"),
        )
    )
    plain, guessed = body["solutions"]
    closed = guessed["closed_form"]
    far = closed["position"]
    assert np.linalg.norm(np.subtract(far, x)) > 4000.0  # measured: 4851 m
    np.testing.assert_allclose(closed["alternative"], x, rtol=0, atol=TRUTH)
    # the guess at the target: the target, and the other root as the alternative
    np.testing.assert_allclose(guessed["position"], x, rtol=0, atol=TRUTH)
    np.testing.assert_allclose(guessed["alternative"], far, rtol=0, atol=TRUTH)
    assert guessed["consistent"] and guessed["solvable"] and guessed["converged"]
    # no guess: the closed form's ranking, the target second
    np.testing.assert_allclose(plain["position"], far, rtol=0, atol=TRUTH)
    np.testing.assert_allclose(plain["alternative"], x, rtol=0, atol=TRUTH)


# --- solves.trajectory -----------------------------------------------------------------

T = 1000.0 + np.arange(12) * 0.5
TRACK = ([3000.0, 4000.0], [0.0, 80.0])
RX_V2 = [[0.0, 10.0], [10.0, 0.0], [-10.0, 0.0]]
TX_V2 = [10.0, 0.0]


def _track_truth(t, x0, v):
    return np.asarray(x0) + np.multiply.outer(np.asarray(t) - t[0], v)


def _trajectory_body(**changes) -> dict:
    tau = T - T[0]
    tx = platform_positions(TX2, TX_V2, tau)
    rx = platform_positions(RX2, RX_V2, tau)
    x = _track_truth(T, *TRACK)
    body = {
        "sample_times": T.tolist(),
        "range_sums": range_sums(x, tx[:, None, :], rx).tolist(),
        "transmitter": {"position": TX2, "velocity": TX_V2},
        "receivers": [{"position": p, "velocity": v} for p, v in zip(RX2, RX_V2, strict=True)],
        "sigma": SIGMA,
        "times": [T[0], 1004.25, 1100.0],
    }
    return copy.deepcopy({**body, **changes})


def test_trajectory_moving_platforms_2d(client):
    body = answer(client.post("/v1/solves/trajectory", json=_trajectory_body()))
    assert body["t_ref"] == T[0]
    np.testing.assert_allclose(body["state"]["position"], TRACK[0], atol=TRUTH)
    np.testing.assert_allclose(body["state"]["velocity"], TRACK[1], atol=TRUTH)
    assert body["consistent"] and body["converged"]
    times = [T[0], 1004.25, 1100.0]
    assert body["times"] == times
    np.testing.assert_allclose(
        body["positions"], _track_truth(np.array(times), *TRACK), atol=TRUTH
    )
    # against core on the same arrays
    tau = T - T[0]
    tx = platform_positions(TX2, TX_V2, tau)[:, None, :].repeat(3, axis=1)
    rx = platform_positions(RX2, RX_V2, tau)
    sol = trajectory_solve(range_sums(_track_truth(T, *TRACK), tx, rx), T, tx, rx, SIGMA)
    np.testing.assert_allclose(body["covariance"], sol.covariance, rtol=1e-9)
    positions, covariances = sol.at(times)
    np.testing.assert_allclose(body["positions"], positions, atol=1e-9)
    np.testing.assert_allclose(body["covariances"], covariances, rtol=1e-9)
    assert body["cost"] == pytest.approx(sol.cost, abs=1e-12)
    assert np.shape(body["residuals"]) == (T.size, 3)
    # the covariance grows away from the samples
    assert np.trace(body["covariances"][2]) > np.trace(body["covariances"][1])


def test_trajectory_fit_outside_the_request_bounds_is_answered(client):
    # one range sum of 1e10 m among sums of ~1e4 m: the fit lands beyond the 1e9 m and
    # 1e6 m/s a request's TargetState allows; it is finite, answered (not consistent),
    # and equals core's (it used to fail the answer's validation: a 500)
    example = ENDPOINTS["solves.trajectory"].example
    example["range_sums"][0][0] = 1e10
    body = answer(client.post("/v1/solves/trajectory", json=example))
    assert_finite(body)
    assert not body["consistent"]
    assert (
        max(
            np.abs(body["state"]["position"]).max() / 1e9,
            np.abs(body["state"]["velocity"]).max() / 1e6,
        )
        > 1.0
    )
    t = np.array(example["sample_times"])
    sol = trajectory_solve(
        np.array(example["range_sums"]),
        t,
        [0.0, 0.0],
        [r["position"] for r in example["receivers"]],
        0.5,
    )
    np.testing.assert_allclose(body["state"]["position"], sol.position, rtol=1e-9)


def test_trajectory_per_sample_platforms_3d(client):
    t = np.arange(8.0)
    x0, v = [3000.0, 4000.0, 2000.0], [50.0, 60.0, -5.0]
    rx = platform_positions(RX3, [[0.0, 10.0, 0.0]] * 4, t)  # (T, P, D)
    txs = platform_positions(TX3, [10.0, 0.0, 1.0], t)  # (T, D)
    x = _track_truth(t, x0, v)
    body = {
        "sample_times": t.tolist(),
        "range_sums": range_sums(x, txs[:, None, :], rx).tolist(),
        "transmitters": [{"positions": txs.tolist()}] * 4,
        "receivers": [{"positions": rx[:, k].tolist()} for k in range(4)],
        "sigmas": [0.5, 0.5, 1.0, 1.0],
        "initial": {"position": [3300.0, 3800.0, 2100.0], "velocity": [0.0, 0.0, 0.0]},
    }
    out = answer(client.post("/v1/solves/trajectory", json=body))
    np.testing.assert_allclose(out["state"]["position"], x0, atol=TRUTH)
    np.testing.assert_allclose(out["state"]["velocity"], v, atol=TRUTH)
    assert out["times"] == t.tolist()  # default: the sample times
    np.testing.assert_allclose(out["positions"], x, atol=TRUTH)
    assert np.shape(out["covariances"]) == (8, 3, 3)


# --- solves.crlb -----------------------------------------------------------------------


def _crlb_body(**changes) -> dict:
    return copy.deepcopy(
        {
            "targets": X2,
            "transmitter": {"position": TX2},
            "receivers": [{"position": p} for p in RX2],
            "sigma": SIGMA,
            **changes,
        }
    )


@pytest.mark.parametrize("measurements", ["sum", "difference"])
def test_crlb_targets_match_core(client, measurements):
    body = answer(
        client.post(
            "/v1/solves/crlb",
            json=_crlb_body(measurements=measurements, sigma=None, sigmas=[0.5, 1.0, 0.7]),
        )
    )
    bound = (crlb if measurements == "sum" else difference_crlb)(X2, TX2, RX2, [0.5, 1.0, 0.7])
    single = body["single_shot"]
    np.testing.assert_allclose(single["sigma"], bound.sigma, rtol=1e-12)
    np.testing.assert_allclose(single["gdop"], bound.gdop, rtol=1e-12)
    np.testing.assert_allclose(single["covariance"], bound.covariance, rtol=1e-12)
    np.testing.assert_allclose(single["sigma_ref"], bound.sigma_ref, rtol=1e-12)
    assert body["positions"] == X2 and body["accumulated"] is None


def test_crlb_difference_is_never_below_sum(client):
    s = answer(client.post("/v1/solves/crlb", json=_crlb_body()))["single_shot"]
    d = answer(client.post("/v1/solves/crlb", json=_crlb_body(measurements="difference")))[
        "single_shot"
    ]
    assert np.all(np.array(d["sigma"]) >= np.array(s["sigma"]) - 1e-12)


@pytest.mark.parametrize("measurements", ["sum", "difference"])
def test_crlb_track_accumulates(client, measurements):
    body = answer(
        client.post(
            "/v1/solves/crlb",
            json={
                "measurements": measurements,
                "track": {"position": TRACK[0], "velocity": TRACK[1]},
                "sample_times": T.tolist(),
                "transmitter": {"position": TX2, "velocity": TX_V2},
                "receivers": [
                    {"position": p, "velocity": v} for p, v in zip(RX2, RX_V2, strict=True)
                ],
                "sigma": SIGMA,
            },
        )
    )
    tau = T - T[0]
    tx = platform_positions(TX2, TX_V2, tau)[:, None, :]
    rx = platform_positions(RX2, RX_V2, tau)
    x = _track_truth(T, *TRACK)
    np.testing.assert_allclose(body["positions"], x, atol=1e-9)
    single = (crlb if measurements == "sum" else difference_crlb)(x, tx, rx, SIGMA)
    np.testing.assert_allclose(body["single_shot"]["sigma"], single.sigma, rtol=1e-12)
    acc = trajectory_crlb(*TRACK, T, tx, rx, SIGMA, measurements=measurements)
    out = body["accumulated"]
    assert out["t_ref"] == T[0] and out["sigma_ref"] == pytest.approx(SIGMA)
    np.testing.assert_allclose(out["state_covariance"], acc.covariance, rtol=1e-12)
    np.testing.assert_allclose(out["sigma"], acc.position_sigma, rtol=1e-12)
    np.testing.assert_allclose(out["gdop"], acc.gdop, rtol=1e-12)
    # accumulating twelve samples beats one
    assert np.all(np.array(out["sigma"]) < np.array(body["single_shot"]["sigma"]))


def test_crlb_targets_with_moving_platforms_3d(client):
    times = [0.0, 5.0, 10.0]
    body = answer(
        client.post(
            "/v1/solves/crlb",
            json={
                "targets": X3,
                "sample_times": times,
                "transmitter": {"position": TX3, "velocity": [10.0, 0.0, 0.0]},
                "receivers": [{"position": p} for p in RX3],
                "sigma": SIGMA,
            },
        )
    )
    tx = platform_positions(TX3, [10.0, 0.0, 0.0], times)[:, None, :]
    bound = crlb(X3, tx, RX3, SIGMA)
    np.testing.assert_allclose(body["single_shot"]["sigma"], bound.sigma, rtol=1e-12)
    assert np.shape(body["single_shot"]["covariance"]) == (3, 3, 3)


def test_crlb_per_target_platforms_need_no_times(client):
    rx0 = [[10000.0 + 100.0 * i, 50.0 * i] for i in range(len(X2))]
    body = answer(
        client.post(
            "/v1/solves/crlb",
            json=_crlb_body(
                receivers=[{"positions": rx0}, {"position": RX2[1]}, {"position": RX2[2]}]
            ),
        )
    )
    rx = np.array([[r, RX2[1], RX2[2]] for r in rx0])
    bound = crlb(X2, TX2, rx, SIGMA)
    np.testing.assert_allclose(body["single_shot"]["covariance"], bound.covariance, rtol=1e-12)


# --- solves.noise ----------------------------------------------------------------------


def test_noise_matches_core_and_is_zero_on_quadratics(client):
    t = np.linspace(100.0, 110.0, 21)
    s = t - 100.0
    series = np.stack(
        [12000.0 + 50.0 * s + 2.0 * s**2, 20000.0 - 30.0 * s, 15000.0 + 0.5 * s**2], axis=1
    )
    rng = np.random.default_rng(7)
    noisy = series + rng.normal(0.0, [0.5, 1.0, 2.0], series.shape)
    x = np.stack([3000.0 + 80.0 * s, 4000.0 - 20.0 * s], axis=1)
    noisy_x = x + rng.normal(0.0, 5.0, x.shape)
    body = answer(
        client.post(
            "/v1/solves/noise",
            json={
                "sample_times": t.tolist(),
                "range_sums": noisy.tolist(),
                "positions": noisy_x.tolist(),
                "window": 7,
            },
        )
    )
    est = range_sum_noise(t, noisy)
    np.testing.assert_allclose(body["sigma"], est.sigma, rtol=1e-12)
    np.testing.assert_allclose(body["variance"], est.variance, rtol=1e-12)
    np.testing.assert_allclose(body["smoothed_range_sums"], est.smoothed, rtol=1e-12)
    assert body["dof"] == 18
    assert 0.2 < body["sigma"][0] < 1.0 and 1.0 < body["sigma"][2] < 3.5
    np.testing.assert_allclose(
        body["smoothed_positions"], smooth_positions(t, noisy_x, 7), rtol=1e-12
    )
    # smoothing removes most of the 5 m noise
    assert np.std(np.subtract(body["smoothed_positions"], x)) < 3.0
    # noise-free: the quadratic fits exactly and a straight track is reproduced
    clean = answer(
        client.post(
            "/v1/solves/noise",
            json={
                "sample_times": t.tolist(),
                "range_sums": series.tolist(),
                "positions": x.tolist(),
                "window": 5,
                "smoothing_degree": 1,
            },
        )
    )
    np.testing.assert_allclose(clean["sigma"], 0.0, atol=TRUTH)
    np.testing.assert_allclose(clean["smoothed_range_sums"], series, atol=TRUTH)
    np.testing.assert_allclose(clean["smoothed_positions"], x, atol=TRUTH)


def test_noise_smoothing_only_matches_core(client):
    t = np.arange(15.0)
    x = np.random.default_rng(3).normal(0.0, 10.0, (15, 3)) + 1000.0
    body = answer(
        client.post(
            "/v1/solves/noise",
            json={"sample_times": t.tolist(), "positions": x.tolist(), "window": 9},
        )
    )
    assert body["sigma"] is None and body["smoothed_range_sums"] is None
    np.testing.assert_allclose(body["smoothed_positions"], smooth_positions(t, x, 9), rtol=1e-12)


# --- bad input -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("problem", "field"),
    [
        (_p(X2[0], TX2, RX2[:1]), "problems[1].range_sums"),
        (_p(X3[0], TX3, RX3[:2]), "problems[1].range_sums"),
    ],
    ids=["2d-one-pair", "3d-two-pairs"],
)
def test_fewer_measurements_than_unknowns(client, problem, field):
    first = _p(X3[0], TX3, RX3) if len(problem["transmitter"]) == 3 else _p(X2[0])
    body = invalid_input(client.post("/v1/solves/position", json=_position(first, problem)), field)
    assert "unknowns" in body["detail"]


def test_fewer_measurements_than_unknowns_elsewhere(client):
    # the difference-range method needs D + 1 pairs
    r = client.post(
        "/v1/solves/position", json=_position(_p(X2[0], TX2, RX2[:2]), method="difference_range")
    )
    invalid_input(r, "problems[0].range_sums")
    one = _trajectory_body()
    one.update(range_sums=[row[:1] for row in one["range_sums"]], receivers=one["receivers"][:1])
    invalid_input(client.post("/v1/solves/trajectory", json=one), "range_sums")
    invalid_input(
        client.post("/v1/solves/crlb", json=_crlb_body(receivers=[{"position": RX2[0]}])),
        "receivers",
    )


def test_coincident_platforms(client):
    at_tx = _p(X2[0], TX2, [TX2, RX2[1], RX2[2]])
    body = invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[1]), at_tx)),
        "problems[1].receivers",
    )
    assert "coincides" in body["detail"]
    twice = _p(X2[0], TX2, [RX2[0], RX2[0], RX2[2]])
    invalid_input(
        client.post("/v1/solves/position", json=_position(twice)), "problems[0].receivers"
    )
    # a moving receiver that reaches the transmitter at sample 4 (t = 1002 s)
    meet = _trajectory_body()
    meet["receivers"][0] = {
        "positions": [[10.0 * k * 0.5 if k != 4 else 20.0, 5.0 * (k != 4)] for k in range(T.size)]
    }
    body = invalid_input(client.post("/v1/solves/trajectory", json=meet), "receivers")
    assert "sample 4" in body["detail"]
    invalid_input(
        client.post(
            "/v1/solves/crlb",
            json=_crlb_body(
                receivers=[{"position": TX2}, {"position": RX2[1]}, {"position": RX2[2]}]
            ),
        ),
        "receivers",
    )


@pytest.mark.parametrize("value", [-1.0, -1e-9])
def test_negative_range_sum(client, value):
    bad = _p(X2[0])
    bad["range_sums"][1] = value
    invalid_input(
        client.post("/v1/solves/position", json=_position(bad)), "problems[0].range_sums[1]"
    )
    track = _trajectory_body()
    track["range_sums"][3][2] = value
    invalid_input(client.post("/v1/solves/trajectory", json=track), "range_sums[3][2]")


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
@pytest.mark.parametrize(
    ("path", "body", "marker", "field"),
    [
        (
            "/v1/solves/position",
            _position(_p(X2[0], rx=[[10000.0, 0.0], [0.0, 1234.5], [-8000.0, -6000.0]])),
            "1234.5",
            "problems[0].receivers[1][1]",
        ),
        ("/v1/solves/position", _position(_p(X2[0], sigma=1234.5)), "1234.5", "problems[0].sigma"),
        ("/v1/solves/trajectory", _trajectory_body(times=[1234.5]), "1234.5", "times[0]"),
        ("/v1/solves/crlb", _crlb_body(targets=[[1234.5, 0.0]]), "1234.5", "targets[0][0]"),
        (
            "/v1/solves/noise",
            {"sample_times": [0.0, 1.0, 2.0, 3.0], "range_sums": [[1e4], [1234.5], [1e4], [1e4]]},
            "1234.5",
            "range_sums[1][0]",
        ),
    ],
    ids=["receiver", "sigma", "times", "target", "noise-series"],
)
def test_non_finite_numbers(client, token, path, body, marker, field):
    text = json.dumps(body).replace(marker, token, 1)
    r = client.post(path, content=text.encode(), headers={"content-type": "application/json"})
    invalid_input(r, field)


def test_non_finite_range_sum(client):
    body = _position(_p(X2[0]))
    body["problems"][0]["range_sums"][2] = 1234.5
    for token in ("NaN", "Infinity"):
        text = json.dumps(body).replace("1234.5", token)
        r = client.post(
            "/v1/solves/position",
            content=text.encode(),
            headers={"content-type": "application/json"},
        )
        invalid_input(r, "problems[0].range_sums[2]")


def test_range_sum_shorter_than_its_baseline(client):
    short = _p(X2[0])
    short["range_sums"][0] = 9000.0  # baseline |tx - rx_0| = 10 km
    body = invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[1]), _p(X2[2]), short)),
        "problems[2].range_sums",
    )
    assert "baseline" in body["detail"]
    track = _trajectory_body()
    track["range_sums"][5][0] = 5000.0
    invalid_input(client.post("/v1/solves/trajectory", json=track), "range_sums[5]")
    # within a few sigma of the baseline is noise, not an error
    near = _p(X2[0])
    near["range_sums"][0] = 10000.0 - 2 * SIGMA
    answer(client.post("/v1/solves/position", json=_position(near)))


def test_zero_sigma(client):
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0], sigma=0.0))),
        "problems[0].sigma",
    )
    invalid_input(
        client.post(
            "/v1/solves/position", json=_position(_p(X2[0], sigma=None, sigmas=[0.5, 0.0, 0.5]))
        ),
        "problems[0].sigmas[1]",
    )
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0], sigma=-1.0))),
        "problems[0].sigma",
    )
    invalid_input(client.post("/v1/solves/trajectory", json=_trajectory_body(sigma=0.0)), "sigma")
    invalid_input(
        client.post("/v1/solves/crlb", json=_crlb_body(sigma=None, sigmas=[1, 0, 1])), "sigmas[1]"
    )


def test_mixed_2d_and_3d(client):
    # the request's dimension is that of most of its vectors; the odd one is named
    body = invalid_input(
        client.post(
            "/v1/solves/position", json=_position(_p(X2[0]), _p(X3[0], TX3, RX3), _p(X2[1]))
        ),
        "problems[1].transmitter",
    )
    assert "2D" in body["detail"]
    within = _p(X2[0])
    within["receivers"][2] = [-8000.0, -6000.0, 0.0]
    invalid_input(
        client.post("/v1/solves/position", json=_position(within)), "problems[0].receivers[2]"
    )
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0], initial=[1.0, 2.0, 3.0]))),
        "problems[0].initial",
    )
    track = _trajectory_body()
    track["receivers"][1]["velocity"] = [10.0, 0.0, 0.0]
    invalid_input(client.post("/v1/solves/trajectory", json=track), "receivers[1].velocity")
    invalid_input(
        client.post("/v1/solves/crlb", json=_crlb_body(targets=[[1.0, 2.0, 3.0]])), "targets[0]"
    )
    invalid_input(
        client.post(
            "/v1/solves/noise",
            json={
                "sample_times": [0.0, 1.0, 2.0],
                "positions": [[0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0]],
                "window": 3,
            },
        ),
        "positions[1]",
    )


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"transmitter": None}, "transmitter"),
        ({"transmitters": [TX2] * 3}, "transmitters"),
        ({"sigma": None}, "sigma"),
        ({"sigmas": [0.5] * 3}, "sigmas"),
        ({"receivers": RX2[:2]}, "receivers"),
        ({"transmitter": None, "transmitters": [TX2] * 2}, "transmitters"),
        ({"sigma": None, "sigmas": [0.5] * 4}, "sigmas"),
        ({"receivers": [[0.0, 0.0], [2e9, 0.0], [1.0, 1.0]]}, "receivers[1][0]"),
        ({"receivers": [[0.0], [1.0, 0.0], [1.0, 1.0]]}, "receivers[0]"),
        ({"range_sums": [1e11, 1e4, 1e4]}, "range_sums[0]"),
        ({"unknown": 1}, "unknown"),
    ],
    ids=[
        "no-transmitter",
        "both-transmitters",
        "no-sigma",
        "both-sigmas",
        "short-receivers",
        "short-transmitters",
        "long-sigmas",
        "far-receiver",
        "1d-receiver",
        "huge-sum",
        "unknown-field",
    ],
)
def test_position_problem_rules(client, changes, field):
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0], **changes))),
        f"problems[0].{field}",
    )


def test_position_request_rules(client):
    invalid_input(client.post("/v1/solves/position", json=_position()), "problems")
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0]), method="chan")), "method"
    )
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0]), alpha=0.0)), "alpha"
    )
    invalid_input(
        client.post("/v1/solves/position", json=_position(_p(X2[0]), max_iter=0)), "max_iter"
    )
    many = [_p(X2[0])] * (MAX_PROBLEMS + 1)
    invalid_input(client.post("/v1/solves/position", json=_position(*many)), "problems")
    # the closed forms need one transmitter per problem
    txs = [[0.0, 0.0], [0.0, 0.0], [100.0, 0.0]]
    several = {
        "range_sums": range_sums(X2[0], txs, RX2).tolist(),
        "transmitters": txs,
        "receivers": RX2,
        "sigma": SIGMA,
    }
    body = answer(client.post("/v1/solves/position", json=_position(several)))
    np.testing.assert_allclose(body["solutions"][0]["position"], X2[0], atol=TRUTH)
    invalid_input(
        client.post("/v1/solves/position", json=_position(several, method="sum_range")),
        "problems[0].transmitters",
    )


def test_trajectory_rules(client):
    body = _trajectory_body()
    invalid_input(
        client.post("/v1/solves/trajectory", json=dict(body, range_sums=body["range_sums"][:-1])),
        "range_sums",
    )
    rows = [list(r) for r in body["range_sums"]]
    rows[2] = rows[2][:2]
    invalid_input(
        client.post("/v1/solves/trajectory", json=dict(body, range_sums=rows)), "range_sums[2]"
    )
    invalid_input(
        client.post("/v1/solves/trajectory", json=dict(body, sample_times=[1000.0] * T.size)),
        "sample_times",
    )
    platform = {"positions": [[1.0, 2.0]] * 3}
    invalid_input(
        client.post(
            "/v1/solves/trajectory", json=dict(body, receivers=[platform, *body["receivers"][1:]])
        ),
        "receivers[0].positions",
    )
    invalid_input(
        client.post(
            "/v1/solves/trajectory",
            json=dict(body, transmitter={"position": TX2, "positions": [TX2] * T.size}),
        ),
        "transmitter.position",
    )
    invalid_input(
        client.post(
            "/v1/solves/trajectory",
            json=dict(body, initial={"position": [0.0, 0.0], "velocity": [0.0, 0.0, 0.0]}),
        ),
        "initial.velocity",
    )
    invalid_input(
        client.post("/v1/solves/trajectory", json=dict(body, sigma=None, sigmas=[0.5, 0.5])),
        "sigmas",
    )


def test_crlb_rules(client):
    invalid_input(
        client.post(
            "/v1/solves/crlb",
            json=_crlb_body(track={"position": [0.0, 0.0], "velocity": [1.0, 0.0]}),
        ),
        "track",
    )
    track = {"position": TRACK[0], "velocity": TRACK[1]}
    invalid_input(
        client.post("/v1/solves/crlb", json=_crlb_body(targets=None, track=track)), "sample_times"
    )
    moving = _crlb_body(
        receivers=[
            {"position": RX2[0], "velocity": [1.0, 0.0]},
            {"position": RX2[1]},
            {"position": RX2[2]},
        ]
    )
    invalid_input(client.post("/v1/solves/crlb", json=moving), "receivers[0].velocity")
    per_target = _crlb_body(
        receivers=[{"positions": [RX2[0]] * 3}, {"position": RX2[1]}, {"position": RX2[2]}]
    )
    invalid_input(client.post("/v1/solves/crlb", json=per_target), "receivers[0].positions")
    invalid_input(
        client.post("/v1/solves/crlb", json=_crlb_body(sample_times=[0.0])), "sample_times"
    )
    body = invalid_input(
        client.post("/v1/solves/crlb", json=_crlb_body(targets=[X2[0], RX2[1]])), "targets[1]"
    )
    assert "platform" in body["detail"]


def test_noise_rules(client):
    base = {"sample_times": [0.0, 1.0, 2.0, 3.0, 4.0], "range_sums": [[1e4]] * 5}
    invalid_input(
        client.post("/v1/solves/noise", json=dict(base, sample_times=[0.0, 1.0, 1.0, 3.0, 4.0])),
        "sample_times[2]",
    )
    invalid_input(client.post("/v1/solves/noise", json=dict(base, degree=4)), "sample_times")
    invalid_input(client.post("/v1/solves/noise", json={"sample_times": [0.0]}), "range_sums")
    positions = [[0.0, 0.0]] * 5
    invalid_input(client.post("/v1/solves/noise", json=dict(base, positions=positions)), "window")
    invalid_input(
        client.post("/v1/solves/noise", json=dict(base, positions=positions, window=6)), "window"
    )
    invalid_input(
        client.post("/v1/solves/noise", json=dict(base, positions=positions, window=2)), "window"
    )
    invalid_input(client.post("/v1/solves/noise", json=dict(base, window=3)), "window")
    invalid_input(
        client.post("/v1/solves/noise", json=dict(base, range_sums=[[1e4]] * 4)), "range_sums"
    )


# --- the wire contract -----------------------------------------------------------------


def test_every_field_is_described():
    for name in ("solves.position", "solves.trajectory", "solves.crlb", "solves.noise"):
        endpoint = ENDPOINTS[name]
        assert endpoint.slow  # each takes well over 50 ms at its size limits
        for model in (endpoint.request, endpoint.response):
            schema = model.model_json_schema()
            for sub in (schema, *schema.get("$defs", {}).values()):
                for field, prop in sub.get("properties", {}).items():
                    assert prop.get("description"), f"{sub['title']}.{field}: no description"


def test_client_methods(tmp_path):
    asyncio.run(_client_calls(create_app(Settings(log_dir=tmp_path, record=False))))


async def _client_calls(app) -> None:
    transport = httpx.ASGITransport(app=app)
    async with AsyncClient("http://plotgate", transport=transport) as client:
        result = await client.solve_position(_position(_p(X2[0]), method="sum_range"))
        assert result.solutions[0].position == pytest.approx(X2[0], abs=TRUTH)
        # P = D from a guess near the target: the target, the mirror root as alternative
        two = _p(X2[0], TX2, RX2[:2], initial=[X2[0][0] + 50.0, X2[0][1] - 50.0])
        guessed = (await client.solve_position(_position(two))).solutions[0]
        assert guessed.position == pytest.approx(X2[0], abs=TRUTH)
        assert guessed.alternative is not None
        assert np.linalg.norm(np.subtract(guessed.alternative, X2[0])) > 1000.0
        assert range_sums(guessed.alternative, TX2, RX2[:2]) == pytest.approx(
            two["range_sums"], abs=TRUTH
        )
        track = await client.solve_trajectory(_trajectory_body())
        assert track.state.velocity == pytest.approx(TRACK[1], abs=TRUTH)
        bound = await client.crlb(_crlb_body())
        assert len(bound.single_shot.gdop) == len(X2)
        est = await client.estimate_noise(
            {"sample_times": [0.0, 1.0, 2.0, 3.0], "range_sums": [[1.0], [2.0], [4.0], [7.0]]}
        )
        assert est.sigma == pytest.approx([0.0], abs=1e-9)
        with pytest.raises(InvalidInputError) as err:
            await client.solve_position(_position(_p(X2[0], TX2, RX2[:1])))
        assert err.value.problem.errors[0].field == "problems[0].range_sums"


# --- recording and replay --------------------------------------------------------------

SESSION = [
    ("position", "/v1/solves/position", _position(*[_p(x) for x in X2], method="sum_range")),
    (
        "position-3d",
        "/v1/solves/position",
        _position(*[_p(x, TX3, RX3) for x in X3], method="difference_range"),
    ),
    (
        "nowhere",
        "/v1/solves/position",
        _position(
            {
                "range_sums": [30000.0, 10001.0],
                "transmitter": TX2,
                "receivers": RX2[:2],
                "sigma": SIGMA,
            }
        ),
    ),
    ("trajectory", "/v1/solves/trajectory", _trajectory_body()),
    ("crlb", "/v1/solves/crlb", _crlb_body(measurements="difference")),
    (
        "crlb-track",
        "/v1/solves/crlb",
        {
            "track": {"position": TRACK[0], "velocity": TRACK[1]},
            "sample_times": T.tolist(),
            "transmitter": {"position": TX2},
            "receivers": [{"position": p} for p in RX2],
            "sigma": SIGMA,
        },
    ),
    (
        "noise",
        "/v1/solves/noise",
        {
            "sample_times": [0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
            "range_sums": [
                [1e4, 2e4],
                [1e4 + 1, 2e4],
                [1e4 + 3, 2e4 + 0.5],
                [1e4 + 6, 2e4],
                [1e4 + 10, 2e4 - 0.5],
                [1e4 + 15.5, 2e4],
            ],
            "positions": [
                [0.0, 0.0],
                [80.0, 1.0],
                [160.0, -1.0],
                [240.0, 0.5],
                [320.0, 0.0],
                [400.0, 0.2],
            ],
            "window": 4,
        },
    ),
    ("bad", "/v1/solves/position", _position(_p(X2[0], TX2, [TX2, RX2[1], RX2[2]]))),
]


def test_session_is_recorded_and_replays(settings, tmp_path, capsys):
    with TestClient(create_app(settings)) as c:
        statuses = {
            rid: c.post(path, json=body, headers={"x-request-id": rid}).status_code
            for rid, path, body in SESSION
        }
    assert statuses == {rid: (422 if rid == "bad" else 200) for rid, _, _ in SESSION}
    [path] = sorted(settings.log_dir.glob("*.mcap"))
    ops = {e.request_id: e.operation for e in read_recording(path).exchanges}
    assert ops == {rid: "solves." + p.split("/")[3] for rid, p, _ in SESSION}

    report = tmp_path / "report.json"
    assert main(["replay", str(path), "--report", str(report)]) == 0
    summary = json.loads(report.read_text())
    assert summary["compared"] == summary["unchanged"] == len(SESSION)
    capsys.readouterr()
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    for op in ("solves.position", "solves.trajectory", "solves.crlb", "solves.noise"):
        assert op in out


def test_a_non_finite_answer_is_a_bug_not_bad_input(client, monkeypatch):
    # JSON cannot carry NaN: were core ever to return one, the answer is a 500, not a 422
    import plotgate.service.operations.solves as solves

    def nan_noise(t, l_, degree):
        est = range_sum_noise(t, l_, degree)
        return type(est)(est.sigma * np.nan, est.variance, est.smoothed, est.residuals, est.dof)

    monkeypatch.setattr(solves.ms, "range_sum_noise", nan_noise)
    r = client.post(
        "/v1/solves/noise",
        json={"sample_times": [0.0, 1.0, 2.0, 3.0], "range_sums": [[1.0], [2.0], [4.0], [7.0]]},
    )
    assert r.status_code == 500 and r.json()["type"] == "urn:plotgate:problem:internal"

    def nan_solve(*args, **kwargs):
        sol = ml_solve(*args, **kwargs)
        return type(sol)(**{**sol.__dict__, "x": sol.x * np.nan})

    monkeypatch.setattr(solves.ms, "ml_solve", nan_solve)
    r = client.post("/v1/solves/position", json=_position(_p(X2[0])))
    assert r.status_code == 500 and r.json()["type"] == "urn:plotgate:problem:internal"
